"""Optimal test-plan design by gradients through the measurement model.

**Fisher information.** For measurements y = h(θ) + e with e ~ N(0, Σ), the information on θ is
F = Jᵀ Σ⁻¹ J with J = ∂h/∂θ from :func:`gyrojax.physics.model.jacobian` — the very model
:func:`gyrojax.inference.identify.fit` uses;
the Cramér–Rao bound is cov(θ̂) ⪰ F⁻¹.

*Static positions (the fast path).* At a static position every sample has the same regressor row j_k (it depends on
the orientation only), so a position held for T_k seconds and sampled every Δt contributes
j_kᵀ j_k / Var(ȳ_k), where ȳ_k is the position mean. The position mean is sufficient under white noise, and

    Var(ȳ_k) = σ_w² / n_k + σ_g² · f(T_k / τ),     f(x) = 2 (x − 1 + e^{−x}) / x²,

with n_k = T_k/Δt, σ_w = N·60/√Δt deg/h for angle random walk N (deg/√h) (IEEE 952 annex C; ``noise.white``),
and f the variance ratio of the mean of a first-order Gauss–Markov process (σ_g, τ) over a window T (from
∫∫ e^{−|t−s|/τ} ds dt / T²). For white noise alone σ_w²/n_k = (60 N)²/T_k, so F = Σ_k T_k j_kᵀ j_k / (60 N)²:
it depends on the dwell time, not on Δt. Positions are treated as independent (the Gauss–Markov correlation
between positions, e^{−gap/τ}, is neglected; this is exact for τ ≪ gap). This is the information of the
position-mean estimator (Hu ch. 4 processing); the GLS bound 1ᵀΣ⁻¹1 of a fit that whitens the drift exactly is
larger, so under coloured noise the criteria are conservative. The rows j_k
come from one :class:`~gyrojax.physics.model.RecordData` whose "samples" are the N positions, so J is differentiable in
the gimbal angles (and, through T_k, in the dwell fractions).

*Any plan (baselines).* For plans with motion (tumble, servo) or several mountings (Hu's eight-position fixture),
F = Σ_records Jᵀ J / σ_w² from the records of a noise-free simulation, with σ_w² = (60 N)²/Δt per sample
(white noise only).

**Criteria** (all written as a loss to minimise):

=================  ===========================================================================================
``D``              −log det F (D-optimal: smallest confidence ellipsoid)
``A``              trace(W F⁻¹), W = diag(weights) (default 1): mean variance
``E``              −λ_min(F) (unit-dependent: θ is in report units; non-smooth where eigenvalues cross, so
                   its final gradient norm need not vanish)
``c:C1=w1,...``    cᵀ F⁻¹ c: the variance of the combination cᵀθ
``detect:NAME``    −log λ_NAME with λ = δᵀ (F_aa − F_aθ F_θθ⁻¹ F_θa) δ the noncentrality of the score test for the
                   omitted effect NAME at nominal magnitude δ (the information on NAME orthogonal to the model's
                   regressors); a small D term (weight 1/10 per coefficient) keeps the model itself estimable
=================  ===========================================================================================

The power of the score test at level α is P(χ²_q(λ) > χ²_{q,1−α}), q = size of NAME (:func:`detect_power`).
For nonlinear effects F depends on θ; :func:`design` takes a prior sample of θ and minimises the mean loss over
it (Bayesian design by ``vmap``); for linear models any θ gives the same F.

**Parameterisation.** N positions on the two-axis table (``plans.TWO_AXIS``): free angles (trunnion, platform) in
rad, and dwell fractions p = m + (1 − N m)·softmax(z) (minimum fraction m) of the total dwell time. Adam then a few
L-BFGS steps, ``vmap`` over random starts; the best start is kept. :func:`design_plan` turns the result into a
:class:`gyrojax.data.plans.Plan` that ``gyrojax simulate`` runs. ``Table.fixture()`` replaces the table by a free
orientation (an E–N–U Euler chain) for a fixture; a discrete N is chosen by :func:`sweep_positions`.

**Limits.** A static SDF position gives one scalar, so a p-coefficient model needs N ≥ p positions (the 9-term
model cannot be identified from 8). In every static 1-g position a_I² + a_O² + a_S² = (g/g0)², so D_OO is aliased
with D_F, D_II, D_SS: ``detect:D_OO`` for the 9-term model has zero noncentrality whatever the plan, and
:func:`design` refuses it (only a centrifuge changes |f|).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import jax
import jax.numpy as jnp
import numpy as np
import optax

from gyrojax.data import plans
from gyrojax.data.arrays import record_data
from gyrojax.errors import ModelError
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model, RecordData, jacobian

TIME_EFFECTS = ("bias_trend", "bias_temperature")
SDF9 = ("D_F", "D_I", "D_O", "D_S", "D_II", "D_SS", "D_IO", "D_IS", "D_OS")
"""The SDF drift model of Hu 2-45 less D_OO (the design tests' model; D_OO is the effect left out)."""
DEFAULT_MAGNITUDE = 0.05  # nominal size of an omitted effect for detect: (report units, e.g. deg/h/g²)


# ---- noise ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Noise:
    """Random drift of the instrument: ARW ``arw`` (deg/√h) and optional Gauss–Markov ``gm`` = (σ deg/h, τ s)."""

    arw: float = 0.01
    gm: tuple[float, float] | None = None

    def mean_variance(self, dwell_s, dt_s):
        """Variance (deg/h)² of the mean of one static position of ``dwell_s`` seconds (module doc)."""
        var = (60.0 * self.arw) ** 2 / dwell_s
        if self.gm is not None:
            s, tau = self.gm
            x = dwell_s / tau
            var = var + s * s * gm_mean_factor(x)
        return var


def gm_mean_factor(x):
    """f(x) = 2(x − 1 + e^{−x})/x²: Var(mean of a GM process over T)/σ², x = T/τ (→ 1 as x → 0, → 2/x)."""
    x = jnp.asarray(x, dtype=jnp.float64)
    small = x < 1e-4
    xs = jnp.where(small, 1.0, x)
    big = 2.0 * (xs - 1.0 + jnp.exp(-xs)) / (xs * xs)
    return jnp.where(small, 1.0 - x / 3.0, big)


# ---- the static-position fast path ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Table:
    """Geometry of a static design: table axes (ENU at zero), instrument mounting and site, as model arrays."""

    template: RecordData
    axis_names: tuple[str, ...]
    axes_enu: tuple
    mount: dict
    latitude_deg: float

    @classmethod
    def two_axis(cls, mount: dict | None = None, latitude_deg: float = plans.DEFAULT_LATITUDE) -> "Table":
        """``plans.TWO_AXIS`` (trunnion East, platform Up) with ``mount`` (default ``plans.SKEW_MOUNT``), at
        ``latitude_deg`` (deg)."""
        return cls.of(plans.TWO_AXIS, mount or plans.SKEW_MOUNT, latitude_deg)

    @classmethod
    def fixture(cls, latitude_deg: float = plans.DEFAULT_LATITUDE) -> "Table":
        """No gimbals: the orientation is a free rotation (three 'axes' E, N, U as an Euler chain)."""
        axes = (("e", plans.E), ("n", plans.N), ("u", plans.U))
        return cls.of(axes, plans.sdf_mount(plans.E, plans.N), latitude_deg)

    @classmethod
    def of(cls, axes, mount: dict, latitude_deg: float) -> "Table":
        """A table of gimbal ``axes`` ((name, ENU unit vector), outermost first) and ``mount``, at ``latitude_deg``
        (deg), built from a one-sample simulated record."""
        # a one-sample record made by the simulator gives the exact arrays fit() would see
        from gyrojax.simulation.simulator import simulate

        k = len(axes)
        run = plans.Run("template", tuple(axes), mount, (plans.Segment((0.0,) * k, 1.0, 1.0),))
        rec = simulate(plans.Plan("template", (run,), latitude_deg), {"coefficients": {}})[0]
        return cls(
            record_data(rec), tuple(n for n, _ in axes), tuple(tuple(u) for _, u in axes), dict(mount), latitude_deg
        )

    def positions_data(self, angles_rad) -> RecordData:
        """A RecordData whose samples are the static positions ``angles_rad`` (n, k)."""
        n, k = angles_rad.shape
        t = self.template
        return replace(
            t,
            time_s=jnp.zeros(n),
            angles=angles_rad,
            rates=jnp.zeros((n, k)),
            temperature=jnp.full(n, 20.0),
            y=jnp.zeros(n * (2 if t.kind == fx.TDF else 1)),
            weight=jnp.ones(n),
            command=jnp.zeros(n),
            dt=jnp.ones(max(n - 1, 0)),
        )


def check_static(model: Model) -> None:
    """Raise ModelError if the model has an effect of ``TIME_EFFECTS`` (``bias_trend``, ``bias_temperature``): a
    static-position design has no clock."""
    bad = [t for t in model.terms if t in TIME_EFFECTS]
    if bad:
        raise ModelError(f"static-position design cannot use time/temperature effects {bad}: they need a clock")


_jacobian_jit = jax.jit(jacobian, static_argnums=0)


def position_rows(model: Model, table: Table, angles_rad, theta=None):
    """Regressor rows j_k of static positions: (channels, n, p) from ``model.jacobian`` (channels = 2 for TDF)."""
    theta = jnp.zeros(model.size) if theta is None else jnp.asarray(theta, dtype=jnp.float64)
    j = _jacobian_jit(model, theta, table.positions_data(jnp.asarray(angles_rad, dtype=jnp.float64)))
    n = angles_rad.shape[0]
    return j.reshape(-1, n, model.size)


def static_fisher(model: Model, table: Table, angles_rad, dwell_s, noise: Noise, dt_s: float = 1.0, theta=None):
    """F = Σ_k j_kᵀ j_k / Var(ȳ_k) for static positions (module doc); ``dwell_s`` (n,) seconds."""
    rows = position_rows(model, table, angles_rad, theta)
    w = 1.0 / noise.mean_variance(jnp.asarray(dwell_s), dt_s)
    return jnp.einsum("cnp,n,cnq->pq", rows, w, rows)


def record_fisher(model: Model, records, noise: Noise, theta=None) -> np.ndarray:
    """F = Σ Jᵀ J / σ² from records (white noise, σ² = (60 N)²/Δt per measurement) via ``identify.linearize``."""
    from gyrojax.inference.identify import Campaign, linearize

    camp = Campaign.of(records)
    theta = np.zeros(model.size) if theta is None else np.asarray(theta, float)
    f = np.zeros((model.size, model.size))
    for (_r, j, lab, _t), d in zip(linearize(model, theta, camp), camp.data):
        dt = _measurement_dt(d, lab)
        w = dt / (60.0 * noise.arw) ** 2
        f += (j * w[:, None]).T @ j
    return f


def _measurement_dt(d: RecordData, lab) -> np.ndarray:
    """Sample interval of each kept measurement (servo: its own interval; rebalance: the record's median step)."""
    lab = np.asarray(lab)
    if d.mode == "servo":
        return np.asarray(d.dt)[lab >= 0]
    dt = np.asarray(d.dt)
    return np.full(int((lab >= 0).sum()), float(np.median(dt)) if dt.size else 1.0)


# ---- criteria -------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Criterion:
    """A design criterion: ``kind`` in D, A, E, c, detect; ``vector`` (A weights or c), ``effect``, ``magnitude``.

    ``magnitude`` is the detect effect's size in its coefficients' report units (deg/h/g², …); weights are
    dimensionless.
    """

    kind: str = "D"
    vector: tuple | None = None
    effect: str | None = None
    magnitude: tuple | None = None
    d_weight: float = 0.1

    @classmethod
    def parse(cls, text: str, model: Model) -> "Criterion":
        """``D``, ``A``, ``A:C=w,...``, ``E``, ``c:C=w,...``, ``detect:NAME`` or ``detect:NAME=δ``."""
        head, _, rest = text.partition(":")
        if head in ("D", "E") and not rest:
            return cls(head)
        if head in ("A", "c"):
            if not rest:
                if head == "c":
                    raise ModelError("criterion c needs a vector: c:COEF=w,...")
                return cls("A")
            w = {}
            for item in rest.split(","):
                k, _, v = item.partition("=")
                try:
                    w[k.strip()] = float(v) if v else 1.0
                except ValueError:
                    raise ModelError(f"criterion {text!r}: weight {v!r} of {k.strip()} is not a number") from None
            unknown = set(w) - set(model.coefficient_names)
            if unknown:
                raise ModelError(f"criterion {text!r}: {sorted(unknown)} not in the model {model.coefficient_names}")
            return cls(head, tuple(w.get(c, 0.0) for c in model.coefficient_names))
        if head == "detect" and rest:
            name, _, mag = rest.partition("=")
            e = fx.get(name if name in fx.names() else fx.effect_of_coefficient(name))
            if e.name in model.terms:
                raise ModelError(f"detect:{e.name}: the effect is already in the model")
            try:
                m = float(mag) if mag else DEFAULT_MAGNITUDE
            except ValueError:
                raise ModelError(f"criterion {text!r}: magnitude {mag!r} is not a number") from None
            return cls("detect", effect=e.name, magnitude=(m,) * e.size)
        raise ModelError(f"unknown criterion {text!r}; valid: D, A, E, c:COEF=w,..., detect:NAME[=magnitude]")

    def design_model(self, model: Model) -> Model:
        """The model whose Fisher information the criterion needs (the model plus the omitted effect)."""
        return model.extend(self.effect) if self.kind == "detect" else model

    def loss(self, f, p: int):
        """Loss to minimise from the Fisher information ``f`` of :meth:`design_model` (module doc)."""
        if self.kind == "D":
            return -_logdet(f)
        if self.kind == "E":
            return -jnp.linalg.eigvalsh(f)[0]
        if self.kind == "A":
            w = jnp.ones(p) if self.vector is None else jnp.asarray(self.vector)
            return jnp.sum(w * jnp.diag(jnp.linalg.inv(f)))
        if self.kind == "c":
            c = jnp.asarray(self.vector)
            return c @ jnp.linalg.solve(f, c)
        if self.kind == "detect":
            lam = noncentrality(f, p, jnp.asarray(self.magnitude))
            return -jnp.log(jnp.maximum(lam, 1e-300)) - self.d_weight * _logdet(f[:p, :p])
        raise ModelError(f"unknown criterion kind {self.kind!r}")

    def label(self) -> str:
        """Short name of the criterion for reports: ``D``, ``A``, …, or ``detect:EFFECT``."""
        return self.kind if self.kind != "detect" else f"detect:{self.effect}"


def _logdet(f):
    return jnp.linalg.slogdet(f)[1]


def noncentrality(f_full, p: int, delta):
    """λ = δᵀ (F_aa − F_aθ F_θθ⁻¹ F_θa) δ: score-test noncentrality for the effect in rows/cols p: of F."""
    fa = f_full[p:, p:] - f_full[p:, :p] @ jnp.linalg.solve(f_full[:p, :p], f_full[:p, p:])
    return delta @ fa @ delta


def detect_power(lam: float, df: int = 1, alpha: float = 0.01) -> float:
    """Power of the χ²_df score test at level α for noncentrality λ."""
    from scipy import stats

    return float(stats.ncx2.sf(stats.chi2.isf(alpha, df), df, max(lam, 1e-300)))


def criterion_values(f, model: Model, extra: dict | None = None) -> dict:
    """D, A, E of a Fisher information and the Cramér–Rao std of every coefficient (inf when not estimable)."""
    f = np.asarray(f, float)
    s = np.sqrt(np.maximum(np.diag(f), 1e-300))
    fs = f / np.outer(s, s)
    ev, vec = np.linalg.eigh(fs)
    null = ev < 1e-10 * max(ev[-1], 1e-300)
    std = np.sqrt(np.maximum(np.diag(np.linalg.pinv(f, rcond=1e-12, hermitian=True)), 0.0))
    if null.any():
        bad = np.abs(vec[:, null]).max(axis=1) > 1e-6
        std = np.where(bad, np.inf, std)
    ok = not null.any()
    out = {
        "D": float(np.linalg.slogdet(f)[1]) if ok else -math.inf,
        "A": float(np.sum(std**2)) if ok else math.inf,
        "E": float(np.linalg.eigvalsh(f)[0]),
        "std": dict(zip(model.coefficient_names, map(float, std))),
    }
    out.update(extra or {})
    return out


# ---- the optimiser -------------------------------------------------------------------------------------------


@dataclass
class DesignResult:
    """A designed static plan and its convergence report."""

    angles_deg: np.ndarray  # (n, k)
    dwell_s: np.ndarray  # (n,)
    loss: float
    criterion: Criterion
    model: Model
    table: Table
    noise: Noise
    dt_s: float
    history: np.ndarray  # best start's loss per iteration (adam then L-BFGS)
    grad_norm: float  # at the end, best start
    start_losses: np.ndarray  # final loss of every start
    fisher: np.ndarray = field(default=None)  # of the model (not the augmented one)
    timing: dict = field(default_factory=dict)  # compile_s, run_s

    def plan(self, name: str = "designed", gap_s: float = 30.0) -> plans.Plan:
        """The design as a plan (see :func:`design_plan`); ``gap_s`` in s between positions."""
        return design_plan(self, name, gap_s)

    def summary(self) -> dict:
        """JSON-ready report: criterion, loss, convergence, timing (s), positions (angles in deg, dwell in s),
        D/A/E and the Cramér–Rao std of every coefficient (report units)."""
        d = criterion_values(self.fisher, self.model)
        out = {
            "criterion": self.criterion.label(),
            "loss": self.loss,
            "grad_norm": self.grad_norm,
            "iterations": len(self.history),
            **self.timing,
            "start_losses": self.start_losses.tolist(),
            "positions": [
                {"angles_deg": a.tolist(), "dwell_s": float(t)} for a, t in zip(self.angles_deg, self.dwell_s)
            ],
            **d,
        }
        if self.criterion.kind == "detect":
            lam = detect_noncentrality(
                self.model, self.criterion, self.table, np.deg2rad(self.angles_deg), self.dwell_s, self.noise, self.dt_s
            )
            out["noncentrality"] = lam
            out["power_1pct"] = detect_power(lam, len(self.criterion.magnitude))
        return out


def detect_noncentrality(model, crit: Criterion, table, angles_rad, dwell_s, noise, dt_s=1.0) -> float:
    """Score-test noncentrality λ (dimensionless) of the criterion's effect at static positions ``angles_rad``
    (rad) held ``dwell_s`` (s) each, sampled every ``dt_s`` (s); see :func:`noncentrality`."""
    full = crit.design_model(model)
    f = static_fisher(full, table, jnp.asarray(angles_rad), jnp.asarray(dwell_s), noise, dt_s)
    return float(noncentrality(f, model.size, jnp.asarray(crit.magnitude)))


def _check_detectable(model, crit, table, angles_rad, dwell_s, noise, dt_s) -> None:
    """Raise when the omitted effect's regressor lies in the model's span at generic static positions.

    Example: D_OO with D_F, D_II, D_SS in the model, since a_I² + a_O² + a_S² = (g/g0)² is the same in every
    static 1-g position: no static plan can reveal it (its score-test noncentrality is zero).
    """
    full = crit.design_model(model)
    n = angles_rad.shape[0]
    f = static_fisher(full, table, angles_rad, jnp.full(n, dwell_s), noise, dt_s)
    p = model.size
    delta = jnp.asarray(crit.magnitude)
    ratio = float(noncentrality(f, p, delta) / (delta @ f[p:, p:] @ delta))
    if not ratio > 1e-9:
        raise ModelError(
            f"detect:{crit.effect}: its regressors lie in the span of the model's at every static "
            f"position tried (orthogonal fraction {ratio:.1e}); no static plan can reveal it"
        )


def dwell_from_logits(z, total_s: float, min_fraction: float):
    """Dwell times in s from unconstrained logits ``z``: each at least ``min_fraction`` of ``total_s`` (s),
    summing to ``total_s`` (a softmax; keeps the optimiser's dwells positive)."""
    n = z.shape[-1]
    return total_s * (min_fraction + (1.0 - n * min_fraction) * jax.nn.softmax(z))


_COMPILED: dict = {}
"""Compiled optimisers by configuration and argument shapes (a repeated design skips compilation)."""


def _optimiser(model, crit, n_positions, total, m, free_dwell, noise, dt_s, adam_steps, lbfgs_steps, learning_rate):
    """The multi-start optimiser: f((angles, logits), template, thetas) -> (params, history, losses, |grad|)."""
    full = crit.design_model(model)

    def loss_fn(params, template, thetas):
        ang, z = params
        dw = dwell_from_logits(z, total, m) if free_dwell else jnp.full(n_positions, total / n_positions)
        tab = Table(template, (), (), {}, 0.0)

        def one(th):
            return crit.loss(static_fisher(full, tab, ang, dw, noise, dt_s, th), model.size)

        return jnp.mean(jax.vmap(one)(thetas))

    adam = optax.adam(learning_rate)
    lb = optax.lbfgs()

    def optimise(params, template, thetas):
        def loss(p):
            return loss_fn(p, template, thetas)

        vg = jax.value_and_grad(loss)
        vg_state = optax.value_and_grad_from_state(loss)

        def run_adam(p0):
            def step(carry, _):
                p, s = carry
                val, g = vg(p)
                upd, s = adam.update(g, s, p)
                return (optax.apply_updates(p, upd), s), val

            (p, _), hist = jax.lax.scan(step, (p0, adam.init(p0)), None, length=adam_steps)
            return p, hist

        def run_lbfgs(p0):
            def step(carry, _):
                p, s = carry
                val, g = vg_state(p, state=s)
                upd, s = lb.update(g, s, p, value=val, grad=g, value_fn=loss)
                return (optax.apply_updates(p, upd), s), val

            (p, _), hist = jax.lax.scan(step, (p0, lb.init(p0)), None, length=lbfgs_steps)
            return p, hist

        p, h1 = jax.vmap(run_adam)(params)
        if lbfgs_steps:
            p2, h2 = jax.vmap(run_lbfgs)(p)
            # keep the L-BFGS result only where it is finite and no worse
            l1, l2 = jax.vmap(loss)(p), jax.vmap(loss)(p2)
            good = jnp.isfinite(l2) & (l2 <= l1)
            p = jax.tree_util.tree_map(lambda a, b: jnp.where(good.reshape((-1,) + (1,) * (a.ndim - 1)), b, a), p, p2)
            h1 = jnp.concatenate([h1, h2], axis=1)
        vals, grads = jax.vmap(vg)(p)
        gn = jax.vmap(lambda g: jnp.sqrt(sum(jnp.sum(x * x) for x in jax.tree_util.tree_leaves(g))))(grads)
        return p, h1, vals, gn

    return optimise


def design(
    terms,
    n_positions: int = 24,
    hours: float = 4.0,
    criterion="D",
    *,
    table: Table | None = None,
    noise: Noise | None = None,
    dt_s: float = 1.0,
    starts: int = 8,
    seed: int = 0,
    adam_steps: int = 600,
    lbfgs_steps: int = 40,
    learning_rate: float = 0.05,
    min_fraction: float | None = None,
    free_dwell: bool = True,
    prior_thetas=None,
    kind: str = fx.SDF,
) -> DesignResult:
    """Design a static ``n_positions`` plan of ``hours`` total dwell that minimises the criterion's loss.

    ``prior_thetas`` (s, p): a prior sample of θ for nonlinear models (the mean loss over it is minimised).
    ``min_fraction`` defaults to 0.25/N (every position keeps at least a quarter of the equal share).
    """
    model = terms if isinstance(terms, Model) else Model.of(terms, kind)
    check_static(model)
    crit = criterion if isinstance(criterion, Criterion) else Criterion.parse(criterion, model)
    full = crit.design_model(model)
    table = table or Table.two_axis()
    noise = noise or Noise()
    total = hours * 3600.0
    m = 0.25 / n_positions if min_fraction is None else min_fraction
    k = len(table.axis_names)
    thetas = jnp.zeros((1, full.size)) if prior_thetas is None else jnp.atleast_2d(jnp.asarray(prior_thetas))
    if thetas.shape[1] == model.size and full.size > model.size:
        thetas = jnp.concatenate([thetas, jnp.zeros((thetas.shape[0], full.size - model.size))], axis=1)

    key = jax.random.PRNGKey(seed)
    ang0 = jax.random.uniform(key, (starts, n_positions, k), minval=0.0, maxval=2 * math.pi)
    if crit.kind == "detect":
        _check_detectable(model, crit, table, ang0[0], total / n_positions, noise, dt_s)
    z0 = jnp.zeros((starts, n_positions))
    config = (model, crit, n_positions, total, m, free_dwell, noise, dt_s, adam_steps, lbfgs_steps, learning_rate)
    args = ((ang0, z0), table.template, thetas)
    ckey = (config, jax.tree_util.tree_structure(args), tuple(x.shape for x in jax.tree_util.tree_leaves(args)))
    t0 = time.perf_counter()
    if ckey not in _COMPILED:
        _COMPILED[ckey] = jax.jit(_optimiser(*config)).lower(*args).compile()
    t1 = time.perf_counter()
    (ang, z), hist, vals, gn = jax.block_until_ready(_COMPILED[ckey](*args))
    timing = {"compile_s": t1 - t0, "run_s": time.perf_counter() - t1}
    vals = np.where(np.isfinite(np.asarray(vals)), np.asarray(vals), np.inf)
    b = int(np.argmin(vals))
    dwell = np.asarray(dwell_from_logits(z[b], total, m)) if free_dwell else np.full(n_positions, total / n_positions)
    angles_deg = np.mod(np.rad2deg(np.asarray(ang[b])), 360.0)
    f = np.asarray(static_fisher(model, table, jnp.deg2rad(jnp.asarray(angles_deg)), jnp.asarray(dwell), noise, dt_s))
    return DesignResult(
        angles_deg,
        dwell,
        float(vals[b]),
        crit,
        model,
        table,
        noise,
        dt_s,
        np.asarray(hist[b]),
        float(gn[b]),
        vals,
        f,
        timing,
    )


def design_plan(res: DesignResult, name: str = "designed", gap_s: float = 30.0) -> plans.Plan:
    """The designed positions as a :class:`gyrojax.data.plans.Plan` (one run; dwell in s rounded to whole samples,
    ``gap_s`` in s between positions)."""
    t = res.table
    segs = []
    for i, (a, d) in enumerate(zip(res.angles_deg, res.dwell_s)):
        n = max(1, int(round(d / res.dt_s)))
        segs.append(plans.Segment(tuple(round(float(x), 6) for x in a), n * res.dt_s, res.dt_s, label=i))
    run = plans.Run(f"{len(segs)}pos-designed", tuple(zip(t.axis_names, t.axes_enu)), t.mount, tuple(segs), gap_s=gap_s)
    return plans.Plan(
        name,
        (run,),
        t.latitude_deg,
        description=f"{len(segs)}-position {res.criterion.label()}-optimal static plan for "
        f"{', '.join(res.model.terms)} (gyrojax.design)",
        reference="Fisher information of the measurement model; Hu ch. 4 (least squares)",
    )


def sweep_positions(terms, counts=(6, 8, 12, 16, 24), **kw) -> dict:
    """Design for each position count (discrete N by sweep): {N: DesignResult}."""
    return {n: design(terms, n, **kw) for n in counts}


# ---- baselines ------------------------------------------------------------------------------------------------


def measured_seconds(plan: plans.Plan) -> float:
    """Total measured time of a plan in s: the sum of its segments' durations (gaps excluded)."""
    return sum(s.duration_s for r in plan.runs for s in r.segments)


def baseline_plans(hours: float = 4.0) -> dict:
    """Classical plans of about ``hours`` of measurement (Fisher information is then normalised to ``hours``)."""
    out = {}
    for n in sorted(plans.MULTIPOSITION_SETS):
        out[f"multiposition-{n}"] = plans.multiposition(n, minutes=hours * 60.0 / n)
    out["eight-position (Hu, fixture)"] = plans.eight_position(minutes=hours * 60.0 / 8)
    out["tumble (flip, CW/CCW)"] = plans.with_dt(plans.tumble(revolutions=1.0), 20.0)
    out["servo polar"] = plans.with_dt(plans.servo("polar", hours=24.0), 60.0)
    return out


def compare(
    terms, hours: float = 4.0, noise: Noise | None = None, designed: dict | None = None, kind: str = fx.SDF
) -> list[dict]:
    """Criterion values and Cramér–Rao stds of classical plans (and designed ones), all at ``hours`` of data.

    White noise: F scales with measured time, so every plan's F is scaled by hours/(its measured hours).
    """
    from gyrojax.simulation.simulator import simulate

    model = Model.of(terms, kind)
    noise = noise or Noise()
    rows = []
    for name, plan in baseline_plans(hours).items():
        f = record_fisher(model, simulate(plan, {"coefficients": {}}), noise)
        f = f * hours * 3600.0 / measured_seconds(plan)
        rows.append({"plan": name, **criterion_values(f, model)})
    for name, res in (designed or {}).items():
        rows.append({"plan": name, **criterion_values(res.fisher * hours * 3600.0 / res.dwell_s.sum(), model)})
    return rows


def table_text(rows: list[dict]) -> str:
    """Side-by-side text table: D, A and the Cramér–Rao std of every coefficient."""
    names = list(rows[0]["std"])
    head = f"{'plan':32s} {'D=logdet':>10s} {'A=tr':>10s} " + " ".join(f"{c:>9s}" for c in names)
    lines = [head, "-" * len(head)]
    for r in rows:
        stds = " ".join(f"{v:9.2e}" if np.isfinite(v) else f"{'inf':>9s}" for v in r["std"].values())
        lines.append(f"{r['plan'][:32]:32s} {r['D']:10.3f} {r['A']:10.3e} {stds}")
    return "\n".join(lines)
