"""Joint calibration of a MEMS gyro triad from static poses and known-angle rotations, with honest σ.

Each channel is an SDF-like rate gyro (:mod:`gyrojax.physics.triad`); the three are fitted jointly from the
segments of ``imu-triad`` records (:mod:`gyrojax.data.triad`):

* **static pose** k: the mean indicated rate of each channel over the pose, modelled at the pose's mean specific
  force (accelerometer, g) with the inertial rate of a body at rest, the Earth rate (below);
* **rotation** r of a known angle Θ about a body axis n, angle history unknown: the integral constraint
  ∫ ω_ind dt = (model of the rotation) dt, in which the body rate is n·Θ·s(t)/∫s dt — the history's *shape* s(t)
  taken from the indicated rate about n itself, its *total* fixed to Θ (sign from the data). Every effect linear in
  the rate (scale factor, misalignment, bias, g-terms) then depends on Θ only, never on the invented shape; the
  rate-nonlinear ones (E_A, E_2) use the shape to first order.

Every coefficient enters linearly, so one generalized-least-squares solve fits them (exact derivatives by
``jax.jacfwd`` of the same measurement model). The covariance of the segment means is built from

* each channel's **long-run noise variance** q_c, estimated from the static residuals by a Bartlett-window
  (Newey–West 1987) sum of the pooled autocovariance, so filtered, correlated MEMS noise gives honest pose means
  (Var(mean of N) = q_c / N);
* the **unknown heading** of each hand-placed pose, a nuisance marginalised with a uniform prior: the horizontal
  Earth rate of magnitude Ω cos φ adds (Ω cos φ)²/2 (I − u uᵀ) to the pose's 3×3 block (u: Up in the body
  frame, from the accelerometer);
* the **angle error** of a hand rotation (``angle_std_deg``), σ_Θ² n nᵀ / T² on the rotation's block.

Earth rate (ω_ie = 15.04 deg/h): with the site latitude φ its vertical part Ω sin φ·u is modelled exactly; the
horizontal part enters as above. With the latitude unknown (``null``), the vertical part cannot be told from a
g-sensitivity along each sensing axis (both are ∝ a_I): it stays in D_I[c] (the result says so), and the horizontal
part is marginalised with its mean square over the sites of the sphere, Ω² E[cos² φ] = (2/3) Ω².
``earth_rate=False`` switches both off (a record's ``"earth_rate": false`` does too). In a gravity-to-gravity move
the Earth turns Up unseen by Ω_h T (T the move's duration): a variance (Ω_h T)²/2 per direction component.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from scipy import stats

from gyrojax import units
from gyrojax.data.record import Record
from gyrojax.data.triad import TRIAD_KIND, acc_g, axis_vector, gyro_dph
from gyrojax.errors import ModelError
from gyrojax.inference.identify import IdentifiabilityError, check_one_instrument, residue_columns
from gyrojax.noise.whiten import pooled_autocovariance
from gyrojax.physics import triad as tp
from gyrojax.protocol import atomic_write_text

DEFAULT_STATIC_TERMS = ("D_F", "D_I", "D_O", "D_S")
DEFAULT_ROTATION_TERMS = DEFAULT_STATIC_TERMS + ("sf_error", "ia_misalignment")
ALIAS_TOL = 1e-7
NW_MAX_LAG = 50  # samples: longest autocovariance lag of the long-run variance (MEMS filters span a few samples)


# ---- segments of the records as arrays -------------------------------------------------------------------------


@dataclass
class Segment:
    """One measurement group: a static pose or a rotation (three rows of the measurement vector, one per channel).

    ``y`` (3,) mean indicated rate, deg/h; ``w`` (n, 3) body rate (deg/h) and ``a`` (n, 3) specific force (g) of the
    model; ``t_h`` (n,) h; ``temp`` (n,) °C; ``extra`` (3, 3) covariance added to the noise (heading, angle), deg²/h²;
    ``n`` samples averaged; ``kind`` ``"static"`` or ``"rotation"``; ``name`` for reports.
    """

    kind: str
    name: str
    y: np.ndarray
    w: np.ndarray
    a: np.ndarray
    t_h: np.ndarray
    temp: np.ndarray
    n: int
    extra: np.ndarray
    record: str = ""
    info: dict = field(default_factory=dict)


@dataclass
class Move:
    """A gravity-to-gravity move (imu_tk): gyro samples ``g`` (n, 3) deg/h and specific force ``a`` (n, 3) g between
    two static poses whose Up directions in the body frame are ``u_from`` and ``u_to`` (unit vectors, from the
    accelerometer); ``dt`` s; ``var_dir`` the variance (rad², per axis) of the two directions' noise."""

    name: str
    g: np.ndarray
    a: np.ndarray
    dt: float
    u_from: np.ndarray
    u_to: np.ndarray
    var_dir: float
    earth_var: float = 0.0


def _earth(record: Record, earth_rate: bool | None):
    """(vertical rate Ω sin φ in deg/h or None when unknown/off, horizontal magnitude bound in deg/h, mode text)."""
    on = record.meta.get("earth_rate", True) if earth_rate is None else earth_rate
    if not on:
        return 0.0, 0.0, "off"
    lat = record.meta["site"].get("latitude_deg")
    omega = units.OMEGA_IE_DEG_PER_H
    if lat is None:  # the site averaged over the sphere: E[cos² φ] = 2/3
        return None, omega * math.sqrt(2.0 / 3.0), "latitude unknown"
    phi = math.radians(float(lat))
    return omega * math.sin(phi), omega * math.cos(phi), f"latitude {float(lat):g} deg"


def triad_segments(record: Record, earth_rate: bool | None = None):
    """The static and rotation segments of one triad record as :class:`Segment` s, the per-segment static residual
    series (deg/h, (n, 3), for the noise estimate), the Earth-rate mode (module doc) and the :class:`Move` s."""
    gyro = gyro_dph(record)
    acc = acc_g(record)
    t = np.asarray(record.time_s, dtype=float)
    temp = record.columns.get("temperature_C")
    temp = np.full(len(t), 20.0) if temp is None else np.asarray(temp, dtype=float)
    seg = np.asarray(record.columns["segment"]).astype(int)
    vertical, horizontal, mode = _earth(record, earth_rate)
    g_site = float(record.meta["site"]["gravity_mps2"]) / units.G0
    out, resid, moves = [], [], []
    for spec in record.meta["segments"]:
        sel = np.flatnonzero(seg == spec["label"])
        if spec["type"] == "move":
            mv = _move(record, spec, gyro, acc, t, seg)
            # Up is fixed to the Earth, the gyro integrates the inertial rate: over the move the Earth turns Up by
            # Ω_h T about a horizontal axis of unknown heading, variance (Ω_h T)²/2 per component
            mv.earth_var = (horizontal * len(mv.g) * mv.dt * units.DEG_PER_H) ** 2 / 2.0
            moves.append(mv)
            continue
        if len(sel) < 2:
            raise ModelError(f"{record.name}: segment {spec['label']} has {len(sel)} sample(s); at least 2 are needed")
        name = spec.get("name", f"{spec['type']}-{spec['label']}")
        g = gyro[sel]
        a = acc[sel] if acc is not None else None
        th = t[sel] / units.SECONDS_PER_HOUR
        if spec["type"] == "static":
            if a is not None:
                a_mean = a.mean(axis=0)
                u = a_mean / np.linalg.norm(a_mean)
            else:
                u = axis_vector(spec["up"])
                a_mean = u * g_site
            w = np.zeros((1, 3)) if vertical is None else (vertical * u)[None, :]
            extra = 0.5 * horizontal**2 * (np.eye(3) - np.outer(u, u))
            out.append(
                Segment(
                    "static",
                    name,
                    g.mean(axis=0),
                    w,
                    a_mean[None, :],
                    th.mean()[None],
                    temp[sel].mean()[None],
                    len(sel),
                    extra,
                    record.name,
                    {"up": u},
                )
            )
            resid.append(g - g.mean(axis=0))
        else:  # rotation of a known angle about a body axis, history unknown
            n_axis = axis_vector(spec["axis"])
            shape = g @ n_axis
            total = float(shape.sum())
            direction = spec.get("direction", "from-data")
            sign = {"positive": 1.0, "negative": -1.0}.get(direction, math.copysign(1.0, total))
            if direction == "from-data" and abs(total) == 0.0:
                raise ModelError(
                    f"{record.name}: rotation segment {spec['label']} shows no rotation about {spec['axis']}"
                )
            dt = (t[sel[-1]] - t[sel[0]]) / (len(sel) - 1)
            theta_deg = sign * float(spec["angle_deg"])
            # body rate (deg/h): n Θ s(t) / Σ s dt, so that Σ ω dt = n Θ (deg·h/h = deg, times 3600 s/h)
            w = np.outer(shape / total * theta_deg * units.SECONDS_PER_HOUR / dt, n_axis) * (1.0 if total else 0.0)
            if vertical is not None and a is not None:
                w = w + vertical * a / np.linalg.norm(a, axis=1, keepdims=True)
            a_rot = a if a is not None else np.tile(n_axis * sign * 0.0, (len(sel), 1))
            span = len(sel) * dt
            sd = float(spec.get("angle_std_deg", 0.0)) * units.SECONDS_PER_HOUR / span  # angle error as a mean rate
            # the horizontal Earth rate (unknown heading) turns with the body: its mean over the rotation is
            # |m| Ω_h with m = mean(exp(i φ(t))) over the angle history's shape; uniform heading ⇒ covariance
            # (Ω_h² |m|² / 2) (I − n nᵀ) (0 for a uniform full turn, up to the static value for a slow start/stop)
            phase = np.radians(theta_deg) * np.cumsum(shape) / total
            m2 = float(abs(np.mean(np.exp(1j * phase))) ** 2)
            nn = np.outer(n_axis, n_axis)
            extra = sd**2 * nn + 0.5 * horizontal**2 * m2 * (np.eye(3) - nn)
            out.append(
                Segment(
                    "rotation",
                    name,
                    g.mean(axis=0),
                    w,
                    a_rot,
                    th,
                    temp[sel],
                    len(sel),
                    extra,
                    record.name,
                    {"angle_deg": theta_deg, "axis": n_axis.tolist(), "duration_s": span},
                )
            )
    return out, resid, mode, moves


def _move(record: Record, spec: dict, gyro, acc, t, seg) -> Move:
    """The :class:`Move` of a ``move`` segment (module doc of :mod:`gyrojax.data.triad`)."""
    if acc is None:
        raise ModelError(f"{record.name}: move segment {spec['label']} needs the accelerometer (acc_<c>_g columns)")

    def pose(label):
        a = acc[seg == label]
        m = a.mean(axis=0)
        return m / np.linalg.norm(m), float(a.var(axis=0).mean()) / len(a) / float(m @ m)

    sel = np.flatnonzero(seg == spec["label"])
    if len(sel) < 2:
        raise ModelError(f"{record.name}: move segment {spec['label']} has {len(sel)} sample(s)")
    u0, v0 = pose(spec["from"])
    u1, v1 = pose(spec["to"])
    # the samples of the move plus the boundary samples, so that the integration spans the whole motion
    lo, hi = max(sel[0] - 1, 0), min(sel[-1] + 2, len(t))
    dt = (t[hi - 1] - t[lo]) / max(hi - lo - 1, 1)
    return Move(spec.get("name", f"move-{spec['label']}"), gyro[lo:hi], acc[lo:hi], float(dt), u0, u1, v0 + v1)


def linear_matrices(model, theta):
    """b (3,) deg/h, S (3, 3) and G (3, 3) deg/h/g of a linear channel model at θ (3p,), from the channel model
    itself (unit inputs through :func:`gyrojax.physics.triad.triad_output`), differentiable in θ."""
    th = theta.reshape(3, model.size)
    zero = jnp.zeros((3, 3))
    eye = jnp.eye(3)
    t, temp = jnp.zeros(3), jnp.full(3, 20.0)
    b = tp.triad_output(model, th, zero, zero, t, temp)[0]
    s = (tp.triad_output(model, th, eye, zero, t, temp) - b).T
    g = (tp.triad_output(model, th, zero, eye, t, temp) - b).T
    return b, s, g


def _expm_so3(v):
    """exp([v×]) by Rodrigues' formula, safe at v = 0 (v in rad)."""
    th2 = v @ v
    th = jnp.sqrt(jnp.where(th2 > 0, th2, 1.0))
    small = th2 < 1e-16
    a = jnp.where(small, 1.0 - th2 / 6.0, jnp.sin(th) / th)
    b = jnp.where(small, 0.5 - th2 / 24.0, (1.0 - jnp.cos(th)) / jnp.where(th2 > 0, th2, 1.0))
    k = jnp.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return jnp.eye(3) + a * k + b * (k @ k)


def move_residual(model, theta, g, a, mask, dt, u_from, u_to):
    """Residual u_to − Rᵀ u_from of a gravity-to-gravity move: R is the body's rotation over the move, integrated
    from the calibrated rates ω = S⁻¹ (ω_ind − b − G a) (sample by sample, exact exponential of each step's mean
    rate); Up stays fixed in space, so the predicted Up at the end is Rᵀ u_from (imu_tk, Tedaldi et al. §IV-C).
    ``g`` (n, 3) deg/h, ``a`` (n, 3) g, ``dt`` s, unit vectors ``u_from``/``u_to``; the residual is dimensionless.
    ``mask`` (n−1,) is 1 for the steps of the move and 0 for padding (moves are padded to one length, one compile)."""
    b, s, gm = linear_matrices(model, theta)
    w = jnp.linalg.solve(s, (g - b - a @ gm.T).T).T * units.DEG_PER_H  # rad/s
    steps = 0.5 * (w[1:] + w[:-1]) * dt * mask[:, None]

    def step(r, v):
        return r @ _expm_so3(v), None

    r, _ = jax.lax.scan(step, jnp.eye(3), steps)
    return u_to - r.T @ u_from


def _moves_residual(model, theta, g, a, mask, dt, u_from, u_to):
    """:func:`move_residual` of every move at once (arrays of :func:`pack_moves`: gyro deg/h, specific force g,
    dt s, Up directions unit vectors); (M, 3), dimensionless."""
    return jax.vmap(move_residual, in_axes=(None, None, 0, 0, 0, 0, 0, 0))(model, theta, g, a, mask, dt, u_from, u_to)


moves_residual_jit = jax.jit(_moves_residual, static_argnums=0)
moves_jacobian_jit = jax.jit(jax.jacfwd(_moves_residual, argnums=1), static_argnums=0)
LINEAR_TERMS = ("D_F", "D_I", "D_O", "D_S", "sf_error", "ia_misalignment")


def long_run_variance(resid: list[np.ndarray], max_lag: int = NW_MAX_LAG) -> np.ndarray:
    """Long-run variance q_c ((deg/h)², per channel) of static residual series: Var(mean of N samples) ≈ q_c / N.

    The pooled autocovariance γ_l (lagged products never cross a segment) summed with Bartlett weights,
    q = γ_0 + 2 Σ_{l=1..L} (1 − l/(L+1)) γ_l (Newey & West 1987), L = min(``max_lag``, shortest segment / 4);
    floored at γ_0 / 10 (a negative sum means L is too short to tell, not that the mean is exact)."""
    lens = [len(r) for r in resid if len(r)]
    if not lens:
        raise ModelError("no static segment: the noise of the pose means cannot be estimated")
    lag = int(max(1, min(max_lag, min(lens) // 4)))
    r_all = np.concatenate(resid, axis=0)
    bounds, i0 = [], 0
    for n in lens:
        bounds.append((i0, i0 + n))
        i0 += n
    w = 1.0 - np.arange(1, lag + 1) / (lag + 1)
    # each segment's mean was removed: its lagged products sum low by ≈ q each, so the pooled γ_l are low by
    # ≈ q / n̄ (n̄: mean segment length) and the window sum by the factor 1 − (1 + 2 Σ w_l)/n̄; divided out
    n_h = sum(lens) / len(lens)
    shrink = max(1.0 - (1.0 + 2.0 * float(w.sum())) / n_h, 0.5)
    q = np.zeros(3)
    for c in range(3):
        gam, _ = pooled_autocovariance(r_all[:, c], bounds, lag)
        q[c] = max(gam[0] + 2.0 * float(w @ gam[1:]), gam[0] / 10.0) / shrink
    return q


# ---- the fit ---------------------------------------------------------------------------------------------------


@dataclass
class TriadFit:
    """Per-channel coefficients of a gyro triad with their covariance, the matrix forms and fit statistics."""

    model: object
    names: list
    theta: np.ndarray
    cov: np.ndarray
    segments: list
    residuals: np.ndarray  # (m,) raw residual of each segment mean, deg/h
    noise_q: np.ndarray
    chi2: float
    dof: int
    earth_mode: str
    record_names: list
    not_excited: list
    counts_per_dps: float | None = None
    notes: list = field(default_factory=list)

    @property
    def std(self) -> np.ndarray:
        """Standard error of each coefficient, report units (NaN where the plan does not excite it)."""
        return np.sqrt(np.clip(np.diag(self.cov), 0.0, None))

    @property
    def values(self) -> dict:
        """``{"D_F[x]": value, …}`` in report units."""
        return dict(zip(self.names, map(float, self.theta)))

    @property
    def stds(self) -> dict:
        """``{"D_F[x]": std, …}`` in report units."""
        return dict(zip(self.names, map(float, self.std)))

    def units(self) -> dict:
        """Coefficient name → report unit."""
        u = self.model.coefficient_units
        return {tp.channel_name(c, ch): uu for ch in tp.CHANNELS for c, uu in zip(self.model.coefficient_names, u)}

    @property
    def residual_rms(self) -> float:
        """RMS of the segment-mean residuals, deg/h."""
        return float(np.sqrt(np.mean(self.residuals**2))) if self.residuals.size else float("nan")

    def matrices(self) -> dict:
        """b (deg/h), S, G (deg/h/g) of ω_ind = S ω + G a + b (:func:`gyrojax.physics.triad.matrices`)."""
        return tp.matrices(self.values)

    def apply(self, record: Record) -> np.ndarray:
        """Calibrated body rates (n, 3) deg/h of a triad record: ω = S⁻¹ (ω_ind − b − G a) (the linear model; the
        Earth rate is part of ω, as a navigator wants it). Refuses rate-nonlinear effects and missing
        accelerometer columns when G ≠ 0."""
        nonlin = [
            t for t in self.model.terms if t in ("sf_asymmetry", "sf_quadratic", "bias_trend", "bias_temperature")
        ]
        if nonlin:
            raise ModelError(f"apply inverts the linear model only; this fit has {nonlin}: refit without them")
        m = self.matrices()
        g = gyro_dph(record)
        a = acc_g(record)
        if a is None:
            if np.any(m["G"] != 0):
                raise ModelError(f"{record.name}: the fit has g-sensitivity but the record has no acc_<c>_g columns")
            a = np.zeros_like(g)
        return np.linalg.solve(m["S"], (g - m["b"] - a @ m["G"].T).T).T

    def to_json(self) -> dict:
        """The fit JSON (CONVENTIONS §7 shape, per-channel names ``D_F[x]``), with the matrix forms."""
        from gyrojax import __version__

        coeffs = {}
        unit = self.units()
        for n, v, s in zip(self.names, self.theta, self.std):
            coeffs[n] = {"value": float(v), "std": _num(s), "unit": unit[n]}
        m = self.matrices()
        k = self.counts_per_dps or 1.0
        ic = tp.imucal_form(m, k, rotation_sign=-1.0)
        kal = tp.kalibr_form(m)
        p = float(stats.chi2.sf(self.chi2, self.dof)) if self.dof > 0 else float("nan")
        return {
            "terms": list(self.model.terms),
            "instrument": TRIAD_KIND,
            "channels": list(tp.CHANNELS),
            "coefficients": coeffs,
            "residual_rms_deg_per_h": self.residual_rms,
            "n_samples": int(sum(s.n for s in self.segments)),
            "records": [{"name": n} for n in self.record_names],
            "not_excited": list(self.not_excited),
            "matrices": {
                "model": "omega_ind = S omega + G a + b (deg/h, a in g)",
                "b_deg_per_h": m["b"].tolist(),
                "S": m["S"].tolist(),
                "G_deg_per_h_per_g": m["G"].tolist(),
                "imucal": {
                    "model": "raw = K_g R_g omega + K_ga a + b_g (omega deg/s, a m/s^2 with grav 9.81, raw counts); "
                    "R_g for imucal's default expected_angle -360",
                    "counts_per_dps": k,
                    **{key: np.asarray(v).tolist() for key, v in ic.items() if key.startswith(("K", "R", "b"))},
                },
                "kalibr": {
                    "model": "omega_m = C_gyro_i M omega + A a + b (rad/s, a m/s^2)",
                    **{key: np.asarray(v).tolist() for key, v in kal.items() if key in ("C_gyro_i", "M", "A", "b")},
                },
            },
            "earth_rate": {"mode": self.earth_mode, "rate_deg_per_h": units.OMEGA_IE_DEG_PER_H},
            "noise": {
                ch: {"long_run_std_deg_per_h_sqrt_sample": float(np.sqrt(q))}
                for ch, q in zip(tp.CHANNELS, self.noise_q)
            },
            "segments": [
                {"name": s.name, "kind": s.kind, "n": s.n, "residual_deg_per_h": r.tolist(), **_jsonable(s.info)}
                for s, r in zip(self.segments, self.residuals.reshape(-1, 3))
            ],
            "fit": {"chi2": self.chi2, "dof": self.dof, "p_value": _num(p)},
            "notes": list(self.notes),
            "gyrojax_version": __version__,
        }

    def save(self, path, force: bool = False) -> Path:
        """Write :meth:`to_json` with ``theta``/``cov``/``names`` (format ``gyrojax-fit-1``) atomically."""
        import json

        p = Path(path)
        if p.exists() and not force:
            raise ModelError(f"{p}: exists; pass force=True (or --force) to overwrite")
        d = self.to_json()
        d.update(format="gyrojax-fit-1", names=list(self.names), theta=[float(x) for x in self.theta])
        d["cov"] = [[_num(x) for x in row] for row in self.cov]
        atomic_write_text(p, json.dumps(d, indent=1) + "\n")
        return p

    def text(self) -> str:
        """A coefficient table, one row per coefficient and channel."""
        lines = [f"{'coefficient':14s} {'value':>14s} {'std':>12s}  unit"]
        u = self.units()
        for n, v, s in zip(self.names, self.theta, self.std):
            lines.append(f"{n:14s} {v:14.6g} {s:12.4g}  {u[n]}")
        lines.append(f"earth rate: {self.earth_mode}; chi2 {self.chi2:.3g} on {self.dof} dof")
        lines.extend(f"note: {n}" for n in self.notes)
        return "\n".join(lines)


def _jsonable(d: dict) -> dict:
    return {k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v) for k, v in d.items()}


def _num(x):
    x = float(x)
    return x if math.isfinite(x) else None


def is_triad_input(records) -> bool:
    """True when ``records`` (a record or a list) are ``imu-triad`` records."""
    if isinstance(records, Record):
        return records.kind == TRIAD_KIND
    try:
        recs = list(records)
    except TypeError:
        return False
    return bool(recs) and all(isinstance(r, Record) and r.kind == TRIAD_KIND for r in recs)


def segment_means(model, theta, arrays):
    """Model of the stacked segment means (3 per segment, deg/h) for θ (3p,).

    ``arrays`` = (w (N, 3) deg/h, a (N, 3) g, t_h (N,), temperature (N,) °C, segment index (N,), counts (m,)): the
    samples of every segment concatenated, so that one evaluation of the channel model serves them all (one small
    compiled graph, reused while the shapes stay)."""
    w, a, t, temp, idx, counts = arrays
    y = tp.triad_output(model, theta.reshape(3, model.size), w, a, t, temp)
    sums = jax.ops.segment_sum(y, idx, num_segments=counts.shape[0])
    return (sums / counts[:, None]).reshape(-1)


def pack_segments(segments) -> tuple:
    """The ``arrays`` of :func:`segment_means` from :class:`Segment` s."""
    w = np.concatenate([s.w for s in segments])
    a = np.concatenate([s.a for s in segments])
    t = np.concatenate([s.t_h for s in segments])
    temp = np.concatenate([s.temp for s in segments])
    idx = np.concatenate([np.full(len(s.t_h), i) for i, s in enumerate(segments)])
    counts = np.array([len(s.t_h) for s in segments], dtype=float)
    return tuple(jnp.asarray(x) for x in (w, a, t, temp, idx, counts))


segment_means_jit = jax.jit(segment_means, static_argnums=0)
segment_jacobian_jit = jax.jit(jax.jacfwd(segment_means, argnums=1), static_argnums=0)


def fit_triad(
    records,
    terms=None,
    *,
    earth_rate: bool | None = None,
    allow_aliases: bool = False,
    noise_q=None,
) -> TriadFit:
    """Fit per-channel SDF coefficients of a gyro triad to ``imu-triad`` records of one instrument (module doc).

    Args:
      records: a triad :class:`Record` or a list of them (one instrument: ``instrument.id`` decides).
      terms: effect names applied to every channel (default D_F, D_I, D_O, D_S, plus sf_error and
        ia_misalignment when there are rotations).
      earth_rate: override the records' ``earth_rate`` (False: no Earth rate in the model or the covariance).
      allow_aliases: return a minimum-norm fit instead of raising when the segments cannot separate some effects.
      noise_q: per-channel long-run noise variance (deg/h)² per sample, instead of estimating it.

    Returns: a :class:`TriadFit`; coefficients ``<name>[<channel>]`` in report units.
    Raises: :class:`~gyrojax.inference.identify.IdentifiabilityError` naming what the segments cannot separate.
    """
    recs = [records] if isinstance(records, Record) else list(records)
    if not recs:
        raise ModelError("no records to fit")
    if not is_triad_input(recs):
        raise ModelError("fit_triad takes imu-triad records only")
    check_one_instrument(recs)
    segments, resid, modes, moves = [], [], set(), []
    for r in recs:
        s, q, mode, mv = triad_segments(r, earth_rate)
        segments.extend(s)
        resid.extend(q)
        modes.add(mode)
        moves.extend(mv)
    if not segments:
        raise ModelError("the records hold no static or rotation segment to fit")
    has_rot = any(s.kind == "rotation" for s in segments) or bool(moves)
    if terms is None:
        terms = DEFAULT_ROTATION_TERMS if has_rot else DEFAULT_STATIC_TERMS
    model = tp.channel_model(terms)
    if moves and any(t not in LINEAR_TERMS for t in model.terms):
        raise ModelError(
            f"gravity-to-gravity moves integrate the calibrated rate of the linear model ({', '.join(LINEAR_TERMS)}); "
            f"drop {[t for t in model.terms if t not in LINEAR_TERMS]}"
        )
    names = [tp.channel_name(c, ch) for ch in tp.CHANNELS for c in model.coefficient_names]
    q = long_run_variance(resid) if noise_q is None else np.asarray(noise_q, dtype=float)

    arrays = pack_segments(segments)
    theta0 = jnp.zeros(3 * model.size)
    base = np.asarray(segment_means_jit(model, theta0, arrays))
    jac = np.asarray(segment_jacobian_jit(model, theta0, arrays))
    y = np.concatenate([s.y for s in segments])
    # whitening by the Cholesky factor of each segment's 3×3 covariance block
    rw, jw = np.empty_like(y), np.empty_like(jac)
    for i, s in enumerate(segments):
        block = np.diag(q / s.n) + s.extra
        low = np.linalg.cholesky(block)
        sl = slice(3 * i, 3 * i + 3)
        rw[sl] = np.linalg.solve(low, y[sl] - base[sl])
        jw[sl] = np.linalg.solve(low, jac[sl])
    lin_r, lin_j = rw, jw
    theta = np.zeros(3 * model.size)
    move_w = _move_whitening(moves, q)
    packed = pack_moves(moves) if moves else None
    if moves:  # Gauss–Newton on the linear rows and the moves' direction residuals (2 whitened rows per move)
        theta = _svd_step(lin_j, lin_r)  # statics (+ rotations): bias and g-terms; scale factor nominal
        for _ in range(30):
            mr, mj = _move_rows(model, theta, packed, move_w)
            rw = np.concatenate([lin_r - lin_j @ theta, mr])
            jw = np.concatenate([lin_j, mj])
            step = _svd_step(jw, rw)
            theta = theta + step
            # converged when no coefficient moves by more than 1e-6 of its own standard error (whitened columns)
            if np.max(np.abs(step) * np.sqrt((jw * jw).sum(axis=0))) < 1e-6:
                break
        mr, mj = _move_rows(model, theta, packed, move_w)
        rw = np.concatenate([lin_r - lin_j @ theta, mr])
        jw = np.concatenate([lin_j, mj])
    residue = residue_columns(jw)
    not_excited = [names[i] for i in np.flatnonzero(residue)]
    jw = np.where(residue, 0.0, jw)
    norms = np.sqrt((jw * jw).sum(axis=0))
    z = jw / np.where(norms > 0, norms, 1.0)
    u, sv, vt = np.linalg.svd(z, full_matrices=False)
    keep = sv >= ALIAS_TOL * sv[0]
    groups = []
    for k in np.flatnonzero(~keep):
        members = [names[i] for i in np.flatnonzero(np.abs(vt[k]) > 0.05) if not residue[i]]
        if members:
            groups.append(members)
    if (groups or not_excited) and not allow_aliases:
        msg = "; ".join("[" + " + ".join(g) + "]" for g in groups)
        msg = ("these segments cannot tell apart: " + msg) if msg else ""
        if not_excited:
            msg += ("; " if msg else "") + "not excited: " + ", ".join(not_excited)
        raise IdentifiabilityError(
            msg + "; drop effects, or add poses/rotations that separate them",
            {"aliases": groups, "unexcited": not_excited},
        )
    sinv = np.where(keep, 1.0 / np.where(keep, sv, 1.0), 0.0)
    theta = theta + (vt.T * sinv) @ (u.T @ rw) / np.where(norms > 0, norms, 1.0)
    cov = ((vt.T * sinv**2) @ vt) / np.outer(np.where(norms > 0, norms, 1.0), np.where(norms > 0, norms, 1.0))
    if moves:
        mr, _ = _move_rows(model, theta, packed, move_w)
        rw = np.concatenate([lin_r - lin_j @ theta, mr])
        jw_full = np.concatenate([lin_j, np.zeros((len(mr), lin_j.shape[1]))])
        e_all = rw
    else:
        jw_full = None
    bad = residue.copy()
    if not keep.all():
        bad |= np.abs(vt[~keep]).max(axis=0) > 0.05
    cov[bad, :] = np.nan
    cov[:, bad] = np.nan
    e = e_all if moves else rw - jw @ theta
    dof = int(len(rw) - keep.sum())
    chi2 = float(e @ e)
    raw_res = y - base - jac @ np.where(bad, 0.0, theta)
    del jw_full
    mode = " / ".join(sorted(modes))
    notes = []
    if "latitude unknown" in modes and any(t == "D_I" for t in model.terms):
        notes.append(
            "site latitude unknown: the vertical Earth rate Omega sin(phi) (|.| <= 15.04 deg/h) cannot be told from "
            "g-sensitivity along each sensing axis, so each D_I[c] includes it (G includes Omega sin(phi) S / |a|: "
            "also M_O, M_S times it in D_O, D_S); the horizontal Earth rate (unknown heading) is marginalised with "
            "its mean square over the sites of the sphere, (2/3) (15.04 deg/h)^2"
        )
    if dof > 0 and stats.chi2.sf(chi2, dof) < 0.01:
        notes.append(
            f"the segment means scatter more than the sample noise explains (chi2 {chi2:.3g} on {dof} dof, "
            f"p {stats.chi2.sf(chi2, dof):.2g}): bias shifts between poses or a missing effect; the standard errors "
            "assume the noise model and may be too small"
        )
    scales = {float(r.meta["instrument"].get("gyro_counts_per_dps") or 0.0) for r in recs}
    k = scales.pop() if len(scales) == 1 else None
    return TriadFit(
        model,
        names,
        theta,
        cov,
        segments,
        raw_res,
        q,
        chi2,
        dof,
        mode,
        [r.name for r in recs],
        not_excited,
        counts_per_dps=k or None,
        notes=notes,
    )


def _svd_step(jw, rw):
    """Minimum-norm least-squares step in normalised columns (a rank cut at :data:`ALIAS_TOL`)."""
    norms = np.sqrt((jw * jw).sum(axis=0))
    sc = np.where(norms > 0, norms, 1.0)
    u, sv, vt = np.linalg.svd(jw / sc, full_matrices=False)
    keep = sv >= ALIAS_TOL * sv[0]
    sinv = np.where(keep, 1.0 / np.where(keep, sv, 1.0), 0.0)
    return (vt.T * sinv) @ (u.T @ rw) / sc


def _move_whitening(moves, q) -> list:
    """Per move: (P (3, 2) basis ⟂ u_to, σ (rad) of each of the two residual components). The variance is the
    gyro noise integrated over the move (mean long-run variance of the channels × n dt²), the noise of the two Up
    directions, and the Earth turning Up unseen during the move (:attr:`Move.earth_var`, heading unknown)."""
    out = []
    q_mean = float(np.mean(q))
    for m in moves:
        n = len(m.g)
        angle_var = q_mean * n * m.dt**2 * units.DEG_PER_H**2
        var = angle_var + m.earth_var + m.var_dir
        u = m.u_to
        a = np.eye(3)[int(np.argmin(np.abs(u)))]
        e1 = np.cross(u, a)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(u, e1)
        out.append((np.column_stack([e1, e2]), float(np.sqrt(var))))
    return out


def pack_moves(moves) -> tuple:
    """The moves padded to one length: (g (M, L, 3), a (M, L, 3), mask (M, L−1), dt (M,), u_from (M, 3), u_to)."""
    length = max(len(m.g) for m in moves)
    g = np.zeros((len(moves), length, 3))
    a = np.zeros((len(moves), length, 3))
    mask = np.zeros((len(moves), length - 1))
    for i, m in enumerate(moves):
        n = len(m.g)
        g[i, :n], a[i, :n] = m.g, m.a
        g[i, n:], a[i, n:] = m.g[-1], m.a[-1]
        mask[i, : n - 1] = 1.0
    dt = np.array([m.dt for m in moves])
    u0 = np.array([m.u_from for m in moves])
    u1 = np.array([m.u_to for m in moves])
    return tuple(jnp.asarray(x) for x in (g, a, mask, dt, u0, u1))


def _move_rows(model, theta, packed, whitening):
    """Whitened residual rows (2 per move) and their Jacobian (2 per move, 3p columns) at θ."""
    th = jnp.asarray(theta)
    r = np.asarray(moves_residual_jit(model, th, *packed))
    j = -np.asarray(moves_jacobian_jit(model, th, *packed))  # rows of "y − f": the Jacobian of f is −∂r/∂θ
    rows = [p.T @ r[i] / sd for i, (p, sd) in enumerate(whitening)]
    jacs = [p.T @ j[i] / sd for i, (p, sd) in enumerate(whitening)]
    return np.concatenate(rows), np.concatenate(jacs)


def load_triad_fit(path) -> TriadFit:
    """A triad fit saved by :meth:`TriadFit.save` (estimates and covariance; segment residuals are not kept)."""
    import json

    p = Path(path)
    try:
        d = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:  # unreadable, not UTF-8, not JSON
        raise ModelError(f"{p}: cannot read a fit result ({e})") from None
    if d.get("format") != "gyrojax-fit-1" or d.get("instrument") != TRIAD_KIND or "theta" not in d:
        raise ModelError(f"{p}: not a saved imu-triad fit (save one with `gyrojax fit RECORDS --save FIT.json`)")
    try:
        return _triad_fit_of(d)
    except (KeyError, TypeError, ValueError, IndexError) as e:
        raise ModelError(
            f"{p}: a damaged imu-triad fit ({type(e).__name__}: {e}); save it again with `fit --save`"
        ) from None


def _triad_fit_of(d: dict) -> TriadFit:
    model = tp.channel_model(d["terms"])
    cov = np.array([[np.nan if x is None else x for x in row] for row in d["cov"]], dtype=float)
    return TriadFit(
        model,
        list(d["names"]),
        np.asarray(d["theta"], dtype=float),
        cov,
        [],
        np.zeros(0),
        np.zeros(3),
        float(d["fit"]["chi2"]),
        int(d["fit"]["dof"]),
        d["earth_rate"]["mode"],
        [r["name"] for r in d["records"]],
        list(d.get("not_excited", [])),
        counts_per_dps=d["matrices"]["imucal"].get("counts_per_dps"),
        notes=list(d.get("notes", [])),
    )
