"""The table hours Hu's classical sequence needs to reach the same σ, on the same truth, by the same simulation.

**The sequence** (Hu ch. 3), as the plan builders of :mod:`gyrojax.data.plans` make them, in their default
proportions: for an SDF gyro the 24-position static test on the two-axis table (``multiposition``, 10 min a
position), then the polar tumble (``tumble``: 2 revolutions at 10 Earth rates, CCW and CW, upright and flipped),
then the polar servo test (``servo``, 24 h); for a TDF gyro the eight-position test (``eight_position``, 10 min)
then its polar tumble (``tdf_tumble``, 2 revolutions); for a pendulous accelerometer the dividing-head tumble
(``accel_tumble``, 36 positions of 60 s) in Hu's two states, the output axis and then the pendulous axis along the
head axis (Hu 3-42, 3-43: one shows K_IP, the other K_IO).

**Scaled to reach the σ.** Every measuring time of the sequence — the dwell of each position, the revolutions of
each tumble, the hours of the servo run — is multiplied by one scale s (the settling and remounting gaps are not);
its table hours are the scaled plan's duration (runs, gaps, remounts). The sequence *reaches* the goal at the
smallest s at which the fit of the campaign's final model to the sequence's records, simulated from the truth, has
every coefficient's σ at or below its target. s is found from the Fisher information of the noise-free sequence at
s = 1 (σ² ∝ 1/s: every measuring time scaled alike; the truth's noise, its Gauss–Markov terms as their long-run
white equivalent), then checked by simulating the sequence at s from the truth (the campaign's seed) and fitting:
while a fitted σ exceeds its target, s grows by the squared ratio (at most :data:`CHECKS` times; a σ still above
its target at the last check is stated in ``reason`` beside the hours). The sample
interval scales with s, so every run keeps its number of samples: white-noise information depends on the measuring
time, not the interval.

**A hand-held triad's classical calibration** (:func:`hand_classical_hours`): the campaign's first session — with
``--first ferraris`` imucal's Ferraris protocol, the standard hand calibration — repeated n times, each repetition a
session of its own (a person does not hold a box still for hours: the session is repeated, not lengthened), fitted
jointly with the campaign's final model. n is the fewest at which every σ reaches its target: from the Fisher
information of one session at the truth's noise (:func:`gyrojax.planning.triad_protocol.steps_fisher`; n sessions
carry n times it, so σ² ∝ 1/n), then checked by simulating the n sessions from the truth (their own seeds) and
fitting (:func:`gyrojax.inference.triad.fit_triad`, which estimates the noise as the loop's fits do): while a fitted
σ exceeds its target, n grows by the squared ratio (at most :data:`CHECKS` times). Beyond
:data:`MAX_CHECKED_SESSIONS` sessions the hours stand on the Fisher information alone, and ``reason`` says so. A
first session that does not identify a targeted coefficient of the final model (its information singular there:
no number of repetitions reaches the target) gives no hours, with the reason; so does a truth that draws no noise
(its simulated σ are zero at any length).

**The best split.** Beside the sequence in its own proportions, the hours of the most favourable split of time
among its tests (the scale of each test chosen apart, minimising the total measuring time under the σ targets;
Fisher information only): a lower bound on what any lab would spend on that sequence.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import jax
import numpy as np

from gyrojax.data import plans
from gyrojax.errors import ModelError
from gyrojax.inference.identify import fit
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics import effects as fx
from gyrojax.physics import triad as tp
from gyrojax.physics.model import Model
from gyrojax.planning.fisher import record_fisher
from gyrojax.simulation.simulator import simulate

CHECKS = 3
"""Simulated checks of the scale (each one a simulation and a fit of the whole sequence)."""
MAX_CLASSICAL_HOURS = 1.0e5
"""Table hours (h, about 11 years) beyond which the classical sequence is reported as not a test anyone runs (its
hours are then null, with the coefficient whose σ target asks for them), never as a number."""
MAX_CHECKED_SESSIONS = 40
"""Repetitions of a hand session beyond which the classical hours are not checked by simulation (Fisher only)."""
_NOISELESS = (
    "the truth draws no noise ({} is 0): its simulated σ are zero at any length, so no classical hours are defined"
)
SAMPLES = {"position": 20, "tumble": 720, "servo": 1440, "head": 30}
"""Samples per static position, per tumble run, per servo run and per dividing-head position, at every scale."""


def white_equivalent(noise) -> float:
    """N_eff (deg/√h): √(N² + Σ 2σ²τ/3600), the noise's long-run white equivalent (each Gauss–Markov term's
    variance of a mean over T ≫ τ is 2σ²τ/T): the sequence's runs are long against the drift's τ."""
    return math.sqrt(noise.white**2 + sum(2.0 * s * s * tau / 3600.0 for s, tau in noise.gauss_markov))


def sequence(kind: str, scale: float, latitude_deg: float = plans.DEFAULT_LATITUDE) -> list:
    """The classical sequence of ``kind`` at ``scale`` as a list of (test name, plan)."""
    s = float(scale)
    if kind in (fx.SDF, fx.FOG, fx.RLG):
        mp = plans.multiposition(24, minutes=10.0 * s, dt_s=600.0 * s / SAMPLES["position"], latitude_deg=latitude_deg)
        rev = 2.0 * s
        turn_s = 360.0 / (10.0 * 15.04107 / 3600.0)
        tb = plans.tumble(revolutions=rev, dt_s=rev * turn_s / SAMPLES["tumble"], latitude_deg=latitude_deg)
        sv = plans.servo("polar", hours=24.0 * s, dt_s=24.0 * 3600.0 * s / SAMPLES["servo"], latitude_deg=latitude_deg)
        out = [("multi-position", mp), ("tumble", tb), ("servo", sv)]
        if kind != fx.SDF:
            out = [(n, _with_kind(p, kind)) for n, p in out]
        return out
    if kind == fx.TDF:
        ep = plans.eight_position(
            10.0 * s, dt_s=600.0 * s / SAMPLES["position"], kind=fx.TDF, latitude_deg=latitude_deg
        )
        rev = 2.0 * s
        turn_s = 360.0 / (10.0 * 15.04107 / 3600.0)
        tb = plans.tdf_tumble(rev, dt_s=rev * turn_s / SAMPLES["tumble"], latitude_deg=latitude_deg)
        return [("eight-position", ep), ("tumble", tb)]
    if kind == fx.ACCEL:
        dwell, dt = 60.0 * s, 60.0 * s / SAMPLES["head"]
        return [
            ("dividing-head tumble, OA along the head", plans.accel_tumble(36, dwell, dt, latitude_deg, "oa")),
            ("dividing-head tumble, PA along the head", plans.accel_tumble(36, dwell, dt, latitude_deg, "pa")),
        ]
    raise ModelError(f"no classical sequence for a {kind}")


def _with_kind(plan, kind):
    from dataclasses import replace

    runs = tuple(replace(r, instrument={**r.instrument, "kind": kind}) for r in plan.runs)
    return replace(plan, runs=runs)


def joined(tests) -> plans.Plan:
    """The tests of a sequence as one plan, in order, on one clock."""
    runs = tuple(r for _, p in tests for r in p.runs)
    first = tests[0][1]
    return plans.Plan(
        "classical", runs, first.latitude_deg, description="Hu's classical sequence", reference="Hu ch. 3"
    )


def _hours(tests) -> float:
    return float(joined(tests).duration_s) / 3600.0


@dataclass
class ClassicalResult:
    """The classical sequence that reaches the goal: its scale, hours, and the fit after each of its tests."""

    scale: float | None
    hours: float | None
    sigma: dict  # fitted σ of every coefficient of the final model (report units) at that scale
    path: list = field(default_factory=list)  # per test: cumulative hours, σ, residual RMS
    best_split_hours: float | None = None
    reason: str = ""

    def to_json(self) -> dict:
        """JSON: scale, hours, σ, the path through the sequence, the best split and why (when not reached)."""
        return {
            "scale": self.scale,
            "hours": self.hours,
            "sigma": self.sigma,
            "path": self.path,
            "best_split_hours": self.best_split_hours,
            "reason": self.reason,
        }


def _information(model: Model, tests, noise: NoiseSpec):
    out = []
    for _, p in tests:
        recs = simulate(p, {"coefficients": {}})
        out.append(record_fisher(model, recs, noise))
    return out


def _variances(f, idx) -> np.ndarray:
    d = np.sqrt(np.maximum(np.diag(f), 1e-300))
    try:
        inv = np.linalg.inv(f / np.outer(d, d)) / np.outer(d, d)
    except np.linalg.LinAlgError:
        return np.full(len(idx), np.inf)
    v = np.diag(inv)[idx]
    return np.where(v > 0, v, np.inf)


def _best_split(infos, base_hours, targets, idx) -> float | None:
    """Fewest measuring hours Σ s_k·H_k with every σ² of Σ s_k F_k ≤ target² (Fisher only), plus the gaps."""
    from scipy import optimize

    h = np.asarray(base_hours)

    def worst(x):
        f = sum(math.exp(v) * fk for v, fk in zip(x, infos))
        return float(np.max(_variances(f, idx) / targets**2))

    def objective(x):
        return float(np.exp(x) @ h)

    x0 = np.zeros(len(infos))
    w0 = worst(x0)
    if not math.isfinite(w0):
        return None
    x0 = x0 + math.log(w0)
    res = optimize.minimize(
        objective,
        x0,
        method="SLSQP",
        constraints=[{"type": "ineq", "fun": lambda x: 1.0 - worst(x)}],
        bounds=[(x0[0] - 25.0, x0[0] + 10.0)] * len(infos),
    )
    x = res.x if res.success and worst(res.x) <= 1.0 + 1e-6 else x0
    return float(np.exp(x) @ h)


def classical_hours(truth, terms, goal, kind: str, seed: int = 0, latitude_deg: float = plans.DEFAULT_LATITUDE):
    """The :class:`ClassicalResult` of ``kind``'s classical sequence for the model ``terms`` and ``goal``'s σ
    targets on ``truth`` (module doc)."""
    from gyrojax.data.truth import Truth, truth_from_dict

    truth = truth if isinstance(truth, Truth) else truth_from_dict(truth)
    model = Model.of(terms, kind)
    names = model.coefficient_names
    targets = np.array([goal.target(c) or math.inf for c in names])
    idx = np.arange(model.size)
    if truth.noise.is_zero:
        return ClassicalResult(None, None, {}, reason=_NOISELESS.format("noise"))
    white = white_equivalent(truth.noise)
    if not white > 0.0:
        return ClassicalResult(
            None,
            None,
            {},
            reason="the truth's noise has no white or Gauss–Markov part, the classical sequence's information is "
            "computed from them: its hours are not computed for this noise",
        )
    noise = NoiseSpec(white=white)
    base = sequence(kind, 1.0, latitude_deg)
    infos = _information(model, base, noise)
    measure = [_hours([t]) - _gap_hours(t[1]) for t in base]
    v1 = _variances(sum(infos), idx)
    if not np.all(np.isfinite(v1)):
        bad = [c for c, v in zip(names, v1) if not math.isfinite(v)]
        return ClassicalResult(None, None, {}, reason=f"the classical sequence does not identify {', '.join(bad)}")
    scale = float(np.max(v1 / targets**2))
    need = _hours(sequence(kind, scale, latitude_deg))
    if not need <= MAX_CLASSICAL_HOURS:
        worst = names[int(np.argmax(v1 / targets**2))]
        return ClassicalResult(
            None,
            None,
            {},
            reason=f"the classical sequence would need {need:.3g} table hours for {worst}'s σ target "
            f"{goal.target(worst):g} (its own unit): beyond {MAX_CLASSICAL_HOURS:g} h, no test anyone runs",
        )
    best_split = _best_split(infos, measure, targets, idx)
    if best_split is not None:
        best_split += sum(_gap_hours(p) for _, p in base) + joined(base).gap_between_runs_s * (len(base) - 1) / 3600.0
    key = jax.random.fold_in(jax.random.PRNGKey(seed), 7919)

    def run(scale):
        tests = sequence(kind, scale, latitude_deg)
        recs = simulate(joined(tests), truth, key=key)
        return tests, recs, fit(recs, list(model.terms))

    scale, (tests, recs, res), ratio = _checked(run, scale, names, targets, lambda s, r: s * r**2 * 1.001)
    path = _path(recs, tests, model, res)
    return ClassicalResult(scale, _hours(tests), res.stds, path, best_split, reason=_short(ratio))


def _checked(run, scale, names, targets, grow, beyond=lambda scale: False):
    """``(scale, run(scale), worst σ/target)`` once the fit of the simulated ``run(scale)`` (its last item) meets
    every target, the scale grown by ``grow(scale, worst ratio)`` at most :data:`CHECKS` times; the run is ``None``
    where the grown scale is ``beyond`` what is checked by simulation."""
    for check in range(CHECKS + 1):
        out = run(scale)
        ratio = max(out[-1].stds[c] / t for c, t in zip(names, targets))
        if ratio <= 1.0 or check == CHECKS:
            return scale, out, ratio
        scale = grow(scale, ratio)
        if beyond(scale):
            return scale, None, ratio


def _gap_hours(plan) -> float:
    """Unscaled gaps of a plan: between positions and between its runs (h)."""
    gaps = sum(r.gap_s * (len(r.segments) - 1) for r in plan.runs) + plan.gap_between_runs_s * (len(plan.runs) - 1)
    return gaps / 3600.0


def _path(recs, tests, model: Model, last) -> list:
    """After each test of the sequence: cumulative table hours, fitted σ (report units; null where the records so far
    do not identify a coefficient), residual RMS and noise floor (output units); ``last`` the fit of every record."""
    out, n = [], 0
    for i, (name, p) in enumerate(tests):
        n += len(p.runs)
        clock = float(joined(tests[: i + 1]).duration_s) / 3600.0
        last_test = i == len(tests) - 1
        out.append(
            _point(name, clock, lambda: last if last_test else fit(recs[:n], list(model.terms), allow_aliases=True))
        )
    return out


def _point(test: str, hours: float, fitted) -> dict:
    """A point of a path: the cumulative hours after ``test``, and the σ (null where not identified), residual RMS
    and noise floor of the fit ``fitted()``; σ empty and the rest null where the records so far do not identify the
    model (:class:`~gyrojax.errors.ModelError`)."""
    try:
        res = fitted()
    except ModelError:
        return {"test": test, "hours": hours, "sigma": {}, "residual_rms": None, "noise_floor": None}
    sigma = {c: (v if math.isfinite(v) else None) for c, v in res.stds.items()}
    return {
        "test": test,
        "hours": hours,
        "sigma": sigma,
        "residual_rms": res.residual_rms,
        "noise_floor": res.noise_floor,
    }


def hand_classical_hours(truth, first, terms, goal, seed: int = 0) -> ClassicalResult:
    """The :class:`ClassicalResult` of the hand calibration ``first`` — (start attitude, steps) of a
    :class:`~gyrojax.data.truth.TriadTruth`'s first session — repeated until the model ``terms`` reaches ``goal``'s σ
    targets on ``truth`` (module doc). ``scale`` is the number of sessions n, ``hours`` n times one session's."""
    from gyrojax.inference.triad import fit_triad
    from gyrojax.planning import triad_protocol as tpr
    from gyrojax.planning.triad_fisher import TriadNoise
    from gyrojax.simulation.triad_session import simulate_session

    start, steps = first
    session_h = tpr.session_seconds(steps) / 3600.0
    opts = truth.session_options()
    if not (truth.arw > 0.0 and opts["acc_noise_g"] > 0.0):
        key = "noise.white" if not truth.arw > 0.0 else "session.acc_noise_g"
        return ClassicalResult(None, None, {}, reason=_NOISELESS.format(key))
    try:
        model = tpr.triad_model(terms)
    except ModelError as e:
        return ClassicalResult(None, None, {}, reason=f"the first session's hours for this model are not computed: {e}")
    noise = TriadNoise(
        arw=truth.arw,
        acc_noise_g=opts["acc_noise_g"],
        rate_hz=opts["rate_hz"],
        latitude_deg=None,  # the simulated records leave the site unknown, as a hand session's
        earth_rate=opts["earth_rate"],
        placement_deg=opts["placement_deg"],
    )
    names = list(tp.channel_names(model))
    targets = np.array([goal.target(c) or math.inf for c in names])
    one = tpr.sigma(tpr.steps_fisher(model, start, steps, noise), model)
    v1 = np.array([one[c] for c in names]) ** 2
    bad = [c for c, v, t in zip(names, v1, targets) if not math.isfinite(v) and math.isfinite(t)]
    if bad:
        return ClassicalResult(
            None,
            None,
            {},
            reason=f"the first session does not identify {', '.join(bad[:6])}"
            + (f" (and {len(bad) - 6} more)" if len(bad) > 6 else "")
            + ": no number of its repetitions reaches their targets",
        )
    n = max(1, math.ceil(float(np.max(v1 / targets**2))))
    if n * session_h > MAX_CLASSICAL_HOURS:
        worst = names[int(np.argmax(v1 / targets**2))]
        return ClassicalResult(
            None,
            None,
            {},
            reason=f"the first session hardly sees {worst} (σ {math.sqrt(v1[names.index(worst)]):.3g} after one): it "
            f"would be repeated {float(n):.3g} times ({n * session_h:.3g} h) for its σ target {goal.target(worst):g}, "
            f"beyond {MAX_CLASSICAL_HOURS:g} h, no calibration anyone runs",
        )
    if n > MAX_CHECKED_SESSIONS:
        sigma = {c: float(math.sqrt(v / n)) for c, v in zip(names, v1)}
        note = f"{n} sessions: beyond {MAX_CHECKED_SESSIONS}, the hours stand on the Fisher information alone"
        return ClassicalResult(n, n * session_h, sigma, reason=note)
    sim = truth.simulation_options()

    def run(n):
        recs = []
        for i in range(n):
            sub = int(np.random.SeedSequence([seed, 7919, i]).generate_state(1)[0])
            recs.append(simulate_session(steps, truth.coefficients, start_attitude=start, seed=sub, **sim))
        return recs, fit_triad(recs, list(model.terms))

    n, out, ratio = _checked(
        run, n, names, targets, lambda n, r: math.ceil(n * r**2 * 1.001), lambda n: n > MAX_CHECKED_SESSIONS
    )
    if out is None:
        note = (
            f"the simulated sessions leave a σ {ratio:.3g} × its target: {n} sessions, beyond "
            f"{MAX_CHECKED_SESSIONS}, are not checked by simulation"
        )
        return ClassicalResult(n, n * session_h, {}, reason=note)
    recs, res = out
    path = [
        _point(
            f"{k} × the first session",
            k * session_h,
            lambda: res if k == n else fit_triad(recs[:k], list(model.terms)),
        )
        for k in sorted({1, n})
    ]
    return ClassicalResult(n, n * session_h, dict(res.stds), path, reason=_short(ratio))


def _short(ratio: float) -> str:
    """Why hours whose last simulated check left a σ above its target are stated anyway ("" when none is)."""
    if ratio <= 1.0:
        return ""
    return f"after {CHECKS} rescalings the simulated fit still leaves a σ {ratio:.3g} × its target: the hours are short"
