"""The campaign loop end to end on a simulated laboratory (``gj.run_campaign``, ``gyrojax campaign --simulate``).

The lab's first test is simulated from the truth; then, step after step, :func:`gyrojax.adaptive.step.next_test`
diagnoses every record so far, adds what the data ask for and designs the next test on the lab's table, which is
simulated from the same truth on the campaign's clock (test k draws its noise from ``fold_in(key(seed), k)``) and
fitted jointly with everything before, until the goal is met, refused as unreachable, blocked, or ``max_tests`` tests
have run. A hand-held triad's campaign (:func:`run_hand_campaign`) runs the same loop on sessions a person makes.
Its table hours are compared with Hu's classical sequence scaled to reach the same σ on the same truth
(:mod:`gyrojax.adaptive.classical`; a triad's sessions with its first session repeated), and with the fewest table
hours any campaign from the same first test needs to meet the requirements of the loop's last look
(:mod:`gyrojax.adaptive.bound`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import jax
import numpy as np

from gyrojax.adaptive import requirements as rq
from gyrojax.adaptive.bound import table_hours_bound
from gyrojax.adaptive.classical import ClassicalResult, classical_hours, hand_classical_hours
from gyrojax.adaptive.goal import Goal
from gyrojax.adaptive.hand import HandLab
from gyrojax.adaptive.lab import Lab
from gyrojax.adaptive.step import NextTest, next_test
from gyrojax.data.truth import TriadTruth, Truth, truth_from_dict
from gyrojax.errors import ModelError
from gyrojax.planning.triad_protocol import session_seconds
from gyrojax.simulation.simulator import simulate
from gyrojax.simulation.triad_session import simulate_session

MAX_TESTS = 8
"""Designed tests a simulated campaign runs at most."""


@dataclass
class CampaignStep:
    """One test of the campaign: its plan, hours and why it was run; then the state of the fit with its records."""

    plan: object
    hours: float
    reason: str
    cumulative_hours: float
    state: dict = field(default_factory=dict)  # terms, σ, residual RMS and verdict after this test's records
    file: str | None = None
    predicted: list = field(default_factory=list)  # σ the design predicted after it: coefficient, sub-model, σ
    name: str | None = None  # the test's name where its plan has none (a hand session)
    protocol: dict | None = None  # a designed hand session's protocol file content (NextTest.protocol)

    def to_json(self) -> dict:
        """JSON: plan name (or file), hours, cumulative hours, reason and the state after it."""
        return {
            "plan": self.file or self.name or self.plan.name,
            "hours": self.hours,
            "cumulative_hours": self.cumulative_hours,
            "reason": self.reason,
            "predicted": self.predicted,
            **self.state,
        }


@dataclass
class CampaignResult:
    """A simulated campaign: its steps, the final model, fit and diagnosis, and the classical sequence beside it."""

    status: str
    reason: str
    steps: list
    last: NextTest
    records: list
    goal: Goal
    lab: Lab
    classical: ClassicalResult | None = None
    first_hours: float = 0.0
    bound: dict | None = None  # :func:`gyrojax.adaptive.bound.table_hours_bound` of the last look's requirements

    def hours_bound(self) -> dict | None:
        """The table hours no campaign from the same first test can go below (the first test's hours plus the
        dwell bound of the last look's requirements), the ratio to the classical sequence they imply, and whether
        ≤ 1/3 of the classical hours is possible at all."""
        if self.bound is None:
            return None
        low = self.first_hours + self.bound["dwell_lower"]
        c = self.classical.hours if self.classical is not None else None
        ratio = low / c if c else None
        out = {**self.bound, "table_hours_lower": low, "ratio_lower": ratio}
        if ratio is not None:
            watched = sorted({r.effect for r in self.last.requirements if r.kind == "detect"})
            out["one_third_possible"] = bool(ratio <= 1.0 / 3.0)
            out["statement"] = (
                f"no campaign that starts with this first test can bring {', '.join(self.last.terms)} to the targets"
                + (f" and rule out {', '.join(watched)} at the sizes that matter" if watched else "")
                + f" in fewer than {low:.3g} table hours (the first test's {self.first_hours:.3g} h and "
                f"{self.bound['dwell_lower']:.3g} h of dwell, a bound over every static design on a "
                f"{self.bound['grid_deg']:g}° grid of the table's angles; a design of "
                f"{self.bound['dwell_design']:.3g} h meets them): {ratio:.3f} of the classical sequence's {c:.3g} h"
                + ("" if ratio <= 1.0 / 3.0 else ", so 1/3 of its hours cannot be reached")
            )
        return out

    @property
    def goal_met(self) -> bool:
        """Whether the campaign met its goal."""
        return self.status == "goal-met"

    @property
    def table_hours(self) -> float:
        """Table hours of every test of the campaign, the first included (h)."""
        return sum(s.hours for s in self.steps)

    def to_json(self) -> dict:
        """The campaign's JSON (the command's ``--json``): goal_met, table_hours, classical_table_hours, terms,
        verdict, steps, and the rest."""
        d = self.last.diagnosis
        c = self.classical
        ratio = None
        if c is not None and c.hours:
            ratio = self.table_hours / c.hours
        return {
            "goal_met": self.goal_met,
            "status": self.status,
            "reason": self.reason,
            "table_hours": self.table_hours,
            "classical_table_hours": c.hours if c is not None else None,
            "hours_ratio": ratio,
            "hours_lower_bound": self.hours_bound(),
            "classical": c.to_json() if c is not None else None,
            "terms": list(self.last.terms),
            "verdict": d.verdict if d is not None else None,
            "diagnosis": d.to_json() if d is not None else None,
            "coefficients": self.last.to_json()["coefficients"],
            "requirements": self.last.requirement_rows(),
            "looks": self.last.looks,
            "steps": [s.to_json() for s in self.steps],
            "goal": self.goal.to_json(),
            "lab": self.lab.to_json(),
        }


def state_of(nt: NextTest) -> dict:
    """The fit and diagnosis a step found on the records so far: terms, σ and values (report units), residual RMS,
    noise floor (output units), verdict, what it added."""
    j = nt.to_json()
    return {
        "terms": j["terms"],
        "added": [a["effect"] for a in nt.added],
        "verdict": j["verdict"],
        "residual_rms": j["residual_rms_deg_per_h"],
        "noise_floor": j["noise_floor_deg_per_h"],
        "coefficients": j["coefficients"],
    }


def run_campaign(
    truth,
    first,
    terms,
    goal: Goal,
    lab: Lab | None = None,
    *,
    seed: int = 0,
    max_tests: int = MAX_TESTS,
    classical: bool = True,
    lab_options: dict | None = None,
    on_step=None,
    **search,
) -> CampaignResult:
    """Run the campaign loop on a laboratory simulated from ``truth`` (module doc).

    Args:
      truth: a :class:`~gyrojax.data.truth.Truth` or truth dict (conventions §8).
      first: the lab's first test, a :class:`~gyrojax.data.plans.Plan`.
      terms: the lab's model before any test (effect names).
      goal: the :class:`~gyrojax.adaptive.goal.Goal`.
      lab: the table of the designed tests (default: the first test's, with ``lab_options``).
      seed: noise seed of the campaign (and of the classical sequence it is compared with).
      max_tests: designed tests at most.
      classical: also compute the classical sequence's hours for the final model.
      on_step: called with each :class:`NextTest` as it is made (progress).
      search: ``starts``, ``steps`` of the design search.

    Returns: a :class:`CampaignResult`.
    """
    if isinstance(truth, TriadTruth):
        raise ModelError("an imu-triad truth is a hand lab's: run_hand_campaign runs its sessions, not a turntable")
    truth = truth if isinstance(truth, Truth) else truth_from_dict(truth)
    key = jax.random.PRNGKey(seed)
    records = simulate(first, truth, key=jax.random.fold_in(key, 0))
    lab = lab or Lab.from_records(records, **(lab_options or {}))
    hours = float(first.duration_s) / 3600.0
    first_step = CampaignStep(first, hours, "the lab's first test", hours)

    def run(nt, k, records):
        clock = max(float(r.time_s[-1]) for r in records) + lab.settle_s
        return simulate(nt.plan, truth, key=jax.random.fold_in(key, k), start_s=clock), nt.plan

    status, reason, steps, nt, records = _loop(
        records, first_step, terms, goal, lab, run, seed, max_tests, on_step, search
    )
    result = CampaignResult(status, reason, steps, nt, records, goal, lab, first_hours=hours)
    if classical:
        try:
            result.classical = classical_hours(truth, nt.terms, goal, nt.kind, seed, lab.latitude_deg)
        except ModelError as e:
            result.classical = ClassicalResult(None, None, {}, reason=str(e))
        if result.classical.hours and truth.noise.white > 0:
            result.bound = table_hours_bound(
                simulate(first, {"coefficients": {}}),
                nt.requirements,
                rq.universe(nt.terms, goal, nt.kind, nt.alias),
                lab,
                truth.noise.white,
            )
    return result


def _loop(records, first_step, terms, goal, lab, run, seed: int, max_tests: int, on_step, search: dict):
    """The campaign's loop body, on any lab: :func:`~gyrojax.adaptive.step.next_test` on every record so far, then
    ``run(nt, k, records)`` — the k-th designed test simulated, (its records, what :class:`CampaignStep` keeps) —
    until the goal is met, refused, blocked, or ``max_tests`` tests have run. Returns (status, reason, steps, the last
    :class:`NextTest`, records)."""
    steps = [first_step]
    looks, current = 0, tuple(terms)
    for k in range(1, max_tests + 2):
        nt = next_test(
            records,
            current,
            goal,
            lab,
            looks=looks,
            hours_spent=sum(s.hours for s in steps),
            name=f"test-{k + 1}",
            seed=seed + k,
            **search,
        )
        if on_step is not None:
            on_step(nt)
        steps[-1].state = state_of(nt)
        looks, current = nt.looks, nt.terms
        if nt.status != "test":
            return nt.status, nt.reason, steps, nt, records
        if k > max_tests:
            reason = f"the goal is not met after {max_tests} designed tests: " + nt.reason
            return "unreachable", reason, steps, nt, records
        new, plan = run(nt, k, records)
        records = records + new
        total = sum(s.hours for s in steps) + nt.hours
        predicted = [
            {"coefficient": r.coefficient, "sub_model": list(r.effects), "sigma": float(x)}
            for r, x in zip(nt.requirements, nt.sigma_after)
            if r.kind != "separate" and math.isfinite(x)
        ]
        steps.append(CampaignStep(plan, nt.hours, nt.reason, total, predicted=predicted, protocol=nt.protocol))


def run_hand_campaign(
    truth,
    first,
    terms,
    goal: Goal,
    lab: HandLab | None = None,
    *,
    seed: int = 0,
    max_tests: int = MAX_TESTS,
    session: dict | None = None,
    classical: bool = True,
    on_step=None,
    **search,
) -> CampaignResult:
    """The campaign loop on a hand-held triad simulated from ``truth`` (module doc; the lab a person turning a box,
    :mod:`gyrojax.adaptive.hand`): the first session and every designed one simulated by
    :func:`gyrojax.simulation.triad_session.simulate_session` (session k from the seed sequence (``seed``, k)) and
    fitted jointly with every session before.

    Args:
      truth: a :class:`~gyrojax.data.truth.TriadTruth` (coefficients, ARW and the sessions' options), or its
        per-channel coefficients alone (``{"D_F[x]": deg/h, "E_SF[y]": ppm, "M_O[z]": arcsec, …}``).
      first: the first session, (start attitude body → ENU 3×3, steps) as
        :func:`~gyrojax.planning.triad_protocol.ferraris_steps` gives it.
      terms: the model before any session (effect names).
      goal: the :class:`~gyrojax.adaptive.goal.Goal` (targets per channel coefficient).
      lab: the :class:`~gyrojax.adaptive.hand.HandLab` (default one).
      session: options of ``simulate_session`` for every session (``rate_hz``, ``gyro_noise_dps`` deg/s per sample,
        ``acc_noise_g``, ``placement_deg``, ``latitude_deg`` …), over a TriadTruth's.
      classical: also compute the hours of the first session repeated to the same σ
        (:func:`~gyrojax.adaptive.classical.hand_classical_hours`; a TriadTruth's only: coefficients alone do not
        state the noise it is simulated at, and ``classical`` then says so).
      search: ``starts``, ``steps``, ``lbfgs_steps`` of the session search.

    Returns: a :class:`CampaignResult` (``table_hours``: the sessions' hours).
    """
    lab = lab or HandLab()
    coefficients = truth.coefficients if isinstance(truth, TriadTruth) else truth
    session = {**(truth.simulation_options() if isinstance(truth, TriadTruth) else {}), **(session or {})}
    start, plan = first

    def simulate_one(start, plan, k):
        sub = int(np.random.SeedSequence([seed, k]).generate_state(1)[0])
        return simulate_session(plan, coefficients, start_attitude=start, seed=sub, **session)

    records = [simulate_one(start, plan, 0)]
    hours = session_seconds(plan) / 3600.0
    first_step = CampaignStep(None, hours, "the lab's first session", hours, name="first session")

    def run(nt, k, records):
        proto = nt.design
        return [simulate_one(proto.start_attitude, proto.steps, k)], proto

    status, reason, steps, nt, records = _loop(
        records, first_step, terms, goal, lab, run, seed, max_tests, on_step, search
    )
    for k, step in enumerate(steps[1:], start=2):
        step.name = f"session-{k}"
    result = CampaignResult(status, reason, steps, nt, records, goal, lab, first_hours=hours)
    if classical and not isinstance(truth, TriadTruth):
        why = "the truth gives coefficients alone, not the noise of the sessions (give a TriadTruth)"
        result.classical = ClassicalResult(None, None, {}, reason=why)
    elif classical:
        result.classical = hand_classical_hours(truth, first, nt.terms, goal, seed)
    return result
