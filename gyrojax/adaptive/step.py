"""One step of the campaign: from the records so far and the current model, the next test (``gj.next_test``,
``gyrojax next``).

1. **Diagnose and add.** The records are diagnosed at the level of the campaign's next look
   (:func:`gyrojax.adaptive.goal.look_alpha`); the effect the diagnosis proposes (significant, accepted by ``fit``,
   plausible) is added and the records diagnosed again, until it proposes nothing. A proposal the records cannot
   tell from other candidates (its ``aliases`` or ``indistinguishable``, plausible ones) is *not* added: naming one
   member of an alias group would be a guess, and the next test is designed to separate the group instead. So is
   a proposal that is no longer significant beside the other significant watched candidates fitted together
   (:func:`_rivals`): two missing effects can together look like a third, or one take the other's signal. When
   those candidates stay significant beside it, the records prefer them, and the strongest of them is added instead.
2. **Require.** What stands between the data and the goal (:mod:`gyrojax.adaptive.requirements`): σ of the model's
   coefficients (the fit's own standard errors), σ of each watched candidate were it added (detection of every size
   that matters), σ of the alias group's members in one fit.
3. **Stop or design.** The goal is met when the diagnosis finds nothing missing and every requirement is met. A
   requirement no orientation of the table reaches, or a goal the hours left cannot reach, is refused with the
   reason and what would reach it (:mod:`gyrojax.adaptive.reach`). Otherwise the test is designed by gradients
   (:mod:`gyrojax.adaptive.design`) and written as a plan on the lab's table, with the σ predicted after it and
   why it was chosen: the requirements it was designed to meet, worst first. A test that takes all the hours a
   test may (the requirements need more) is shaped for the models the records may turn out to hold
   (:func:`_anticipated`): a watched candidate no record has excited is asked at its σ target as if it were in the
   model, beside each member of the alias group; not at its detection level alone, which a present candidate
   outgrows as soon as it is added. Its hours stay those of the test the requirements ask for.

**A hand-held triad** (imu-triad records; the lab a person turning a box, :class:`~gyrojax.adaptive.hand.HandLab`):
step 1 is the same (a triad candidate ``D_II[z]`` adds the effect ``D_II`` on every channel); the requirements are
the σ of the model's channel coefficients that have a target; the next test is the shortest hand session whose
information, added to the records', meets them (:mod:`gyrojax.adaptive.hand`), written as a protocol file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from gyrojax.adaptive import requirements as rq
from gyrojax.adaptive.design import MAX_HOURS, STARTS, STEPS, design_test
from gyrojax.adaptive.goal import Goal, detect_level, detection_power, look_alpha, noncentrality_for_power
from gyrojax.adaptive.hand import HandLab, design_session, prior_information, session_comparison, session_noise
from gyrojax.adaptive.information import (
    RESOLVED_CORRELATION_TIMES,
    compiled_information,
    record_information,
    test_noise,
)
from gyrojax.adaptive.lab import Lab
from gyrojax.adaptive.reach import out_of_reach
from gyrojax.data.triad import TRIAD_KIND as TRIAD
from gyrojax.errors import ModelError
from gyrojax.inference.diagnose import diagnose, fit_with
from gyrojax.inference.identify import DEFAULT_TERMS, fit
from gyrojax.inference.triad import default_terms
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model
from gyrojax.planning import triad_protocol as tpr

POSTERIOR_DRAWS = 8
"""Posterior draws of θ over which a nonlinear universe's information is averaged."""


@dataclass
class NextTest:
    """The outcome of one step: ``status`` ``"goal-met"``, ``"test"`` (a test is designed: :attr:`plan`),
    ``"unreachable"`` or ``"blocked"`` (the diagnosis finds what no named effect or test can resolve), with the
    model, its fit and diagnosis, the requirements and their σ now and after the test (report units). On imu-triad
    records the test is a hand session: :attr:`design` its protocol, :attr:`protocol` the protocol file's content,
    :attr:`hours` its length (h)."""

    status: str
    terms: tuple
    kind: str
    fit: object
    diagnosis: object
    added: list
    alias: tuple
    requirements: list
    sigma_now: np.ndarray
    alpha_next: float
    looks: int
    goal: Goal
    family: int = 1
    reason: str = ""
    design: object = None
    plan: object = None
    hours: float = 0.0
    sigma_after: np.ndarray | None = None
    kappa: float = 1.0
    notes: list = field(default_factory=list)
    protocol: dict | None = None

    @property
    def alpha_detect(self) -> float:
        """The level a lone missing candidate is tested at in the next look: Holm over its ``family`` tests starts at
        α/m (:func:`gyrojax.adaptive.goal.detect_level`)."""
        return detect_level(self.alpha_next, self.family)

    @property
    def lam(self) -> float:
        """λ*: the noncentrality at which the next look detects a lone missing candidate with the goal's power."""
        return noncentrality_for_power(self.alpha_detect, self.goal.power)

    @property
    def goal_met(self) -> bool:
        """Whether the goal is met on the records (then there is no next test)."""
        return self.status == "goal-met"

    def requirement_rows(self) -> list:
        """Per requirement: kind, coefficient, target, unit, σ now and after, met now, and for candidates the size
        that matters, the power of the next look at it and the size above which it would be detected (power
        ``goal.power``), now and after the test."""
        out = []
        root = math.sqrt(self.lam)
        for i, r in enumerate(self.requirements):
            row = {**r.to_json(), "sigma_now": _num(self.sigma_now[i]), "met": bool(self.sigma_now[i] <= r.target)}
            if self.sigma_after is not None:
                row["sigma_after"] = _num(self.sigma_after[i])
            if r.kind == "detect":
                size = self.goal.detect_size(r.coefficient, self.kind)
                row["size_that_matters"] = size
                row["power_now"] = detection_power(size, self.sigma_now[i], self.alpha_detect)
                row["detected_above_now"] = _num(self.sigma_now[i] * root)
                if self.sigma_after is not None:
                    row["power_after"] = detection_power(size, self.sigma_after[i], self.alpha_detect)
                    row["detected_above_after"] = _num(self.sigma_after[i] * root)
            out.append(row)
        return out

    def to_json(self) -> dict:
        """The step as JSON: status, goal_met, model, added effects, requirements, the test (plan, hours, mounting)
        and the reason."""
        d = self.diagnosis
        out = {
            "status": self.status,
            "goal_met": self.goal_met,
            "terms": list(self.terms),
            "added": self.added,
            "alias": list(self.alias),
            "looks": self.looks,
            "alpha_next_look": self.alpha_next,
            "holm_family": self.family,
            "verdict": d.verdict if d is not None else None,
            "residual_rms_deg_per_h": d.residual_rms if d is not None else None,
            "noise_floor_deg_per_h": d.noise_floor if d is not None else None,
            "coefficients": _coefficients(self.fit),
            "requirements": self.requirement_rows(),
            "reason": self.reason,
            "notes": list(self.notes),
            "information_scale": self.kappa,
        }
        if self.plan is not None:
            out["test"] = {
                "plan": self.plan.name,
                "hours": self.hours,
                "dwell_hours": self.design.dwell_hours,
                "runs": [
                    {"name": r.name, "mounting": r.instrument, "positions": len(r.segments), "gap_s": r.gap_s}
                    for r in self.plan.runs
                ],
                "hours_needed_for_goal": self.design.hours_needed,
            }
        if self.protocol is not None:
            out["protocol"] = {
                "minutes": self.hours * 60.0,
                "poses": len(self.protocol["table"]),
                "turn_pairs": self.protocol["search"]["turn_pairs"],
                "table": self.protocol["table"],
                "comparison": self.protocol["comparison"],
            }
        return out


def _num(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _coefficients(res) -> dict:
    if res is None:
        return {}
    units = res.units()
    return {c: {"value": res.values[c], "std": res.stds[c], "unit": units[c]} for c in res.coefficient_names}


def _check_records(records) -> str:
    if not records:
        raise ModelError("next test: no records")
    kinds = {r.kind for r in records}
    if len(kinds) != 1:
        raise ModelError(f"next test: the records mix instrument kinds {sorted(kinds)}")
    return kinds.pop()


def _update_model(records, terms, goal: Goal, looks: int, kind: str):
    """Diagnose, add what the data ask for, stop at an alias group (module doc). Returns (terms, fit, diagnosis,
    added, alias group, looks, note)."""
    terms = tuple(terms)
    added, res = [], None
    while True:
        try:
            res = res or fit(records, list(terms))
        except ModelError as e:  # the records cannot identify the model: the next test must
            return terms, None, None, added, (), looks, f"the records cannot identify the model: {e}"
        look = looks + 1
        a = look_alpha(look, goal.alpha)
        d = diagnose(records, list(terms), alpha=a, result=res, suggest_tests=False)
        looks = look
        if d.proposal is None:
            return terms, res, d, added, (), looks, ""
        c = _proposed(d)
        plausible = {x.name for x in d.candidates if x.implausible is None and x.refused is None}
        rivals, preferred = _rivals(records, terms, c, d, a, goal, kind, plausible)
        if preferred:  # the records single out the watched rivals: the strongest of them is the proposal
            c = next(x for x in d.candidates if x.name in rivals)
        group = _named_aliases(c, plausible, terms, kind)
        group = group if preferred else tuple(dict.fromkeys(group + rivals))
        if group:
            return terms, res, d, added, (c.name,) + group, looks, ""
        try:
            new = fit_with(d, records, _effect(c))
        except ModelError:
            if not preferred:
                raise
            # a preferred rival the fit refuses: the records hold a group to separate
            return terms, res, d, added, (d.proposal,) + rivals, looks, ""
        res, terms = new, terms + (_effect(c),)
        added.append(
            {
                "effect": _effect(c),
                **({"candidate": c.name} if c.name != _effect(c) else {}),
                "look": look,
                "alpha": a,
                "p_adjusted": c.p_adjusted,
                "estimate": c.estimate,
            }
        )


def _proposed(d):
    """The candidate of the diagnosis' proposal: the candidate of that name, or on a triad the strongest of the
    effect's channels (``D_II[z]`` for the proposal ``D_II``: the candidates are ranked)."""
    return next(x for x in d.candidates if x.name == d.proposal or _effect(x) == d.proposal)


def _effect(c) -> str:
    """The effect a candidate adds (on a triad, on every channel: ``D_II`` of ``D_II[z]``)."""
    return c.name.split("[")[0]


def _named_aliases(c, plausible, terms, kind: str) -> tuple:
    """The plausible named effects of ``kind`` outside ``terms`` the records cannot tell from the candidate ``c``."""
    names = fx.names(kind)
    return tuple(
        g for g in dict.fromkeys(c.aliases + c.indistinguishable) if g in names and g in plausible and g not in terms
    )


def _rivals(records, terms, c, d, alpha: float, goal: Goal, kind: str, plausible) -> tuple[tuple, bool]:
    """(rivals, preferred) of the proposal ``c``: the significant, plausible watched candidates R other than ``c``
    when ``c`` is no longer significant (level ``alpha``) in the fit of the model with all of R; ``preferred`` when
    R, in turn, is still significant beside ``c`` (Holm over R): the records then single out R, not ``c``. ((), False)
    when ``c`` holds or has no rival. The one-at-a-time tests rank candidates by what each alone explains: two
    missing effects can together look like a third, one that no single test names (a scale-factor asymmetry |ω_I|
    at Earth rate follows a_O and a_S² across a set of static positions; a table azimuth error follows several
    g-sensitive terms of a multi-position test), and one watched effect can take another's signal where a test tells
    them apart only in part (D_II beside a missing D_SS: a_I² + a_S² nearly constant over its positions)."""
    watched = goal.watched(kind)
    rivals = [
        x.name
        for x in d.candidates
        if x.name in watched
        and x.name != c.name
        and x.name in plausible
        and x.name not in terms
        and x.p_adjusted < alpha
    ]
    if not rivals:
        return (), False
    model = list(terms) + rivals
    try:
        res = fit(records, model, allow_aliases=True)
        beside = diagnose(
            records, model, alpha=alpha, result=res, candidates=[c.name], suggest_tests=False, model_free=False
        )
    except ModelError:
        return (), False
    held = next((x for x in beside.candidates if x.name == c.name), None)
    if held is not None and held.p_adjusted < alpha:
        return (), False
    try:
        with_c = list(terms) + [c.name]
        res = fit(records, with_c, allow_aliases=True)
        back = diagnose(
            records, with_c, alpha=alpha, result=res, candidates=rivals, suggest_tests=False, model_free=False
        )
    except ModelError:
        return tuple(rivals), False
    return tuple(rivals), any(x.p_adjusted < alpha for x in back.candidates if x.name in rivals)


def _family(d, goal, kind: str, terms) -> int:
    """The number of tests in the next look's Holm family, taken as the last diagnosis' (named candidates and
    model-free shapes); without a diagnosis (the records cannot identify the model), the watched candidates outside
    the model."""
    if d is not None and d.tests:
        return int(d.tests)
    return max(sum(1 for e in goal.watched(kind) if e not in terms), 1)


def _assess(records, terms, goal, kind, alias, res, alpha_detect):
    """The requirements of the model ``terms`` and ``alias`` group (candidates detected at level ``alpha_detect``),
    their universe, the records' information on it (with its scale κ and the saturated fit it came from) and every
    requirement's σ now (the fit's own σ for the model's coefficients)."""
    reqs = rq.build(terms, goal, kind, alpha_detect, alias)
    uni = rq.universe(terms, goal, kind, alias)
    sat = _noise_fit(records, uni, res)
    f_rec, kappa = record_information(uni, records, sat, _theta(uni, res))
    sigma_now = rq.sigmas(f_rec, reqs, uni)
    if res is not None:
        stds = res.stds
        sigma_now = np.array([stds[r.coefficient] if r.kind == "sigma" else x for r, x in zip(reqs, sigma_now)])
    return reqs, uni, f_rec, kappa, sat, sigma_now


def _noise_fit(records, uni: Model, res):
    """The fit whose noise the records' information and the next test take: the current fit when its noise has no
    Gauss–Markov colour; else — the colour may be a missing effect's misfit — the fit of the whole universe
    (minimum-norm where the records alias its effects), whose residual holds no effect the model misses. Not that
    one first: fitted to few records, the universe's many terms leave chance structure a white + Gauss–Markov noise
    fit can take for colour."""
    if res is not None and not any(nz.gauss_markov for nz in res.noise):
        return res
    try:
        return fit(records, list(uni.terms), allow_aliases=True)
    except ModelError:
        return res


def _theta(uni: Model, res) -> np.ndarray:
    th = np.zeros(uni.size)
    if res is not None:
        for c, v in res.values.items():
            th[uni.coefficient_names.index(c)] = v
    return th


def _draws(uni: Model, res, n: int, seed: int):
    """Posterior draws of θ on the universe (the fit's estimate and covariance; 0 elsewhere); None when linear."""
    if uni.is_linear or res is None:
        return None
    rng = np.random.default_rng(seed)
    idx = [uni.coefficient_names.index(c) for c in res.coefficient_names]
    cov = np.nan_to_num(np.asarray(res.cov, dtype=float))
    draws = np.tile(_theta(uni, res), (n, 1))
    draws[:, idx] = rng.multivariate_normal(np.asarray(res.theta, dtype=float), cov, n, check_valid="ignore")
    return draws


def next_test(
    records,
    terms=None,
    goal: Goal | None = None,
    lab: Lab | None = None,
    *,
    looks: int = 0,
    hours_spent: float = 0.0,
    name: str = "next-test",
    start_s: float | None = None,
    seed: int = 0,
    starts: int = STARTS,
    steps: int = STEPS,
    lbfgs_steps: int | None = None,
) -> NextTest:
    """One step of the campaign (module doc).

    Args:
      records: the lab's records so far (one instrument).
      terms: the current model (effect names; default the fit's default model of the records' kind).
      goal: the :class:`~gyrojax.adaptive.goal.Goal` (target σ in report units, watched candidates, error budget).
      lab: the :class:`~gyrojax.adaptive.lab.Lab` (default: the first record's table and mounting, default limits);
        for imu-triad records a :class:`~gyrojax.adaptive.hand.HandLab` (default one).
      looks: diagnoses the campaign has already made (their levels are spent: :func:`look_alpha`).
      hours_spent: table hours the campaign has already used (h), against ``lab.budget_hours``.
      name: the designed plan's name.
      start_s: the test's start on the campaign clock (s; default: after the last record, one settle time later).
      seed, starts, steps: the design search's random starts (per mounting), their seed and Adam iterations.
      lbfgs_steps: imu-triad records: the L-BFGS refinement of the session's search at most (default that of
        :func:`gyrojax.planning.triad_protocol.design_protocol`; 0: none, a quicker compile).

    Returns: a :class:`NextTest`.
    """
    records = list(records)
    kind = _check_records(records)
    if goal is None:
        raise ModelError("next test: give a goal (target σ)")
    if kind == TRIAD:
        search = {"seed": seed, "starts": starts, "steps": steps, "lbfgs_steps": lbfgs_steps}
        return _next_session(records, terms, goal, lab, looks, hours_spent, search)
    if isinstance(lab, HandLab):
        raise ModelError(f"next test: a hand lab (a person turning a box) designs imu-triad sessions, not {kind} tests")
    lab = lab or Lab.from_records(records)
    if lab.kind != kind:
        raise ModelError(f"next test: the lab's instrument is a {lab.kind}, the records' a {kind}")
    terms = tuple(Model.of(terms if terms else DEFAULT_TERMS[kind], kind).terms)
    added, notes = [], []
    while True:
        terms, res, d, more, alias, looks, note = _update_model(records, terms, goal, looks, kind)
        added += more
        notes += [note] if note else []
        alpha_next = look_alpha(looks + 1, goal.alpha)
        family = _family(d, goal, kind, terms)
        alpha_detect = detect_level(alpha_next, family)
        reqs, uni, f_rec, kappa, sat, sigma_now = _assess(records, terms, goal, kind, alias, res, alpha_detect)
        unwatched = tuple(g for g in alias if g not in goal.watched(kind))
        if unwatched and out_of_reach(uni, [r for r in reqs if r.kind == "separate"], f_rec, lab):
            # a member no test on the table separates from the model and the group (D_OO beside D_F, D_II, D_SS at
            # 1 g) is not a name the campaign can give: the group is its watched members
            notes.append(
                f"left out of the alias group, as no test on this table separates them: {', '.join(unwatched)}"
            )
            alias = tuple(g for g in alias if g not in unwatched)
            if len(alias) == 1:  # one name left, the one the campaign can give (Hu drops D_OO so): add it
                c = next(x for x in d.candidates if x.name == alias[0])
                try:
                    fit(records, list(terms + alias))
                except ModelError:
                    pass
                else:
                    added.append(
                        {
                            "effect": c.name,
                            "look": looks,
                            "alpha": look_alpha(looks, goal.alpha),
                            "p_adjusted": c.p_adjusted,
                            "estimate": c.estimate,
                        }
                    )
                    terms = terms + alias
                    continue
            reqs, uni, f_rec, kappa, sat, sigma_now = _assess(records, terms, goal, kind, alias, res, alpha_detect)
        break
    out = NextTest(
        "test",
        terms,
        kind,
        res,
        d,
        added,
        alias,
        reqs,
        sigma_now,
        alpha_next,
        looks,
        goal,
        family,
        kappa=kappa,
        notes=notes,
    )
    unmet = [i for i, (r, x) in enumerate(zip(reqs, sigma_now)) if not x <= r.target]
    clean = d is not None and d.verdict == "adequate" and not alias
    met = (
        ", every coefficient of the model is known to its target σ, and no watched candidate could hide at a size "
        "that matters"
    )
    if _settled(out, unmet, clean, met, "test"):
        return out
    missing = out_of_reach(uni, [reqs[i] for i in unmet], f_rec, lab)
    if missing:
        out.status = "unreachable"
        out.reason = "; ".join(why for _, why in missing)
        return out
    left = lab.budget_hours - hours_spent
    if left <= 0.0:
        out.status = "unreachable"
        out.reason = f"the campaign's budget of {lab.budget_hours:g} table hours is spent; " + _unmet_text(out, unmet)
        return out
    noise, unresolved = test_noise(sat, records)
    for sig, tau in unresolved:
        out.notes.append(
            f"the fitted Gauss–Markov drift (σ {sig:.3g} deg/h, τ {tau:.4g} s) is not resolved by the records (their "
            f"longest continuous segment holds fewer than {RESOLVED_CORRELATION_TIMES:g} correlation times): the test "
            "is designed for the white noise, and the fit after it says whether the drift is there"
        )
    last_end = max(float(r.time_s[-1]) for r in records)
    start = last_end + lab.settle_s if start_s is None else float(start_s)
    cap, draws = min(lab.hours_per_test, left), _draws(uni, res, POSTERIOR_DRAWS, seed)
    # a test that takes all the hours a test may is shaped for the models the records may turn out to hold
    anticipated = _anticipated(reqs, sigma_now, goal, terms, alias)
    shape = rq.arrays(anticipated, uni) if anticipated is not None else None
    search = {"budget_hours": left, "starts": starts, "steps": steps, "seed": seed, "shape": shape}
    test = design_test(uni, rq.arrays(reqs, uni), f_rec, lab, noise, cap, start, goal.margin, draws, **search)
    if test.hours_needed is None or test.hours_needed > left:
        factor = math.sqrt(max(test.ratio_at_budget, 0.0)) * goal.margin
        if test.hours_needed is None:
            need, budget = f"more than {MAX_HOURS:g} h", f"more than {hours_spent + MAX_HOURS:.3g} h"
        else:
            need, budget = f"about {test.hours_needed:.3g} h", f"at least {hours_spent + test.hours_needed:.3g} h"
        out.status = "unreachable"
        out.reason = (
            f"the goal needs {need} of dwell beyond the records on this table (by the best test the search finds) "
            f"and the budget leaves {left:.3g} h: within it the worst requirement reaches {factor:.3g} × its target "
            f"σ. A campaign budget of {budget} (the {hours_spent:.3g} h spent, that dwell and the moves between "
            f"positions), targets {factor:.3g} times larger or a quieter instrument would reach it. Unmet: "
            + _unmet_text(out, unmet)
        )
        return out
    if shape is not None and test.hours_needed > cap:
        unseen = dict.fromkeys(r.effect for r, x in zip(reqs, sigma_now) if r.kind == "detect" and not math.isfinite(x))
        out.notes.append(
            "the test takes all the hours a test may, so it is shaped for the models the records may turn out to "
            f"hold: {', '.join(unseen)} (not seen by the records so far) at their σ target as if in the model"
            + (f", beside each of {', '.join(alias)}" if alias else "")
        )
    if test.convergence_note:
        out.notes.append(f"design search: {test.convergence_note}")
    description = f"{len(test.mountings)}×{lab.positions}-position test designed by gyrojax next for {', '.join(terms)}"
    plan = lab.plan(name, test.triads, test.angles_deg, test.dwell_s, description)
    out.design, out.plan, out.hours = test, plan, float(plan.duration_s) / 3600.0
    out.sigma_after = _predicted(uni, reqs, f_rec, lab, noise, plan, res, start)
    out.reason = _why(out, unmet)
    return out


def _next_session(records, terms, goal: Goal, lab, looks: int, hours_spent: float, search: dict) -> NextTest:
    """One step on imu-triad records (module doc; the lab is a person turning a box, :mod:`gyrojax.adaptive.hand`):
    diagnose and add as on a table; the requirements are the σ of the model's channel coefficients with a target;
    the next test is the shortest hand session whose information, added to the records', meets them all."""
    lab = HandLab() if lab is None else lab
    if not isinstance(lab, HandLab):
        raise ModelError("next test: imu-triad records are a hand session: give a HandLab, not a turntable's Lab")
    terms = tuple(terms) if terms else tuple(default_terms(records))
    terms, res, d, added, alias, looks, note = _update_model(records, terms, goal, looks, TRIAD)
    if res is None:
        raise ModelError(f"next test: {note}; design a first session (gyrojax design --instrument imu-triad)")
    if not res.converged:
        raise ModelError(f"next test: the triad fit did not converge ({res.convergence_note})")
    units = res.units()
    reqs = [
        rq.Requirement("sigma", c, terms, goal.target(c), units[c]) for c in res.names if goal.target(c) is not None
    ]
    if not reqs:
        raise ModelError(f"next test: the goal sets no target for a coefficient of the model ({', '.join(terms)})")
    sigma_now = np.array([res.stds[r.coefficient] for r in reqs])
    notes = [note] if note else []
    if goal.watch:
        notes.append(
            "the watched candidates of a triad are every candidate the diagnosis tests at each look; the hand design "
            "does not aim at detecting them"
        )
    out = NextTest(
        "test",
        terms,
        TRIAD,
        res,
        d,
        added,
        alias,
        reqs,
        sigma_now,
        look_alpha(looks + 1, goal.alpha),
        looks,
        goal,
        _family(d, goal, TRIAD, terms),
        notes=notes,
    )
    unmet = [i for i, (r, x) in enumerate(zip(reqs, sigma_now)) if not x <= r.target]
    met = " and every channel coefficient with a target is known to it"
    if _settled(out, unmet, d.verdict == "adequate" and not alias, met, "session"):
        return out
    try:
        model = tpr.triad_model(terms)
    except ModelError as e:
        out.status = "unreachable"
        out.reason = f"no hand session is designed for this model ({e}); unmet: " + _unmet_text(out, unmet)
        return out
    noise, more = session_noise(res, records, lab)
    out.notes += more
    prior = prior_information(res, model)
    names = list(res.names)
    targets = np.full(len(names), np.nan)
    for r in reqs:
        targets[names.index(r.coefficient)] = r.target
    hd = design_session(model, targets, prior, noise, lab, goal.margin, **search)
    out.notes += hd.notes
    out.sigma_after = np.array([hd.sigma_after[names.index(r.coefficient)] for r in reqs])
    left = math.inf if lab.budget_minutes is None else lab.budget_minutes - 60.0 * hours_spent
    if hd.protocol is None and lab.budget_minutes is not None and hd.minutes_needed <= left:
        # the budget holds more sessions: this one takes the longest a session may, the fit after it says the rest
        hd.protocol, hd.minutes = hd.longest, lab.max_minutes
        out.notes.append(
            f"the goal needs about {hd.minutes_needed:.3g} min of hand session beyond the records: this session takes "
            f"the longest a session may ({lab.max_minutes:g} min), and the campaign's {left:.3g} min left hold more"
        )
    if hd.protocol is None:
        out.status = "unreachable"
        sessions = math.ceil(hd.minutes_needed / lab.max_minutes)
        factor = hd.ratio_at_longest / goal.margin
        out.reason = (
            f"the goal needs about {hd.minutes_needed:.3g} min of hand session beyond the records (by the best "
            f"session the search finds at the lab's longest, {lab.max_minutes:g} min, the worst σ reaches "
            f"{hd.ratio_at_longest:.3g} × its target): {sessions} sessions of {lab.max_minutes:g} min, one of "
            f"{hd.minutes_needed:.3g} min, targets {factor:.3g} times larger or a gyro about {factor:.3g} times "
            "quieter (ARW) would reach it"
            + ("" if math.isinf(left) else f" (the campaign's budget leaves {max(left, 0.0):.3g} min)")
            + ". Unmet: "
            + _unmet_text(out, unmet)
        )
        return out
    out.design, out.hours = hd.protocol, hd.minutes / 60.0
    out.protocol = tpr.protocol_payload(hd.protocol, session_comparison(hd.protocol, prior, model, targets))
    out.protocol["next"] = {
        "prior": "the inverse of the fit's covariance of the records so far",
        "minutes": hd.minutes,
        "sigma_after": {r.coefficient: float(x) for r, x in zip(reqs, out.sigma_after)},
        "targets": {r.coefficient: r.target for r in reqs},
    }
    out.reason = _why_session(out, unmet)
    return out


def _settled(out: NextTest, unmet, clean: bool, met: str, test: str) -> bool:
    """Whether the step ends without a test, its status and reason set: the goal met (a ``clean`` diagnosis and
    nothing ``unmet``; ``met`` ends the reason), or blocked (nothing unmet, but the diagnosis finds what no further
    ``test`` resolves)."""
    if unmet:
        return False
    d = out.diagnosis
    if clean:
        out.status = "goal-met"
        out.reason = f"goal met: the diagnosis at α = {d.alpha:.2g} finds nothing missing{met}"
    else:
        out.status = "blocked"
        out.reason = f"the diagnosis finds what no named effect or further {test} of the goal resolves: " + _findings(d)
    return True


def _why_session(out: NextTest, unmet) -> str:
    """Why this session: the unmet requirements, worst first, and where the session takes them."""
    order = sorted(unmet, key=lambda i: -_ratio(out.sigma_now[i], out.requirements[i].target))
    parts = [
        f"{rq.describe(out.requirements[i], out.sigma_now[i], out.alpha_detect, out.goal)} → "
        f"{out.sigma_after[i]:.3g} after it"
        for i in order[:6]
    ]
    more = f" (and {len(order) - 6} more)" if len(order) > 6 else ""
    proto = out.design
    rests = sum(s["type"] == "rest" for s in proto.steps)
    turns = f", {proto.turn_pairs} pair(s) of known-angle turns about each body axis" if proto.turn_pairs else ""
    met = all(out.sigma_after[i] <= out.requirements[i].target for i in unmet)
    what = (
        "the shortest hand session found whose information, added to the records', meets every target"
        if met
        else "the longest session a person runs, designed to bring the worst σ nearest its target (more follow)"
    )
    return (
        f"to bring the model's σ to target: {what}: {rests} rests in {out.hours * 60.0:.3g} min{turns}; "
        + "; ".join(parts)
        + more
    )


def _anticipated(reqs, sigma_now, goal: Goal, terms=(), alias=()) -> list | None:
    """The requirements with every watched candidate c the records have not seen at all (σ = ∞: nothing so far
    excites it) asked at its σ target, as if it were in the model; None when there is none. Nothing has lowered
    the chance that such a candidate is present, and a present one, once a test excites it, is added and must then
    reach that target: a test shaped for its detection alone leaves most of that to later tests. With an alias
    group G to separate, each model the records may hold is asked for: c and the member g both at target in
    M ∪ {g, c}, for every g of G."""
    members = [g for g in alias if g not in terms]
    out, changed = [], False
    for r, x in zip(reqs, sigma_now):
        s = goal.target(r.coefficient)
        if not (r.kind == "detect" and not math.isfinite(x) and s is not None and s < r.target):
            out.append(r)
            continue
        changed = True
        if not members:
            out.append(replace(r, target=s))
        for g in members:
            sub = tuple(terms) + (g, r.effect)
            out.append(replace(r, target=s, effects=sub))
            eff = fx.get(g)
            out += [
                rq.Requirement("sigma", c, sub, goal.target(c), u)
                for c, u in zip(eff.coefficients, eff.units)
                if goal.target(c) is not None
            ]
    return out if changed else None


def _predicted(uni, reqs, f_rec, lab, noise, plan, res, start) -> np.ndarray:
    """σ of every requirement after the plan as written (whole samples, its gaps), with the full noise model."""
    import jax.numpy as jnp

    keys = {fx.TDF: ("x", "y", "z"), fx.ACCEL: ("ia", "pa", "oa")}.get(lab.kind, ("ia", "oa", "sa"))
    table, theta = lab.table(), jnp.asarray(_theta(uni, res))
    f = np.array(f_rec, dtype=float)
    t0 = start
    for run in plan.runs:
        ang = jnp.deg2rad(jnp.asarray([s.start_deg for s in run.segments]))
        dwell = jnp.asarray([s.duration_s for s in run.segments])
        triad = jnp.asarray([run.instrument[k] for k in keys], dtype=float)
        f += np.asarray(compiled_information(uni, noise)(table.template, triad, ang, dwell, t0, run.gap_s, theta))
        t0 += run.duration_s + plan.gap_between_runs_s
    return rq.sigmas(f, reqs, uni)


def _unmet_text(out: NextTest, unmet) -> str:
    order = sorted(unmet, key=lambda i: -_ratio(out.sigma_now[i], out.requirements[i].target))
    return "; ".join(rq.describe(out.requirements[i], out.sigma_now[i], out.alpha_detect, out.goal) for i in order)


def _ratio(sigma, target) -> float:
    return math.inf if not math.isfinite(sigma) else sigma / target


def _why(out: NextTest, unmet) -> str:
    """Why this test: the unmet requirements, worst first, and what the test makes of them."""
    order = sorted(unmet, key=lambda i: -_ratio(out.sigma_now[i], out.requirements[i].target))
    parts = []
    for i in order[:6]:
        r = out.requirements[i]
        after = out.sigma_after[i]
        parts.append(f"{rq.describe(r, out.sigma_now[i], out.alpha_detect, out.goal)} → {after:.3g} after it")
    more = f" (and {len(order) - 6} more)" if len(order) > 6 else ""
    kinds = {out.requirements[i].kind for i in unmet}
    head = []
    if "separate" in kinds:
        head.append(f"separate {' / '.join(out.alias)}")
    if "detect" in kinds:
        head.append("rule out the watched candidates the records cannot see")
    if "sigma" in kinds:
        head.append("bring the model's σ to target")
    runs = out.plan.runs
    mounts = " and ".join(str(np.round(t[0], 3).tolist()) for t in out.design.triads)
    return (
        f"to {', '.join(head)}: {sum(len(r.segments) for r in runs)} static positions in {len(runs)} run(s), "
        f"{out.design.dwell_hours:.3g} h of dwell ({out.hours:.3g} h on the table), first instrument axis along "
        f"{mounts} (platform coordinates); " + "; ".join(parts) + more
    )


def _findings(d) -> str:
    if d is None:
        return "no diagnosis"
    found = [s.to_json().get("versus", "") + " " + s.to_json().get("shape", "") for s in d.unexplained[:3]]
    sig = [
        f"{c.name} ({c.implausible or c.refused})"
        for c in d.candidates
        if c.p_adjusted < d.alpha and (c.implausible or c.refused)
    ]
    return "; ".join(x.strip() for x in found + sig if x.strip()) or f"verdict {d.verdict}"
