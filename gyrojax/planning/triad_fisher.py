"""The MEMS gyro triad's plug-in of the Fisher core (:func:`gyrojax.planning.fisher.information`): the rows and
the noise of a hand calibration protocol as the triad fit (:func:`gyrojax.inference.triad.fit_triad`) weighs them.

A protocol is a chain of rests joined by motions (:mod:`gyrojax.simulation.triad_session`). The rows are those of
the fit's own channel model (:func:`gyrojax.physics.triad.triad_output`) at θ = 0 (nominal S = I: a MEMS triad's
1 % scale errors change F by about 1 %), where for the linear terms every row is affine in the body rate ω and the
specific force a (:func:`gyrojax.physics.triad.affine_rows`: rows(ω, a) = B₀ + ω·B_ω + a·B_a). Each part gives:

* **rest** k, Up u_k in the body frame, T_k s: the mean indicated rate, rows(Ω sin φ u_k or 0, |g| u_k) (the
  vertical Earth rate only with the latitude known); covariance (conventions §9.3, Hu 3-14 least squares)
  (ARW² / T_k + τ_b²) I + ½ Ω_h² (I − u uᵀ) (the horizontal Earth rate of unknown heading; τ_b the per-pose bias
  scatter, 0 unless given);
* **known-angle turn** (imucal) by Θ about n in T s: the mean indicated rate, rows(Θ/T n + the vertical Earth rate
  along the mean Up, |g| × the mean of R(n, α)ᵀ u over the turn's profile); covariance ARW²/T I + σ_Θ²/T² n nᵀ +
  ½ Ω_h² |⟨e^{iα}⟩|² (I − n nᵀ), the angle error σ_Θ = √2 σ_placement;
* **gravity-to-gravity move** (imu_tk) by Φ about n in T s: the residual u_to − Rᵀ u_from of
  :func:`gyrojax.inference.triad_rows.move_residual`, R = E_1 ⋯ E_K the product of the exact exponentials of the K
  steps' mean rates v_k (:data:`MOVE_SAMPLES` samples of the profile ∝ sin(π t / T), at rest before and after). Its
  rows at θ = 0 are the first-order perturbation of that product (y = Rᵀ u_from, P_k = E_1 ⋯ E_k, J_r the right
  Jacobian of SO(3); ∂ω/∂θ = −rows(ω, a) at S = I):

      ∂r/∂θ = −[y×] Rᵀ Σ_k P_k J_r(v_k) ∂v_k/∂θ,   ∂v_k/∂θ = −½ Δt (rows(ω_k, a_k) + rows(ω_{k+1}, a_{k+1}))

  the same numbers as ``jax.jacfwd`` of the fit's residual, to rounding; projected ⟂ u_to, variance ARW² T (the
  angle noise) + (Ω_h T)²/2 (Earth turning Up unseen) + the accelerometer noise of the two Up directions
  σ_a² / (rate T_rest) each + τ_m² (the per-move angle noise, 0 unless given). The placement error of a rest does
  not enter a move: both Up directions are measured.

Parts carry a weight (1, or 0 for padding): one compiled function serves protocols of different structure.
``F = Σ Jᵀ C⁻¹ J`` (3p × 3p, report units: deg/h, deg/h/g, ppm, arcsec), coefficients ``<name>[<channel>]``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.errors import ModelError
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics import so3
from gyrojax.physics import triad as tp
from gyrojax.physics.gravity import site_gravity
from gyrojax.physics.kept_model import keepable
from gyrojax.planning.fisher import information
from gyrojax.runtime.kept import kept_arrays

MOVE_SAMPLES = 24
"""Samples of a move's profile in its rows (between the rests before and after)."""
TURN_SAMPLES = 64
"""Samples of a known-angle turn's profile (its Earth-rate phase and mean specific force)."""


@dataclass(frozen=True)
class TriadNoise:
    """What the design assumes about the session: the gyro's angle random walk ``arw`` (deg/√h, each channel), the
    accelerometer's white noise ``acc_noise_g`` (g per sample at ``rate_hz``), the site (``latitude_deg`` None:
    unknown to the fit, as in most hand calibrations; ``earth_rate`` False: no Earth rate; ``gravity_mps2`` None: the
    site's, :func:`gyrojax.physics.gravity.site_gravity`), the hand's ``placement_deg`` (σ of each placement about
    each body axis, deg), and the fit's variance components between segments
    (:mod:`gyrojax.inference.triad_components`): ``pose_scatter_dph`` (an independent bias level at each rest, σ in
    deg/h on every axis) and ``move_angle_deg`` (an angle error of each move about each horizontal axis, σ in deg)."""

    arw: float = 1.2
    acc_noise_g: float = 0.002
    rate_hz: float = 100.0
    latitude_deg: float | None = None
    earth_rate: bool = True
    placement_deg: float = 0.0
    gravity_mps2: float | None = None
    pose_scatter_dph: float = 0.0
    move_angle_deg: float = 0.0

    @classmethod
    def from_spec(cls, spec: NoiseSpec, where: str = "noise", **session) -> "TriadNoise":
        """The session's noise from a gyro :class:`~gyrojax.noise.spec.NoiseSpec`: its white noise, with each
        Gauss–Markov drift taken as its long-run white equivalent N² + 2σ²τ (τ much shorter than the rests: the
        fit's rest means see its integral); slower terms are refused, naming ``where`` (a hand session's minutes
        cannot tell them from the bias). ``session``: the other fields."""
        slow = [k for k in ("random_walk", "rate_ramp", "bias_instability") if getattr(spec, k)]
        if slow:
            raise ModelError(
                f"{where}: the imu-triad design takes white noise and Gauss-Markov drift; {slow[0]} is not modelled "
                "by the triad fit"
            )
        if not 0 < spec.white < math.inf:
            raise ModelError(
                f"{where}: the imu-triad design needs a white noise (ARW) > 0 deg/sqrt(h); got {spec.white}"
            )
        eff = spec.white**2 + sum(2.0 * s**2 * t / units.SECONDS_PER_HOUR for s, t in spec.gauss_markov)
        return cls(arw=math.sqrt(eff), **session)

    def earth(self) -> tuple[float | None, float]:
        """(vertical Earth rate Ω sin φ in deg/h, None when unknown or off; horizontal magnitude Ω_h in deg/h)."""
        if not self.earth_rate:
            return None, 0.0
        om = units.OMEGA_IE_DEG_PER_H
        if self.latitude_deg is None:
            return None, om * math.sqrt(2.0 / 3.0)
        phi = math.radians(self.latitude_deg)
        return om * math.sin(phi), om * math.cos(phi)

    @property
    def g(self) -> float:
        """|g| in g: the stated gravity, else the site's."""
        grav = site_gravity(self.latitude_deg) if self.gravity_mps2 is None else self.gravity_mps2
        return grav / units.G0

    def numbers(self) -> "NoiseNumbers":
        """The numbers the information uses (arrays in a traced function: one compiled function for any noise)."""
        vertical, horizontal = self.earth()
        return NoiseNumbers(
            self.arw,
            self.acc_noise_g,
            self.rate_hz,
            self.g,
            vertical or 0.0,
            horizontal,
            self.placement_deg,
            self.pose_scatter_dph,
            self.move_angle_deg,
        )


class NoiseNumbers(NamedTuple):
    """:class:`TriadNoise` as numbers: ``arw`` deg/√h, ``acc_noise_g`` g, ``rate_hz`` Hz, ``g`` (|g| in g), the
    modelled vertical Earth rate ``vertical`` (deg/h, 0 when unknown or off), the horizontal one ``horizontal``
    (deg/h), ``placement_deg``, ``pose_scatter_dph`` (deg/h), ``move_angle_deg`` (deg)."""

    arw: object
    acc_noise_g: object
    rate_hz: object
    g: object
    vertical: object
    horizontal: object
    placement_deg: object
    pose_scatter_dph: object = 0.0
    move_angle_deg: object = 0.0


class Parts(NamedTuple):
    """A protocol's parts as arrays (leading axes: any batch, then the parts), each with a weight (1, or 0 for
    padding). Rests: Up ``rest_up`` (…, N, 3) in the body frame, ``rest_s`` (…, N) s. Known-angle turns:
    ``turn_up`` (start Up), unit ``turn_axis``, ``turn_angle`` rad, ``turn_s``. Moves: ``move_up`` (start Up),
    unit ``move_axis``, ``move_angle`` rad, ``move_s``, the rests on either side ``move_rest_from``/``move_rest_to``
    s."""

    rest_up: object
    rest_s: object
    rest_w: object
    turn_up: object
    turn_axis: object
    turn_angle: object
    turn_s: object
    turn_w: object
    move_up: object
    move_axis: object
    move_angle: object
    move_s: object
    move_rest_from: object
    move_rest_to: object
    move_w: object


_affine_rows = jax.jit(tp.affine_rows, static_argnums=0)


@functools.lru_cache(maxsize=16)
def rows_basis(model) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The model's :func:`~gyrojax.physics.triad.affine_rows` (B₀, B_ω, B_a) as numpy arrays: computed once, and kept
    across processes (:func:`~gyrojax.runtime.kept.kept_arrays`) when the model's effects are all built in."""

    def compute():
        return [np.asarray(b) for b in _affine_rows(model)]

    if not keepable(model):
        return tuple(compute())
    return tuple(kept_arrays("affine_rows", (model.kind, model.terms), compute))


def profile_fractions(n_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """The profile ∝ sin(π t / T) of a turn by Φ in T s sampled ``n_samples`` times (that of
    :func:`gyrojax.simulation.triad.turn_samples`): the fraction of Φ turned in each sample interval (summing to 1)
    and the fraction turned at each sample's midpoint; rate_k = Φ frac_k / Δt, angle_k = Φ mid_k (numpy)."""
    prof = np.sin(np.pi * (np.arange(n_samples) + 0.5) / n_samples)
    frac = prof / prof.sum()
    return frac, np.cumsum(frac) - 0.5 * frac


def _rows(basis, w, a):
    """rows(ω, a) (…, 3, 3p) of inputs ``w`` (…, 3) deg/h and ``a`` (…, 3) g (module doc)."""
    b0, bw, ba = basis
    return b0 + jnp.einsum("...j,jcq->...cq", w, bw) + jnp.einsum("...j,jcq->...cq", a, ba)


def _turned_up(u, axis, c, s):
    """R(n, α)ᵀ u by Rodrigues from c = cos α and s = sin α (or their means over a turn: the mean Up)."""
    return u * c - jnp.cross(axis, u) * s + axis * (axis @ u) * (1.0 - c)


def rest_information(basis, parts: Parts, noise: NoiseNumbers):
    """F of the rests of ``parts`` (module doc)."""
    up = parts.rest_up
    jac = _rows(basis, noise.vertical * up, up * noise.g)
    alpha = noise.arw**2 / (parts.rest_s / units.SECONDS_PER_HOUR)  # (deg/h)² of a rest mean
    alpha = alpha + noise.pose_scatter_dph**2  # the rest's own bias level
    uu = up[:, :, None] * up[:, None, :]
    prec = uu / alpha[:, None, None] + (jnp.eye(3) - uu) / (alpha + 0.5 * noise.horizontal**2)[:, None, None]
    return information(jac, prec, parts.rest_w)


def turn_information(basis, parts: Parts, noise: NoiseNumbers):
    """F of the known-angle turns of ``parts`` (module doc; angles in rad, durations in s)."""
    _, mid = profile_fractions(TURN_SAMPLES)

    def one(u, n, angle, dur):
        c, s = jnp.mean(jnp.cos(angle * mid)), jnp.mean(jnp.sin(angle * mid))
        a = _turned_up(u, n, c, s)
        w = angle / dur * n / units.DEG_PER_H + noise.vertical * a
        jac = _rows(basis, w, a * noise.g)
        nn = n[:, None] * n[None, :]
        var_axis = noise.arw**2 / (dur / units.SECONDS_PER_HOUR)
        sd = math.sqrt(2.0) * noise.placement_deg * units.DEG / units.DEG_PER_H / dur  # deg/h, mean rate
        prec = nn / (var_axis + sd**2) + (jnp.eye(3) - nn) / (var_axis + 0.5 * noise.horizontal**2 * (c * c + s * s))
        return jac, prec

    jac, prec = jax.vmap(one)(parts.turn_up, parts.turn_axis, parts.turn_angle, parts.turn_s)
    return information(jac, prec, parts.turn_w)


def _about_axis_sums(prefix_angle, step, weights):
    """Σ_k x_k P_k J_r(v_k) for steps v_k = θ_k n about one unit axis n, P_k = R(n, Θ_k): with K = [n×]
    (K³ = −K), P_k J_r(v_k) = I + β_k K + γ_k K², so each sum is (Σ x, Σ β x, Σ γ x) for every weight sequence x of
    ``weights`` (…, K). Returns (…, 3) coefficients of (I, K, K²)."""
    c, s = jnp.cos(prefix_angle), jnp.sin(prefix_angle)
    sinc = jnp.sinc(step / jnp.pi)  # sin θ/θ, smooth through θ = 0
    c1 = jnp.sin(0.5 * step) * jnp.sinc(0.5 * step / jnp.pi)  # (1 − cos θ)/θ; J_r = I − c1 K + c2 K²
    c2 = 1.0 - sinc  # (θ − sin θ)/θ
    beta = s - c1 - s * c2 + (1.0 - c) * c1
    gamma = c2 - s * c1 + (1.0 - c) * (1.0 - c2)
    return jnp.stack([weights.sum(-1), (weights * beta).sum(-1), (weights * gamma).sum(-1)], -1)


def move_information(basis, parts: Parts, noise: NoiseNumbers):
    """F of the gravity-to-gravity moves of ``parts`` (module doc; angles in rad, times in s; every step of a move is
    about its axis n, so the sums Σ_k P_k J_r(v_k) ∂v_k/∂θ reduce to scalar sums over the steps,
    :func:`_about_axis_sums`)."""
    b0, bw, ba = basis
    frac, mid = profile_fractions(MOVE_SAMPLES)
    sigma = 0.5 * (np.r_[0.0, frac] + np.r_[frac, 0.0])  # each step's share of Φ (at rest before and after)
    theta_frac, alpha_frac = np.cumsum(sigma), np.r_[0.0, mid, 1.0]

    def one(u, n, angle, dur, t0, t1):
        dt = dur / MOVE_SAMPLES
        ca, sa = jnp.cos(angle * alpha_frac), jnp.sin(angle * alpha_frac)  # the turned angle at each sample
        # ω_k + ω_{k+1} = ρ_k n (deg/h); a_k + a_{k+1} = |g| (C_k u − S_k n×u + (2 − C_k)(n·u) n) (R(n, α)ᵀ u)
        rho = 2.0 * angle * sigma / dt / units.DEG_PER_H
        cc, ss = ca[1:] + ca[:-1], sa[1:] + sa[:-1]
        weights = jnp.stack([jnp.ones_like(rho), rho, cc, ss, 2.0 - cc])
        sums = _about_axis_sums(angle * theta_frac, angle * sigma, weights)
        nn = n[:, None] * n[None, :]
        m = (
            sums[:, 0, None, None] * jnp.eye(3)
            + sums[:, 1, None, None] * so3.hat(n)
            + sums[:, 2, None, None] * (nn - jnp.eye(3))  # K² = n nᵀ − I
        )
        nxu = jnp.cross(n, u)
        # the rows' directions: Σ_j v_j B[j] for v = n (rate), u, n × u and n (specific force)
        g = jnp.einsum("vj,vjcq->vcq", jnp.stack([n, u, nxu, n]), jnp.stack([bw, ba, ba, ba]))
        g = jnp.concatenate([2.0 * b0[None], g[:1], noise.g * g[1:2], -noise.g * g[2:3], noise.g * (n @ u) * g[3:]])
        x = jnp.einsum("iab,ibq->aq", m, g)
        x = -0.5 * dt * units.DEG_PER_H * x  # Σ_k P_k J_r(v_k) ∂v_k/∂θ
        cos_t, sin_t = jnp.cos(angle * theta_frac[-1]), jnp.sin(angle * theta_frac[-1])  # R = P_K = R(n, Φ)
        u_to = _turned_up(u, n, cos_t, sin_t)  # Rᵀ u
        nx = (n[:, None] * x).sum(axis=0)
        rt_x = x * cos_t - jnp.cross(n, x, axisb=0, axisc=0) * sin_t + n[:, None] * nx * (1.0 - cos_t)  # Rᵀ x
        jac = -jnp.cross(u_to, rt_x, axisb=0, axisc=0)
        span_h = (dur + 2.0 / noise.rate_hz) / units.SECONDS_PER_HOUR
        var = (noise.arw * jnp.sqrt(span_h) * units.DEG) ** 2
        var = var + (noise.horizontal * span_h * units.SECONDS_PER_HOUR * units.DEG_PER_H) ** 2 / 2.0
        var = var + noise.acc_noise_g**2 / noise.rate_hz / noise.g**2 * (1.0 / t0 + 1.0 / t1)
        var = var + (noise.move_angle_deg * units.DEG) ** 2  # the move's own angle error
        return jac, (jnp.eye(3) - u_to[:, None] * u_to[None, :]) / var

    args = (parts.move_up, parts.move_axis, parts.move_angle, parts.move_s, parts.move_rest_from, parts.move_rest_to)
    jac, prec = jax.vmap(one)(*args)
    return information(jac, prec, parts.move_w)


def protocol_information(basis, parts: Parts, noise: NoiseNumbers):
    """F (3p × 3p) of a protocol's parts (module doc) from the model's :func:`~gyrojax.physics.triad.affine_rows`
    ``basis`` and the session's :meth:`TriadNoise.numbers`; traceable: jit and vmap it over protocols."""
    f = rest_information(basis, parts, noise)
    if parts.turn_up.shape[0]:
        f = f + turn_information(basis, parts, noise)
    if parts.move_up.shape[0]:
        f = f + move_information(basis, parts, noise)
    return f


def steps_parts(start_attitude, steps) -> Parts:
    """The parts (numpy) of a protocol given as steps (:mod:`gyrojax.simulation.triad_session`) from
    ``start_attitude`` (body → ENU, 3×3): the Up of every rest, every known-angle turn and every move (angles of
    the steps in deg, of the parts in rad; times in s); a reorientation is not fitted. Refused with the step's
    index when a move is not between two rests."""
    c = np.asarray(start_attitude, dtype=float)
    rests, turns, moves = [], [], []
    for i, s in enumerate(steps):
        up = c[2].copy()  # Cᵀ e_U
        if s["type"] == "rest":
            rests.append((up, float(s["rest_s"])))
            continue
        ax = np.asarray(s["axis"], dtype=float)
        ax = ax / np.linalg.norm(ax)
        phi = math.radians(float(s["angle_deg"]))
        if s["type"] == "move":
            if not (0 < i < len(steps) - 1 and steps[i - 1]["type"] == steps[i + 1]["type"] == "rest"):
                raise ModelError(f"step {i}: a move is fitted from the rests on both sides")
            rest_to = float(steps[i + 1]["rest_s"])
            moves.append((up, ax, phi, float(s["duration_s"]), float(steps[i - 1]["rest_s"]), rest_to))
        elif s["type"] == "turn":
            turns.append((up, ax, phi, float(s["duration_s"])))
        c = c @ so3.rotation(ax, phi)

    def cols(rows, widths):
        if not rows:
            return [np.zeros((0, 3) if w == 3 else (0,)) for w in widths]
        return [np.array(x, dtype=float) for x in zip(*rows)]

    r = cols(rests, (3, 1))
    t = cols(turns, (3, 3, 1, 1))
    m = cols(moves, (3, 3, 1, 1, 1, 1))
    return Parts(*r, np.ones(len(rests)), *t, np.ones(len(turns)), *m, np.ones(len(moves)))


def pad_parts(parts: list[Parts]) -> Parts:
    """Protocols' parts stacked along a new leading axis, each kind padded to the longest with weight 0 (a rest of
    1 s with Up +z, a turn or move of 1 rad about +z in 1 s between rests of 1 s)."""
    fill = {"up": (0.0, 0.0, 1.0), "axis": (0.0, 0.0, 1.0), "w": 0.0}
    out = []
    for name in Parts._fields:
        arrays = [np.asarray(getattr(p, name), dtype=float) for p in parts]
        longest = max(x.shape[0] for x in arrays)
        value = np.asarray(fill.get(name.rsplit("_", 1)[-1], 1.0))
        out.append(
            np.stack(
                [np.concatenate([x, np.broadcast_to(value, (longest - x.shape[0],) + x.shape[1:])]) for x in arrays]
            )
        )
    return Parts(*out)
