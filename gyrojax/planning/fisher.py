"""Fisher information of a test plan, from the measurement model.

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

The noise is a :class:`~gyrojax.noise.spec.NoiseSpec` of white + Gauss–Markov terms (the ones with a variance of a
static mean, :meth:`~gyrojax.noise.spec.NoiseSpec.mean_variance`); :data:`DEFAULT_NOISE` when none is given.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.data import plans
from gyrojax.data.arrays import record_data
from gyrojax.errors import ModelError
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model, RecordData, jacobian

TIME_EFFECTS = ("bias_trend", "bias_temperature")


# ---- noise ----------------------------------------------------------------------------------------------------

DEFAULT_NOISE = NoiseSpec(white=0.01)
"""The noise of a design when none is given: ARW 0.01 deg/√h."""


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


def static_fisher(model: Model, table: Table, angles_rad, dwell_s, noise: NoiseSpec, dt_s: float = 1.0, theta=None):
    """F = Σ_k j_kᵀ j_k / Var(ȳ_k) for static positions (module doc); ``dwell_s`` (n,) seconds (``dt_s``, the sample
    interval, does not enter the variance of a mean)."""
    rows = position_rows(model, table, angles_rad, theta)
    w = 1.0 / noise.mean_variance(jnp.asarray(dwell_s))
    return jnp.einsum("cnp,n,cnq->pq", rows, w, rows)


# ---- any plan, from its records -------------------------------------------------------------------------------


def record_fisher(model: Model, records, noise: NoiseSpec, theta=None) -> np.ndarray:
    """F = Σ Jᵀ J / σ² from records (white noise, σ² = (60 N)²/Δt per measurement) via ``campaign.linearize``."""
    from gyrojax.inference.campaign import Campaign, linearize

    camp = Campaign.of(records)
    theta = np.zeros(model.size) if theta is None else np.asarray(theta, float)
    f = np.zeros((model.size, model.size))
    for (_r, j, lab, _t), d in zip(linearize(model, theta, camp), camp.data):
        dt = _measurement_dt(d, lab)
        w = dt / (60.0 * noise.white) ** 2
        f += (j * w[:, None]).T @ j
    return f


def _measurement_dt(d: RecordData, lab) -> np.ndarray:
    """Sample interval of each kept measurement (servo: its own interval; rebalance: the record's median step)."""
    lab = np.asarray(lab)
    if d.mode == "servo":
        return np.asarray(d.dt)[lab >= 0]
    dt = np.asarray(d.dt)
    return np.full(int((lab >= 0).sum()), float(np.median(dt)) if dt.size else 1.0)
