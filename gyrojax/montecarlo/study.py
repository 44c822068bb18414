"""Monte Carlo studies of identification: many simulated gyros, one least-squares fit each, in pure JAX.

A *draw* d of a study is, with its own key k_d = fold_in(key(seed), d) (so a draw never depends on the batch
size, the chunking, the number of devices or the number of processes):

1. truth θ_d from the priors: coefficients ~ N(μ, σ²) or U(a, b); set-up errors (``table_tilt``,
   ``table_azimuth``, ``encoder_harmonic``, arcsec) likewise;
2. read angles: on the encoder axis the table reads θ + h(θ) (Hu 5-51); measurements
   y = predict(M_true, θ_d, read data) + n_d, with n_d the random drift of :mod:`gyrojax.noise` (white and
   Gauss–Markov ...) at the plan's sample times;
3. regressors J = ∂predict(M_fit, θ, read data)/∂θ at θ = 0 with the *nominal* set-up (``jax.jacfwd``), so set-up
   errors are unmodelled unless M_fit names them; r = y − predict(M_fit, 0, read data);
4. least squares on the valid rows (weight 1), by :func:`gyrojax.inference.lstsq.lstsq` (column-normalised normal
   equations by Cholesky, or QR): θ̂ = (JᵀJ)⁻¹Jᵀr, σ̂² = |r − Jθ̂|²/(m − p), cov = σ̂²(JᵀJ)⁻¹. Models with set-up
   effects take three Gauss–Newton steps.

**Static plans** (every record a sequence of fixed positions, no rate, no time- or temperature-dependent effect):
the inputs, and so the signal and the regressors, are constant on each run of samples at one position. Each draw
then evaluates the models once per run and the noise, still drawn sample by sample, enters through its per-run sums
Σe and Σe² only: Jᵀr = Σ_runs j (n d + Σe), |r|² = Σ_runs (n d² + 2 d Σe + Σe²) with d the run's signal minus
prediction — the same numbers as the sample-level fit, to rounding, at the cost of drawing the noise
(:func:`constant_runs`).

The white-noise standard error is exact for white noise; under coloured drift it is not, and
:func:`draw_records` writes a draw as records so the GLS fit of :func:`gyrojax.inference.identify.fit` can be
checked on it.

Servo records are simulated conditionally on the nominal (noise-free) trajectory: the regressors see the same
read angles the measurements were generated at, which is exact for models linear in θ given the read angles.

A study is a JSON object (:class:`Study`); :func:`run_study` evaluates it in chunks (bounded memory) over a 1-D
mesh of devices (``jax.sharding.NamedSharding``); :func:`summarize` gives bias, RMS error, mean σ̂ and the coverage
of θ̂ ± σ̂ and θ̂ ± 2σ̂ per coefficient. ``gyrojax mc STUDY.json --out DIR`` runs one from the command line. In a
``jax.distributed`` job :func:`run_study` splits the draws over the processes and gathers them
(:mod:`gyrojax.montecarlo.hosts`); results of separate draw ranges merge with :func:`merge_results`.

Draws evaluate the measurement model itself (:func:`gyrojax.physics.model.predict`, whose kinematics work on whole
records in vector form), with the (cos, sin) of the plan's angles precomputed
(:func:`gyrojax.physics.model.angle_trig`).
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.data import plans as plans_mod
from gyrojax.data.arrays import record_data
from gyrojax.data.record import Record
from gyrojax.data.truth import SETUP_SIZES
from gyrojax.errors import GyrojaxError
from gyrojax.inference.lstsq import lstsq, lstsq_normal
from gyrojax.noise.processes import random_drift, validate_noise
from gyrojax.physics import effects as fx
from gyrojax.physics.kinematics import turn
from gyrojax.physics.model import (
    Model,
    RecordData,
    angle_trig,
    encoder_error_trig,
    indicated_output,
    instrument_inputs,
    predict,
    setup_values,
)
from gyrojax.protocol import atomic_write_bytes, atomic_write_text, read_json_file

STUDY_FORMAT = "gyrojax-mc-study-1"
SDF_NINE_TERMS = ("D_F", "D_I", "D_O", "D_S", "D_II", "D_SS", "D_IO", "D_IS", "D_OS")
"""The SDF drift model less D_OO: in a 1 g test a_I² + a_O² + a_S² = 1, so D_F, D_II, D_OO, D_SS are aliased."""


class StudyError(GyrojaxError, ValueError):
    """A Monte Carlo study definition is malformed (the message names the key)."""


# ---- study definition -------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Study:
    """A Monte Carlo study (JSON-serialisable; :meth:`to_dict` / :func:`study_from_dict`).

    ``priors`` and ``setup`` map a coefficient name (or an effect name: every coefficient of it) to a prior:
    a number (fixed), ``{"normal": [mean, std]}`` or ``{"uniform": [low, high]}``, report units (arcsec for the
    set-up errors). ``noise`` is a noise dict of :mod:`gyrojax.noise` (e.g. ``{"white": 0.01}``).
    """

    plan: str
    terms: tuple[str, ...]
    priors: dict = field(default_factory=dict)
    setup: dict = field(default_factory=dict)
    noise: dict = field(default_factory=dict)
    draws: int = 1000
    seed: int = 0
    plan_options: dict = field(default_factory=dict)
    kind: str = fx.SDF
    chunk: int | None = None
    solver: str = "cholesky"

    def to_dict(self) -> dict:
        """The study as a JSON-ready dict (the study file format, ``STUDY_FORMAT``)."""
        d = asdict(self)
        d["terms"] = list(self.terms)
        d["noise"] = {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.noise.items()}
        d["format"] = STUDY_FORMAT
        return d

    def to_json(self) -> str:
        """The study file text (indented JSON of :meth:`to_dict`)."""
        return json.dumps(self.to_dict(), indent=1)


_STUDY_KEYS = (
    "format",
    "plan",
    "plan_options",
    "terms",
    "priors",
    "setup",
    "noise",
    "draws",
    "seed",
    "kind",
    "chunk",
    "solver",
)


def _prior(v, where: str):
    """(is_uniform, a, b) of a prior: number → N(v, 0); {"normal": [μ, σ]}; {"uniform": [lo, hi]}."""
    if isinstance(v, bool):
        raise StudyError(f"{where}: a prior must be a number or {{'normal': [mean, std]}} / {{'uniform': [lo, hi]}}")
    if isinstance(v, (int, float)):
        if not math.isfinite(v):
            raise StudyError(f"{where}: must be finite, got {v!r}")
        return False, float(v), 0.0
    if not isinstance(v, dict) or len(v) != 1 or next(iter(v)) not in ("normal", "uniform"):
        raise StudyError(
            f"{where}: a prior must be a number or {{'normal': [mean, std]}} / {{'uniform': [lo, hi]}}, got {v!r}"
        )
    ((k, ab),) = v.items()
    if (
        not isinstance(ab, (list, tuple))
        or len(ab) != 2
        or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in ab)
    ):
        raise StudyError(f"{where}.{k}: needs two finite numbers, got {ab!r}")
    a, b = float(ab[0]), float(ab[1])
    if k == "normal" and b < 0:
        raise StudyError(f"{where}.normal: std must be >= 0, got {b}")
    if k == "uniform" and b < a:
        raise StudyError(f"{where}.uniform: needs low <= high, got {ab!r}")
    return k == "uniform", a, b


def _expand(name: str, where: str, setup: bool) -> tuple[str, ...]:
    """Coefficient names of a prior key (a coefficient, or an effect = all its coefficients)."""
    idx = fx.coefficient_index()
    if name in fx.names():
        eff = fx.get(name)
        coeffs = eff.coefficients
    elif name in idx:
        eff = fx.get(fx.effect_of_coefficient(name))
        coeffs = (name,)
    else:
        raise StudyError(f"{where}: key {name!r} is neither an effect nor a coefficient name")
    if setup and eff.name not in SETUP_SIZES:
        raise StudyError(f"{where}: key {name!r} is not a set-up error; valid: {', '.join(SETUP_SIZES)}")
    if not setup and eff.name in SETUP_SIZES:
        raise StudyError(f"{where}: key {name!r} is a set-up error; give its prior under 'setup'")
    return coeffs


def study_from_dict(d, where: str = "study") -> Study:
    """Validate a study dict; every error names the offending key."""
    if not isinstance(d, dict):
        raise StudyError(f"{where}: the top level must be an object")
    for k in d:
        if k not in _STUDY_KEYS:
            raise StudyError(f"{where}: unknown key {k!r}; valid: {', '.join(_STUDY_KEYS)}")
    if d.get("format", STUDY_FORMAT) != STUDY_FORMAT:
        raise StudyError(f"{where}: key 'format' must be {STUDY_FORMAT!r}, got {d.get('format')!r}")
    if "plan" not in d:
        raise StudyError(f"{where}: missing required key 'plan' (a built-in plan name)")
    if d["plan"] not in plans_mod.BUILDERS:
        raise StudyError(f"{where}: key 'plan' = {d['plan']!r}; built-in plans: {', '.join(plans_mod.BUILDERS)}")
    opts = d.get("plan_options") or {}
    if not isinstance(opts, dict):
        raise StudyError(f"{where}: key 'plan_options' must be an object")
    terms = d.get("terms")
    if not isinstance(terms, (list, tuple)) or not terms or not all(isinstance(t, str) for t in terms):
        raise StudyError(f"{where}: key 'terms' must be a non-empty list of effect names")
    kind = d.get("kind", fx.SDF)
    if kind not in (fx.SDF, fx.TDF, fx.ACCEL):
        raise StudyError(f"{where}: key 'kind' = {kind!r}; valid: {fx.SDF}, {fx.TDF}, {fx.ACCEL}")
    try:
        Model.of(terms, kind)
    except GyrojaxError as e:
        raise StudyError(f"{where}: key 'terms': {e}") from None
    for key, setup in (("priors", False), ("setup", True)):
        pr = d.get(key) or {}
        if not isinstance(pr, dict):
            raise StudyError(f"{where}: key {key!r} must be an object")
        for name, v in pr.items():
            _expand(name, f"{where}: key '{key}.{name}'", setup)
            _prior(v, f"{where}: key '{key}.{name}'")
    try:
        noise = validate_noise(d.get("noise"), f"{where}: key 'noise'")
    except GyrojaxError as e:
        raise StudyError(str(e)) from None
    for key in ("draws", "seed", "chunk"):
        v = d.get(key)
        if v is None and key != "draws":
            continue
        if key == "draws" and v is None:
            v = 1000
        if isinstance(v, bool) or not isinstance(v, int) or v < (0 if key == "seed" else 1):
            raise StudyError(f"{where}: key {key!r} must be an integer >= {0 if key == 'seed' else 1}, got {v!r}")
    solver = d.get("solver", "cholesky")
    if solver not in ("cholesky", "qr"):
        raise StudyError(f"{where}: key 'solver' = {solver!r}; valid: cholesky, qr")
    return Study(
        plan=d["plan"],
        terms=tuple(terms),
        priors=dict(d.get("priors") or {}),
        setup=dict(d.get("setup") or {}),
        noise=noise,
        draws=int(d.get("draws", 1000)),
        seed=int(d.get("seed", 0)),
        plan_options=dict(opts),
        kind=kind,
        chunk=d.get("chunk"),
        solver=solver,
    )


def load_study(path) -> Study:
    """Load and validate a study from a JSON file (errors name the file and the key)."""
    return study_from_dict(read_json_file(path, StudyError, "a study"), str(path))


# ---- the per-draw pipeline ---------------------------------------------------------------------------------------


def nominal_records(plan, kind: str | None = None) -> list[Record]:
    """Noise-free records of a perfect instrument on ``plan``: its geometry and sample times (s)."""
    from gyrojax.simulation.simulator import simulate

    return simulate(plan, {}, seed=0)


@dataclass
class Pipeline:
    """A study compiled to arrays: nominal records, models and prior vectors; :meth:`draw` is pure JAX.

    Priors and θ are in report units (deg/h, deg/h/g, ppm, …); ``noise`` as in truth files (CONVENTIONS §8);
    ``dt_white`` the averaging interval (s) of white and quantisation noise per record.
    """

    records: list
    data: tuple
    fit_model: Model
    truth_model: Model
    prior_uniform: np.ndarray
    prior_a: np.ndarray
    prior_b: np.ndarray
    noise: dict
    dt_white: tuple
    solver: str = "cholesky"
    seed: int = 0
    trig: tuple = ()  # per record, per axis (cos, sin) of the nominal angles
    runs: tuple | None = None  # static plans: per record (run index of every sample, first sample of every run)
    _sim_jit: object = field(default=None, repr=False)
    _compiled: dict = field(default_factory=dict, repr=False)  # (devices, chunk) → compiled chunk function

    @property
    def n_measurements(self) -> int:
        """Number of measurements of one draw, summed over the records."""
        return int(sum(float(np.asarray(d.weight).sum()) for d in self.data))

    def truth_index(self) -> np.ndarray:
        """Position of every fitted coefficient in the truth model's θ (integer indices)."""
        names = self.truth_model.coefficient_names
        return np.array([names.index(c) for c in self.fit_model.coefficient_names])

    def draw_truth(self, key):
        """A truth θ drawn from the priors (report units): uniform on [a, b] or normal with mean a, std b."""
        kz, ku = jax.random.split(key)
        p = self.truth_model.size
        z = jax.random.normal(kz, (p,))
        u = jax.random.uniform(ku, (p,))
        a, b = jnp.asarray(self.prior_a), jnp.asarray(self.prior_b)
        return jnp.where(jnp.asarray(self.prior_uniform), a + (b - a) * u, a + b * z)

    def record_noise(self, key, i: int, data: RecordData):
        """Random drift on the measurements of record ``i`` (deg/h), as the simulator adds it."""
        if not self.noise:
            return jnp.zeros(data.y.shape)
        t = np.asarray(self.records[i].time_s, dtype=float)
        k = jax.random.fold_in(key, i)
        if data.kind == fx.TDF:
            return jnp.concatenate(
                [random_drift(jax.random.fold_in(k, c), t, self.noise, self.dt_white[i]) for c in range(2)]
            )
        nu = random_drift(k, t, self.noise, self.dt_white[i])
        if data.mode == "servo":
            return nu[1:] * data.weight
        return nu

    def read_data(self, theta_true, i: int, reduced: bool = False):
        """Record ``i`` as read with the truth's encoder error, θ_read = θ + h(θ) on the encoder axis (Hu 5-51):
        (data, per-axis (cos, sin) of the read angles or None for servo records). ``reduced``: one row per run
        of :attr:`runs` (static plans)."""
        data = self.data[i]
        if data.mode == "servo":
            return data, None
        trig = list(self.trig[i])
        if reduced:
            first = self.runs[i][1]
            data = _rows(data, first)
            trig = [(c[first], sn[first]) for c, sn in trig]
        if "encoder_harmonic" not in self.truth_model.terms:
            return data, trig
        enc = theta_true[self.truth_model.slices()["encoder_harmonic"]] * units.ARCSEC
        e = data.encoder_axis
        h, _ = encoder_error_trig(enc, *trig[e])
        trig[e] = turn(trig[e][0], trig[e][1], h)
        return replace(data, angles=data.angles.at[:, e].add(h)), trig

    def simulate_draw(self, key):
        """(θ_true, [y per record], [(read data, read trig) per record]) of one draw."""
        kt, kn = jax.random.split(key)
        theta = self.draw_truth(kt)
        ys, reads = [], []
        for i, d in enumerate(self.data):
            rd, trig = self.read_data(theta, i)
            ys.append(predict(self.truth_model, theta, rd, trig) + self.record_noise(kn, i, d))
            reads.append((rd, trig))
        return theta, ys, reads

    def _fit_prediction(self, reads):
        """θ ↦ the fit model's prediction on the read data, all records concatenated (output units)."""
        model = self.fit_model
        if model.is_linear and all(rd.mode != "servo" for rd, _ in reads):
            # the inputs do not depend on θ: compute them once, differentiate the balance equation only
            nominal = setup_values(model, jnp.zeros(model.size))
            xs = [instrument_inputs(rd, nominal, trig=trig) for rd, trig in reads]
            return lambda th: jnp.concatenate(
                [indicated_output(model, th, x, rd.kind) for x, (rd, _) in zip(xs, reads)]
            )
        return lambda th: jnp.concatenate([predict(model, th, rd, trig) for rd, trig in reads])

    def solve(self, ys, reads):
        """Least squares of the fit model on the read data (module doc): (θ̂, std, rms)."""
        model = self.fit_model
        p = model.size
        steps = 1 if model.is_linear else 3
        w = jnp.concatenate([d.weight for d in self.data])
        y = jnp.concatenate(ys)

        pred = self._fit_prediction(reads)

        def lin(th):  # residual and regressors, Jᵀ as (p, m): one forward-mode pass per coefficient
            jt = jax.vmap(lambda v: jax.jvp(pred, (th,), (v,))[1])(jnp.eye(p))
            return (y - pred(th)) * w, jt * w

        theta = jnp.zeros(p)
        for _ in range(steps):
            r, jt = lin(theta)
            step, ninv = lstsq(jt.T, r, self.solver)
            theta = theta + step
        res = r - step @ jt
        m = jnp.sum(w)
        s2 = jnp.sum(res * res) / (m - p)
        std = jnp.sqrt(s2 * jnp.diag(ninv))
        return theta, std, jnp.sqrt(jnp.sum(res * res) / m)

    def simulate_draw_reduced(self, key):
        """:meth:`simulate_draw` for static plans: (θ_true, [(signal, n, Σe, Σe²) per run, per record], [read data
        per run]). The noise e is drawn per sample with the keys of :meth:`simulate_draw`; weights as there."""
        kt, kn = jax.random.split(key)
        theta = self.draw_truth(kt)
        parts, reads = [], []
        for i, d in enumerate(self.data):
            rd, trig = self.read_data(theta, i, reduced=True)
            idx, first = self.runs[i]
            e = self.record_noise(kn, i, d) * d.weight
            n_runs = len(first)
            sums = [jax.ops.segment_sum(v, idx, n_runs, indices_are_sorted=True) for v in (d.weight, e, e * e)]
            parts.append((predict(self.truth_model, theta, rd, trig), *sums))
            reads.append((rd, trig))
        return theta, parts, reads

    def solve_reduced(self, parts, reads):
        """:meth:`solve` from per-run sums (module doc): the same (θ̂, std, rms) to rounding."""
        model = self.fit_model
        p = model.size
        steps = 1 if model.is_linear else 3
        sig, nw, s1, s2 = (jnp.concatenate(v) for v in zip(*parts))
        pred = self._fit_prediction(reads)

        theta = jnp.zeros(p)
        for _ in range(steps):
            d = sig - pred(theta)
            jt = jax.vmap(lambda v, th=theta: jax.jvp(pred, (th,), (v,))[1])(jnp.eye(p))
            step, ninv = lstsq_normal((jt * nw) @ jt.T, jt @ (nw * d + s1), "cholesky")
            theta = theta + step
        dres = d - step @ jt
        rss = jnp.sum(nw * dres * dres + 2.0 * dres * s1 + s2)
        m = jnp.sum(nw)
        std = jnp.sqrt(rss / (m - p) * jnp.diag(ninv))
        return theta, std, jnp.sqrt(rss / m)

    def draw(self, index):
        """One draw by index: dict of truth (truth model θ), estimate, std (fit model) and residual rms."""
        key = jax.random.fold_in(jax.random.PRNGKey(self.seed), index)
        if self.runs is not None:
            theta, parts, reads = self.simulate_draw_reduced(key)
            est, std, rms = self.solve_reduced(parts, reads)
        else:
            theta, ys, reads = self.simulate_draw(key)
            est, std, rms = self.solve(ys, reads)
        return {"truth": theta, "estimate": est, "std": std, "rms": rms}


def _rows(data: RecordData, rows) -> RecordData:
    """``data`` at the sample indices ``rows`` (rebalance records; ``dt`` then spans the kept rows)."""
    t = data.time_s[rows]
    return replace(
        data,
        time_s=t,
        angles=data.angles[rows],
        rates=data.rates[rows],
        temperature=data.temperature[rows],
        y=data.y[rows],
        weight=data.weight[rows],
        command=data.command[rows],
        dt=jnp.diff(t),
    )


def constant_runs(data, models, seed: int = 0):
    """Per record data (run index of every sample, first sample of every run) when every record is a sequence of
    fixed positions on which the ``models``' predictions cannot change, else None.

    A run is a maximal stretch of consecutive samples with the same angles (rad), zero rates and the same
    temperature (°C) in a single-output rebalance record; the models must not depend on time (checked by
    predicting at random coefficients, in report units, with the clock shifted by one hour).
    """
    out = []
    rng = np.random.default_rng(seed)
    for d in data:
        if d.mode != "rebalance" or d.kind == fx.TDF or np.any(np.asarray(d.rates) != 0):
            return None
        a = np.column_stack([np.asarray(d.angles), np.asarray(d.temperature)])
        change = np.r_[True, np.any(a[1:] != a[:-1], axis=1)]
        idx = np.cumsum(change) - 1
        first = np.flatnonzero(change)
        later = replace(d, time_s=d.time_s + units.SECONDS_PER_HOUR)
        for m in models:
            th = jnp.asarray(rng.normal(0.0, 1.0, m.size))
            if not np.allclose(predict(m, th, d), predict(m, th, later), rtol=1e-13, atol=0.0):
                return None
        out.append((jnp.asarray(idx, dtype=jnp.int32), jnp.asarray(first)))
    return tuple(out)


def build_pipeline(study: Study, plan=None, records=None) -> Pipeline:
    """Arrays of a study: nominal records of its plan, the fit and truth models, the prior vectors."""
    if plan is None:
        try:
            plan = plans_mod.build(study.plan, **study.plan_options)
        except GyrojaxError as e:
            raise StudyError(f"study: key 'plan_options': {e}") from None
    recs = records if records is not None else nominal_records(plan)
    kind = study.kind
    fit_model = Model.of(study.terms, kind)
    priors = {}
    for key, setup in (("priors", False), ("setup", True)):
        for name, v in getattr(study, key).items():
            for c in _expand(name, f"study: key '{key}.{name}'", setup):
                priors[c] = _prior(v, f"study: key '{key}.{name}'")
    names = list(fit_model.coefficient_names) + [c for c in priors if c not in fit_model.coefficient_names]
    truth_model = Model.of(names, kind)
    uni = np.array([priors.get(c, (False, 0.0, 0.0))[0] for c in truth_model.coefficient_names])
    a = np.array([priors.get(c, (False, 0.0, 0.0))[1] for c in truth_model.coefficient_names])
    b = np.array([priors.get(c, (False, 0.0, 0.0))[2] for c in truth_model.coefficient_names])
    data = tuple(record_data(r) for r in recs)
    dtw = tuple(float(np.median(np.diff(np.asarray(r.time_s)))) if r.n > 1 else 1.0 for r in recs)
    trig = tuple(tuple(angle_trig(jnp.asarray(d.angles))) for d in data)
    runs = constant_runs(data, (fit_model, truth_model))
    return Pipeline(
        recs, data, fit_model, truth_model, uni, a, b, dict(study.noise), dtw, study.solver, study.seed, trig, runs
    )


def identifiable_terms(records, candidates, kind: str = fx.SDF):
    """The candidates a plan can separate: (kept, dropped) after greedily dropping, from each alias group of
    :func:`gyrojax.inference.identify.identifiability` on the noise-free regressors, every member but the first listed
    (and every unexcited effect). E.g. a 1 g test keeps D_F of D_F, D_II, D_OO, D_SS only after dropping one."""
    from gyrojax.inference.identify import identifiability
    from gyrojax.physics.model import jacobian_jit

    terms = list(Model.of(candidates, kind).terms)
    dropped = []
    data = [record_data(r) for r in records]
    while terms:
        model = Model(tuple(terms), kind)
        jac = np.concatenate(
            [np.asarray(jacobian_jit(model, jnp.zeros(model.size), d)) * np.asarray(d.weight)[:, None] for d in data]
        )
        rep = identifiability(jac, model)
        bad = list(rep["unexcited"]) + [t for g in rep["aliases"] for t in g[1:]]
        bad = [t for t in terms if t in bad]
        if not bad:
            break
        drop = bad[-1]  # one at a time: dropping one member may resolve the group
        terms.remove(drop)
        dropped.append(drop)
    return terms, dropped


# ---- running a study ---------------------------------------------------------------------------------------------


def auto_chunk(pipe: Pipeline, n_devices: int = 1, budget_bytes: float = 1.5e9) -> int:
    """Draws per chunk so that the regressors, residuals and noise of a chunk stay within ``budget_bytes``."""
    m = sum(int(d.y.shape[0]) for d in pipe.data)
    per_draw = 8.0 * m * (3 * pipe.fit_model.size + pipe.truth_model.size + 24)
    c = max(1, int(budget_bytes // per_draw))
    return max(n_devices, (c // n_devices) * n_devices)


def _progress(done: int, total: int, t0: float, stream, last: list) -> None:
    """Progress bar on ``stream``: redrawn in place on a terminal at most 10 times a second, and written as a new
    line at most every 10 s elsewhere (log files), always at the end."""
    now = time.perf_counter()
    tty = getattr(stream, "isatty", lambda: False)()
    if done < total and now - last[0] < (0.1 if tty else 10.0):
        return
    last[0] = now
    frac = done / total
    bar = "#" * int(30 * frac)
    rate = done / max(time.perf_counter() - t0, 1e-9)
    head = "\r" if tty else ""
    stream.write(f"{head}[{bar:<30s}] {done}/{total} draws  {rate:,.0f} draws/s")
    if done == total or not tty:
        stream.write("\n")
    stream.flush()


def batched_draws(pipe: Pipeline, devices=None):
    """A jitted function of draw indices (n_dev, k) → per-draw results (n_dev, k, …), θ in report units.

    Axis 0 is sharded over a 1-D mesh of ``devices`` (default: all) with ``NamedSharding``; along axis 1 each
    device runs its draws one after another (``lax.map``), which keeps a draw's arrays in cache: on CPU this is
    several times faster than ``vmap`` over draws, whose batched intermediates do not fit.
    """
    from jax.sharding import Mesh, NamedSharding, PartitionSpec

    devices = list(devices if devices is not None else jax.devices())
    mesh = Mesh(np.array(devices), ("draws",))
    sh = NamedSharding(mesh, PartitionSpec("draws"))
    f = jax.jit(jax.vmap(lambda row: jax.lax.map(pipe.draw, row)), in_shardings=sh, out_shardings=sh)
    return f, sh, len(devices)


@dataclass
class StudyResult:
    """Per-draw arrays of a study: truth (n, p_true), estimate and std (n, p_fit), rms (n,)."""

    study: Study
    truth_names: tuple
    fit_names: tuple
    draw: np.ndarray
    truth: np.ndarray
    estimate: np.ndarray
    std: np.ndarray
    rms: np.ndarray
    compile_s: float = 0.0
    run_s: float = 0.0

    def truth_of_fit(self) -> np.ndarray:
        """Truth of the fitted coefficients only, (n, p_fit), report units, aligned with ``estimate``."""
        return self.truth[:, [self.truth_names.index(c) for c in self.fit_names]]

    def table(self):
        """Tidy pandas DataFrame: one row per draw; ``<c>_truth`` for every truth coefficient, ``<c>_estimate`` and
        ``<c>_std`` for every fitted one, ``rms``."""
        import pandas as pd

        cols = {"draw": self.draw}
        for j, c in enumerate(self.truth_names):
            cols[f"{c}_truth"] = self.truth[:, j]
        for j, c in enumerate(self.fit_names):
            cols[f"{c}_estimate"] = self.estimate[:, j]
            cols[f"{c}_std"] = self.std[:, j]
        cols["rms"] = self.rms
        return pd.DataFrame(cols)


def run_study(
    study: Study,
    draws: int | None = None,
    chunk: int | None = None,
    devices=None,
    progress=False,
    pipeline: Pipeline | None = None,
    start: int = 0,
) -> StudyResult:
    """Evaluate draws ``start … start+draws−1`` of a study in chunks over a mesh of devices (module doc).

    In a ``jax.distributed`` job of N processes (:mod:`gyrojax.montecarlo.hosts`), process k evaluates the block
    :func:`gyrojax.montecarlo.hosts.share` of the draws on its own devices (``devices``: default its local ones),
    and every process returns the whole result, gathered in draw order: the same draws as one process computes.
    ``compile_s`` and ``run_s`` are then the slowest process's.
    """
    from gyrojax.montecarlo import hosts

    pipe = pipeline or build_pipeline(study)
    n = int(draws if draws is not None else study.draws)
    nproc, pid = jax.process_count(), jax.process_index()
    if nproc > 1:
        devices = list(devices) if devices is not None else jax.local_devices()
        if any(d.process_index != pid for d in devices):
            raise StudyError("run_study: in a multi-process job each process runs on its own (local) devices")
    lo, hi = hosts.share(n, nproc, pid)
    local, compile_s, run_s = _evaluate(pipe, start + lo, hi - lo, chunk or study.chunk, devices, progress)
    if nproc > 1:
        counts = [hosts.share(n, nproc, k)[1] - hosts.share(n, nproc, k)[0] for k in range(nproc)]
        local = hosts.gather(local, counts)
        times = hosts.gather({"t": np.array([[compile_s, run_s]])}, [1] * nproc)["t"]
        compile_s, run_s = float(times[:, 0].max()), float(times[:, 1].max())
    return StudyResult(
        study,
        pipe.truth_model.coefficient_names,
        pipe.fit_model.coefficient_names,
        np.arange(start, start + n),
        local["truth"],
        local["estimate"],
        local["std"],
        local["rms"],
        compile_s,
        run_s,
    )


def _evaluate(pipe: Pipeline, start: int, n: int, chunk, devices, progress):
    """Per-draw arrays of draws ``start … start+n−1`` on ``devices`` (default: all): (dict, compile_s, run_s)."""
    f, sh, ndev = batched_draws(pipe, devices)
    chunk = chunk or auto_chunk(pipe, ndev)
    chunk = int(math.ceil(min(chunk, max(n, 1)) / ndev) * ndev)
    stream = sys.stderr
    outs = []
    t0 = time.perf_counter()
    per = chunk // ndev
    cache_key = (tuple(str(d) for d in (devices if devices is not None else jax.devices())), chunk)
    compiled = pipe._compiled.get(cache_key)
    if compiled is None:
        idx0 = jax.device_put(np.arange(start, start + chunk, dtype=np.int64).reshape(ndev, per), sh)
        compiled = pipe._compiled[cache_key] = f.lower(idx0).compile()
    compile_s = time.perf_counter() - t0
    t1 = time.perf_counter()
    last = [-math.inf]
    for s in range(0, n, chunk):
        idx = np.arange(start + s, start + s + chunk, dtype=np.int64)  # the last chunk is padded, then trimmed
        out = compiled(jax.device_put(idx.reshape(ndev, per), sh))
        k = min(chunk, n - s)
        outs.append({key: np.asarray(v).reshape((chunk,) + v.shape[2:])[:k] for key, v in out.items()})
        if progress:
            _progress(s + k, n, t1, stream, last)
    run_s = time.perf_counter() - t1
    if outs:
        cat = {key: np.concatenate([o[key] for o in outs]) for key in outs[0]}
    else:  # no draws: empty arrays of the right widths
        p_true, p_fit = pipe.truth_model.size, pipe.fit_model.size
        cat = {"truth": np.zeros((0, p_true)), "estimate": np.zeros((0, p_fit)), "std": np.zeros((0, p_fit))}
        cat["rms"] = np.zeros(0)
    return cat, compile_s, run_s


# ---- records of a draw (for the numpy GLS path) -------------------------------------------------------------------


def draw_records(pipe: Pipeline, index: int) -> list[Record]:
    """The records a draw stands for: read angles (deg) and indicated currents (mA) of each (rebalance) record."""
    key = jax.random.fold_in(jax.random.PRNGKey(pipe.seed), index)
    if pipe._sim_jit is None:
        pipe._sim_jit = jax.jit(pipe.simulate_draw)
    theta, ys, reads = pipe._sim_jit(key)
    out = []
    for rec, y, (rd, _) in zip(pipe.records, ys, reads):
        if rd.mode == "servo":
            raise StudyError("draw_records: servo records are not written from a draw; use gyrojax.simulate")
        cols = dict(rec.columns)
        e = rec.encoder_axis_index
        name = [k for k in cols if k.startswith("angle_")][e]
        cols[name] = np.rad2deg(np.asarray(rd.angles)[:, e])
        y = np.asarray(y)
        sf = rec.meta.get("scale_factor_g_per_mA", rec.meta.get("scale_factor_deg_per_h_per_mA"))
        if rd.kind == fx.TDF:
            cols["current_x_mA"] = y[: rec.n] / sf
            cols["current_y_mA"] = y[rec.n :] / sf
        else:
            cols["current_mA"] = y / sf
        out.append(Record(rec.meta, cols))
    return out


# ---- summaries, files, plot ----------------------------------------------------------------------------------------


def summarize(res: StudyResult):
    """Per fitted coefficient: bias, RMS error, mean σ̂, mean and std of (θ̂−θ)/σ̂, coverage of ±1σ̂ and ±2σ̂."""
    import pandas as pd

    err = res.estimate - res.truth_of_fit()
    z = err / res.std
    rows = []
    for j, c in enumerate(res.fit_names):
        rows.append(
            {
                "coefficient": c,
                "bias": err[:, j].mean(),
                "rms_error": np.sqrt((err[:, j] ** 2).mean()),
                "mean_std": res.std[:, j].mean(),
                "mean_z": z[:, j].mean(),
                "std_z": z[:, j].std(ddof=1),
                "cover_1sigma": np.mean(np.abs(z[:, j]) <= 1.0),
                "cover_2sigma": np.mean(np.abs(z[:, j]) <= 2.0),
            }
        )
    return pd.DataFrame(rows)


def save_result(res: StudyResult, out_dir, force: bool = False) -> dict:
    """Write draws (Parquet if pyarrow is importable, else CSV), the study JSON, the summary and the plot."""
    import io as _io

    out = Path(out_dir)
    names = {"study": out / "study.json", "summary": out / "summary.csv", "plot": out / "coverage.png"}
    try:
        import pyarrow  # noqa: F401

        names["draws"] = out / "draws.parquet"
    except ImportError:
        names["draws"] = out / "draws.csv"
    if not force:
        clash = [str(p) for p in names.values() if p.exists()]
        if clash:
            raise StudyError(f"{clash[0]} exists; use --force to overwrite")
    df = res.table()
    if names["draws"].suffix == ".parquet":
        buf = _io.BytesIO()
        df.to_parquet(buf, index=False)
        atomic_write_bytes(names["draws"], buf.getvalue())
    else:
        atomic_write_text(names["draws"], df.to_csv(index=False, float_format="%.17g"))
    d = res.study.to_dict()
    d["draws"] = int(len(res.draw))
    atomic_write_text(names["study"], json.dumps(d, indent=1))
    atomic_write_text(names["summary"], summarize(res).to_csv(index=False, float_format="%.6g"))
    from gyrojax.report import figures

    figures.save(figures.montecarlo_figure(res, summarize(res)), names["plot"])
    return {k: str(v) for k, v in names.items()}


def load_result(out_dir) -> StudyResult:
    """A result written by :func:`save_result`: its study JSON and its draws table (Parquet or CSV). Errors name
    the directory and the file."""
    import pandas as pd

    out = Path(out_dir)
    study = load_study(out / "study.json")
    table = out / "draws.parquet"
    if not table.exists():
        table = out / "draws.csv"
    if not table.exists():
        raise StudyError(f"{out}: no draws.parquet or draws.csv (not a directory written by gyrojax mc)")
    try:
        df = pd.read_parquet(table) if table.suffix == ".parquet" else pd.read_csv(table)
    except (OSError, ValueError) as e:
        raise StudyError(f"{table}: cannot be read as a draws table ({e})") from None
    cols = list(df.columns)
    truth = tuple(c[: -len("_truth")] for c in cols if c.endswith("_truth"))
    fit = tuple(c[: -len("_estimate")] for c in cols if c.endswith("_estimate"))
    missing = [c for c in ["draw", "rms"] + [f"{f}_std" for f in fit] if c not in cols]
    if missing or not truth or not fit:
        raise StudyError(f"{table}: missing column {missing[0] if missing else '<coefficient>_truth/_estimate'!r}")
    return StudyResult(
        study,
        truth,
        fit,
        df["draw"].to_numpy(dtype=np.int64),
        df[[f"{c}_truth" for c in truth]].to_numpy(dtype=float),
        df[[f"{c}_estimate" for c in fit]].to_numpy(dtype=float),
        df[[f"{c}_std" for c in fit]].to_numpy(dtype=float),
        df["rms"].to_numpy(dtype=float),
    )


def merge_results(results, where=None) -> StudyResult:
    """One result from the results of disjoint draw ranges of one study (the index-range split: ``gyrojax mc
    --start S --draws N`` per host, no coordination), rows in draw order. Refuses different studies (any key but
    ``draws``) and a draw index present twice; ``where`` names the inputs in error messages."""
    results = list(results)
    if not results:
        raise StudyError("merge: no results given")
    where = list(where) if where is not None else [f"result {i}" for i in range(len(results))]

    def key(r):
        d = r.study.to_dict()
        d.pop("draws")
        return d

    ref = results[0]
    for r, w in zip(results[1:], where[1:]):
        if key(r) != key(ref):
            diff = sorted(k for k in key(ref) if key(ref)[k] != key(r).get(k))
            raise StudyError(f"merge: {w} is a different study from {where[0]} (key {diff[0]!r} differs)")
        if r.truth_names != ref.truth_names or r.fit_names != ref.fit_names:
            raise StudyError(f"merge: {w} has other coefficient columns than {where[0]}")
    draw = np.concatenate([r.draw for r in results])
    order = np.argsort(draw, kind="stable")
    dup = draw[order][1:][np.diff(draw[order]) == 0]
    if dup.size:
        owners = [w for r, w in zip(results, where) if dup[0] in r.draw]
        raise StudyError(f"merge: draw {int(dup[0])} is in {' and '.join(owners)} (the draw ranges overlap)")

    def cat(name):
        return np.concatenate([getattr(r, name) for r in results])[order]

    return StudyResult(
        replace(ref.study, draws=int(draw.size)),
        ref.truth_names,
        ref.fit_names,
        draw[order],
        cat("truth"),
        cat("estimate"),
        cat("std"),
        cat("rms"),
        sum(r.compile_s for r in results),
        sum(r.run_s for r in results),
    )
