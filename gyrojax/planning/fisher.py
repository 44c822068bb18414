"""Fisher information of a test plan, from the measurement model.

**Fisher information.** For measurements y = h(θ) + e with e ~ N(0, Σ), the information on θ is
F = Jᵀ Σ⁻¹ J with J = ∂h/∂θ from :func:`gyrojax.physics.model.jacobian` — the very model
:func:`gyrojax.inference.identify.fit` uses;
the Cramér–Rao bound is cov(θ̂) ⪰ F⁻¹.

*Static positions (the fast path).* At a static position every sample has the same regressor row j_k (it depends on
the orientation only), so the plan's information is that of the N position means ȳ: F = Σ_channels Hᵀ Σ⁻¹ H with H
the rows j_k and Σ the full covariance of the position means over the plan's time line (positions held T_k s in
sequence, :data:`DEFAULT_GAP_S` apart; :meth:`~gyrojax.noise.spec.NoiseSpec.mean_covariance`): white 3600N²/T_k on
the diagonal, quantization 2Q²/T_k² with −Q²/(T_k T_{k+1}) between neighbours, each Gauss–Markov term the double
integral of σ²e^{−|t−s|/τ} over two dwell intervals (diagonal σ² f(T_k/τ), f(x) = 2(x − 1 + e^{−x})/x²), random walk
K²min(t, s)/3600 integrated likewise, the flicker floor as Gauss–Markov poles over its band. For white noise alone F
= Σ_k T_k j_kᵀ j_k / (60 N)²: it depends on the dwell time, not on Δt; with τ ≪ dwell and gap the Gauss–Markov
correlation between positions vanishes and Σ is the diagonal of independent positions. This is the information of
the position-mean estimator (Hu ch. 4 processing); the GLS bound of a fit that whitens every sample is larger, so
under coloured noise the criteria are conservative. The rows j_k come from one
:class:`~gyrojax.physics.model.RecordData` whose "samples" are the N positions, so F is differentiable in the gimbal
angles and, through T_k (Σ and the start times), in the dwell fractions.

*Any plan (baselines).* For plans with motion (tumble, servo) or several mountings (Hu's eight-position fixture),
F = Σ_records Jᵀ J / σ_w² from the records of a noise-free simulation, with σ_w² = (60 N)²/Δt per sample
(white noise only).

The noise is a :class:`~gyrojax.noise.spec.NoiseSpec` (white, quantization, Gauss–Markov, random walk, flicker; a
rate ramp or AR colour is refused by :meth:`~gyrojax.noise.spec.NoiseSpec.mean_terms`); :data:`DEFAULT_NOISE` when
none is given.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.data import plans
from gyrojax.data.arrays import record_data
from gyrojax.errors import ModelError
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model, RecordData, jacobian

TIME_EFFECTS = ("bias_trend",) + fx.TEMPERATURE_EFFECTS


# ---- noise ----------------------------------------------------------------------------------------------------

DEFAULT_NOISE = NoiseSpec(white=0.01)
"""The noise of a design when none is given: ARW 0.01 deg/√h."""


# ---- the static-position fast path ----------------------------------------------------------------------------


def _frozen(value):
    """A mounting's value (a string, a number or a vector) in a hashable form."""
    if value is None or isinstance(value, (str, bool, int, float)):
        return value
    arr = np.asarray(value, dtype=float)
    return float(arr) if arr.ndim == 0 else tuple(arr.tolist())


@lru_cache(maxsize=64)
def _template(axes: tuple, mount: tuple, latitude_deg: float) -> RecordData:
    """The one-sample record of a table (:meth:`Table.of`; arguments in hashable form), made by the simulator: the exact
    arrays fit() would see. Kept per table: the simulator runs once for each."""
    from gyrojax.simulation.simulator import simulate

    k = len(axes)
    run = plans.Run("template", axes, dict(mount), (plans.Segment((0.0,) * k, 1.0, 1.0),))
    return record_data(simulate(plans.Plan("template", (run,), latitude_deg), {"coefficients": {}})[0])


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
        axes = tuple((n, tuple(float(c) for c in u)) for n, u in axes)
        frozen = tuple(sorted((key, _frozen(v)) for key, v in mount.items()))
        template = _template(axes, frozen, float(latitude_deg))
        return cls(template, tuple(n for n, _ in axes), tuple(u for _, u in axes), dict(mount), latitude_deg)

    @classmethod
    def of_template(cls, template: RecordData) -> "Table":
        """A table of which only the template record is known: what :meth:`positions_data` needs, inside a traced
        function that takes the template as an argument."""
        return cls(template, (), (), {}, 0.0)

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
    """Raise ModelError if the model has an effect of ``TIME_EFFECTS`` (``bias_trend``, ``bias_temperature``,
    ``temperature_hinge``): a static-position design has no clock."""
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


DEFAULT_GAP_S = 30.0
"""Seconds between consecutive designed positions (``plans.Run.gap_s``'s default, :func:`design_plan`'s)."""


def position_times(dwell_s, gap_s: float = DEFAULT_GAP_S):
    """Start times (s) of positions held ``dwell_s`` (n,) s in sequence, ``gap_s`` s apart, the first at t = 0."""
    dwell = jnp.asarray(dwell_s, dtype=jnp.float64)
    return jnp.concatenate([jnp.zeros(1), jnp.cumsum(dwell[:-1] + gap_s)])


def static_fisher(
    model: Model,
    table: Table,
    angles_rad,
    dwell_s,
    noise: NoiseSpec,
    dt_s: float = 1.0,
    theta=None,
    gap_s: float = DEFAULT_GAP_S,
):
    """F = Σ_c H_cᵀ Σ⁻¹ H_c for static positions held ``dwell_s`` (n,) s in sequence ``gap_s`` s apart: H_c the
    regressor rows of channel c (both channels of a TDF gyro draw their own noise), Σ the covariance of the position
    means over the plan's time line (:meth:`~gyrojax.noise.spec.NoiseSpec.mean_covariance`: white, quantization,
    Gauss–Markov, random walk, flicker; continuous means, so ``dt_s`` does not enter). Diagonal Σ for white
    noise: Σ_k j_kᵀ j_k T_k/(60N)², the module doc's."""
    rows = position_rows(model, table, angles_rad, theta)
    dwell = jnp.asarray(dwell_s, dtype=jnp.float64)
    cov = noise.mean_covariance(position_times(dwell, gap_s), dwell)
    chol = jnp.linalg.cholesky(cov)
    w = jax.vmap(lambda h: jax.scipy.linalg.solve_triangular(chol, h, lower=True))(rows)  # L⁻¹ H per channel
    return jnp.einsum("cnp,cnq->pq", w, w)


# ---- any instrument: information of rows and their noise ------------------------------------------------------


def information(rows, precision, weight):
    """F = Σ_k w_k J_kᵀ W_k J_k of blocks of rows J_k (K, m, p), each with its noise's precision W_k = C_k⁻¹ (K, m, m)
    (a pseudo-inverse where the block measures a projection) and weight w_k (K,); traceable."""
    return jnp.einsum("kip,kiq->pq", rows * weight[:, None, None], jnp.einsum("kij,kjq->kiq", precision, rows))


def scaled(f):
    """F / (s sᵀ), s = √diag F, and log s (the scaling that keeps log det and inverses well conditioned)."""
    s = jnp.sqrt(jnp.maximum(jnp.diag(f), 1e-300))
    return f / jnp.outer(s, s), jnp.log(s)


def covariance(f):
    """F⁻¹ through the scaled F (the units of F⁻¹)."""
    fs, ls = scaled(f)
    s = jnp.exp(ls)
    return jnp.linalg.inv(fs) / jnp.outer(s, s)


# ---- any plan, from its records -------------------------------------------------------------------------------


def record_fisher(model: Model, records, noise: NoiseSpec, theta=None) -> np.ndarray:
    """F = Σ Jᵀ J / σ² from records (white noise, σ² = (60 N)²/Δt per measurement) via ``campaign.linearize``."""
    from gyrojax.inference.campaign import Campaign, linearize

    camp = Campaign.of(records)
    theta = np.zeros(model.size) if theta is None else np.asarray(theta, float)
    f = np.zeros((model.size, model.size))
    for (_r, j, lab, _t), d in zip(linearize(model, theta, camp), camp.data):
        dt = measurement_dt(d, lab)
        w = dt / (60.0 * noise.white) ** 2
        f += (j * w[:, None]).T @ j
    return f


def measurement_dt(d: RecordData, lab) -> np.ndarray:
    """Sample interval (s) of each kept measurement (servo: its own interval; rebalance: the record's median step)."""
    lab = np.asarray(lab)
    if d.mode == "servo":
        return np.asarray(d.dt)[lab >= 0]
    dt = np.asarray(d.dt)
    return np.full(int((lab >= 0).sum()), float(np.median(dt)) if dt.size else 1.0)
