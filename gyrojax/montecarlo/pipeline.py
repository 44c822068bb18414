"""The per-draw pipeline of a Monte Carlo study: many simulated gyros, one least-squares fit each, in pure JAX.

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

The white-noise standard error is exact for white noise; under coloured drift it is not. A static plan under
coloured noise (quantization, Gauss–Markov terms, random walk, flicker) is therefore fitted by GLS of the run means
with their known covariance Σ (:func:`means_whitening`, from :meth:`~gyrojax.noise.spec.NoiseSpec.mean_covariance`
of the simulator's point samples): θ̂ = (HᵀΣ⁻¹H)⁻¹HᵀΣ⁻¹r̄, σ̂ = √diag (HᵀΣ⁻¹H)⁻¹ — the design's Cramér–Rao bound;
the flicker floor is then simulated as the Gauss–Markov poles of that Σ
(:meth:`~gyrojax.noise.spec.NoiseSpec.mean_terms`), not the simulator's own six. Plans with motion keep the
white-noise σ̂ and say so (:attr:`Pipeline.fit_method`); :func:`draw_records` writes a draw as records so the GLS
fit of :func:`gyrojax.inference.identify.fit` can be checked on it.

Servo records are simulated conditionally on the nominal (noise-free) trajectory: the regressors see the same
read angles the measurements were generated at, which is exact for models linear in θ given the read angles.

A study (:class:`~gyrojax.montecarlo.study.Study`) becomes a :class:`Pipeline` by :func:`build_pipeline`;
:func:`gyrojax.montecarlo.runner.run_study` evaluates its draws, :mod:`gyrojax.montecarlo.results` summarises them.

Draws evaluate the measurement model itself (:func:`gyrojax.physics.model.predict`, whose kinematics work on whole
records in vector form), with the (cos, sin) of the plan's angles precomputed
(:func:`gyrojax.physics.model.angle_trig`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.data import plans as plans_mod
from gyrojax.data.arrays import record_data
from gyrojax.data.record import Record
from gyrojax.errors import GyrojaxError
from gyrojax.inference.lstsq import lstsq, lstsq_normal
from gyrojax.montecarlo.study import INSTRUMENTS, Study, StudyError, expand_name, parse_prior
from gyrojax.montecarlo.triad import build_triad_pipeline
from gyrojax.noise.processes import random_drift
from gyrojax.noise.spec import NoiseSpec
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


def nominal_records(plan) -> list[Record]:
    """Noise-free records of a perfect instrument on ``plan``: its geometry and sample times (s)."""
    from gyrojax.simulation.simulator import simulate

    return simulate(plan, {}, seed=0)


@dataclass
class Pipeline:
    """A study compiled to arrays: nominal records, models and prior vectors; :meth:`draw` is pure JAX.

    Priors and θ are in report units (deg/h, deg/h/g, ppm, …); ``noise`` as in truth files (conventions §8);
    ``dt_white`` the averaging interval (s) of white and quantisation noise per record.
    """

    records: list
    data: tuple
    fit_model: Model
    truth_model: Model
    prior_uniform: np.ndarray
    prior_a: np.ndarray
    prior_b: np.ndarray
    noise: NoiseSpec
    dt_white: tuple
    solver: str = "cholesky"
    seed: int = 0
    trig: tuple = ()  # per record, per axis (cos, sin) of the nominal angles
    runs: tuple | None = None  # static plans: per record (run index of every sample, first sample of every run)
    whiten: np.ndarray | None = None  # static plans, coloured noise: L⁻¹ of the run means' covariance (block diagonal)
    _sim_jit: object = field(default=None, repr=False)
    compiled: dict = field(default_factory=dict, repr=False)  # (devices, chunk) → compiled chunk function

    @property
    def draw_bytes(self) -> float:
        """Bytes of the regressors, residuals and noise of one draw (for the chunk size)."""
        m = sum(int(d.y.shape[0]) for d in self.data)
        return 8.0 * m * (3 * self.fit_model.size + self.truth_model.size + 24)

    @property
    def n_measurements(self) -> int:
        """Number of measurements of one draw, summed over the records."""
        return int(sum(float(np.asarray(d.weight).sum()) for d in self.data))

    @property
    def fit_method(self) -> str:
        """How each draw is fitted: ``"ols"`` (white noise: least squares, σ̂ from the residuals, exact),
        ``"gls-position-means"`` (static plan under coloured noise: GLS of the position means with their known
        covariance, :func:`means_whitening`; σ̂ = √diag (HᵀΣ⁻¹H)⁻¹, the design's Cramér–Rao bound), or
        ``"ols-white-se"`` (a plan with motion under coloured noise: the white-noise σ̂, which is then not valid)."""
        if self.whiten is not None:
            return "gls-position-means"
        return "ols" if _white_only(self.noise) else "ols-white-se"

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
        if self.noise.is_zero:
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

        wh = None if self.whiten is None else jnp.asarray(self.whiten)
        theta = jnp.zeros(p)
        for _ in range(steps):
            d = sig - pred(theta)
            jt = jax.vmap(lambda v, th=theta: jax.jvp(pred, (th,), (v,))[1])(jnp.eye(p))
            if wh is None:
                step, ninv = lstsq_normal((jt * nw) @ jt.T, jt @ (nw * d + s1), "cholesky")
            else:  # GLS of the run means d + Σe/n with their covariance Σ = L Lᵀ
                jw, rw = jt @ wh.T, wh @ (d + s1 / nw)
                step, ninv = lstsq_normal(jw @ jw.T, jw @ rw, "cholesky")
            theta = theta + step
        dres = d - step @ jt
        rss = jnp.sum(nw * dres * dres + 2.0 * dres * s1 + s2)
        m = jnp.sum(nw)
        scale = rss / (m - p) if wh is None else 1.0  # known Σ: no residual scale
        std = jnp.sqrt(scale * jnp.diag(ninv))
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


def build_pipeline(study: Study, plan=None, records=None):
    """Arrays of a study: nominal records of its plan, the fit and truth models, the prior vectors (an imu-triad
    study: :func:`gyrojax.montecarlo.triad.build_triad_pipeline`)."""
    if study.instrument != INSTRUMENTS[0]:
        return build_triad_pipeline(study)
    if plan is None:
        try:
            plan = plans_mod.build(study.plan, **study.plan_options)
        except GyrojaxError as e:
            raise StudyError(f"study: key 'plan_options': {e}") from None
    recs = records if records is not None else nominal_records(plan)
    kind = study.kind
    fit_model = Model.of(study.terms, kind)
    hinged = [e.name for e in fit_model.effects if e.knee is not None]
    if hinged:  # its Gauss–Newton starts at zero, where a knee is not seen (gyrojax.inference.knee)
        raise StudyError(f"study: key 'terms': {', '.join(hinged)} has a knee, which the study's solver cannot fit")
    priors = {}
    for key, setup in (("priors", False), ("setup", True)):
        for name, v in getattr(study, key).items():
            for c in expand_name(name, f"study: key '{key}.{name}'", setup):
                priors[c] = parse_prior(v, f"study: key '{key}.{name}'")
    names = list(fit_model.coefficient_names) + [c for c in priors if c not in fit_model.coefficient_names]
    truth_model = Model.of(names, kind)
    uni = np.array([priors.get(c, (False, 0.0, 0.0))[0] for c in truth_model.coefficient_names])
    a = np.array([priors.get(c, (False, 0.0, 0.0))[1] for c in truth_model.coefficient_names])
    b = np.array([priors.get(c, (False, 0.0, 0.0))[2] for c in truth_model.coefficient_names])
    data = tuple(record_data(r) for r in recs)
    dtw = tuple(float(np.median(np.diff(np.asarray(r.time_s)))) if r.n > 1 else 1.0 for r in recs)
    trig = tuple(tuple(angle_trig(jnp.asarray(d.angles))) for d in data)
    runs = constant_runs(data, (fit_model, truth_model))
    noise, whiten = study.noise, None
    if runs is not None and not _white_only(noise):
        noise = noise.mean_terms("study: key 'noise'")  # the flicker floor as the poles the fit's Σ has
        whiten = means_whitening(recs, runs, noise, dtw)
    return Pipeline(
        recs, data, fit_model, truth_model, uni, a, b, noise, dtw, study.solver, study.seed, trig, runs, whiten
    )


def _white_only(noise: NoiseSpec) -> bool:
    """Whether ``noise`` has no random term but white noise (least squares is then the efficient fit)."""
    slow = ("quantization", "bias_instability", "random_walk", "rate_ramp")
    return not (any(getattr(noise, k) for k in slow) or any(s for s, _ in noise.gauss_markov) or noise.ar or noise.ma)


def means_whitening(records, runs, noise: NoiseSpec, dt_white) -> np.ndarray:
    """L⁻¹ (block diagonal over the records, which draw their own noise) of the covariance Σ = L Lᵀ of the run
    means of a static plan: :meth:`~gyrojax.noise.spec.NoiseSpec.mean_covariance` of the point samples every
    ``dt_white`` s of each run, time from the record's first sample, consecutive runs sharing a quantisation angle
    (the simulator's series)."""
    import scipy.linalg as sla

    blocks = []
    for rec, (idx, first), dt in zip(records, runs, dt_white):
        t = np.asarray(rec.time_s, float)
        counts = np.bincount(np.asarray(idx), minlength=len(first)).astype(float)
        cov = np.asarray(noise.mean_covariance(t[np.asarray(first)] - t[0], counts * dt, sample_s=dt))
        blocks.append(sla.solve_triangular(np.linalg.cholesky(cov), np.eye(len(first)), lower=True))
    return sla.block_diag(*blocks)


def identifiable_terms(records, candidates, kind: str = fx.SDF):
    """The candidates a plan can separate: (kept, dropped) after greedily dropping, from each alias group of
    :func:`gyrojax.inference.identifiability.identifiability` on the noise-free regressors, every member but the
    first listed (and every unexcited effect). E.g. a 1 g test keeps D_F of D_F, D_II, D_OO, D_SS only after
    dropping one."""
    from gyrojax.inference.identifiability import identifiability
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
