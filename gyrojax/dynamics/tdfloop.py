"""Capture (rebalance) loops of a two-degree-of-freedom dynamically tuned gyro (DTG), both channels, as a jitted scan.

Rotor dynamics in case axes X, Y (spin axis Z = X × Y, angular momentum H along +Z). θ = (θx, θy) is the rotor's
tilt relative to the case (rad, what the pickoffs read), ω = (ωx, ωy) the case's inertial rate; the rotor's
inertial tilt rate is q = θ̇ + ω. Linearised Euler equations of a symmetric rotor of transverse inertia A with the
tuned suspension's residual forces (all torques about case axes, N·m):

    A θ̈x + D θ̇x + ΔK θx + H θ̇y + λ θy = M_x − H ωy − A ω̇x
    A θ̈y + D θ̇y + ΔK θy − H θ̇x − λ θx = M_y + H ωx − A ω̇y

- The H θ̇ terms are the gyroscopic coupling that makes the two axes one nutating body: undamped, free rotor
  modes at s = 0 and s = ±j·ω_n, ω_n = H/A (Titterton 4.7 with both transverse inertias equal to A).
- ΔK: residual (mistuning) direct spring, N·m/rad: flexure stiffness minus the dynamic negative spring of the
  gimbal (zero at the tuned speed; Titterton §4.2.6, [L1752]).
- D: damping of the rotor relative to the case, N·m·s/rad. Damping D_h acting in the spinning hinges, seen from the
  case, is a damping D_h plus an antisymmetric quadrature spring λ = D_h·N (N the spin rate): the hinge torque
  −D_h·(θ̇ − N ẑ × θ) expressed in case axes gives −D_h θ̇x − D_h N θy about X and −D_h θ̇y + D_h N θx about Y.
- Steady state with the rotor held at null: H ωy = M_x, −H ωx = M_y (Hu 3-94; Titterton 6.4 ω_x = −M_y/H,
  ω_y = M_x/H). So the rate about X is read from the torque about Y: channel X's torquer acts about Y, driven by
  the pickoff of axis X (Hu ch. 3 §6: the x-axis pickoff sits on x, its torquer on y), and likewise for Y.
- A rotor left at an offset drifts: with no torquer, −H θ̇x = −ΔK θy + λ θx, i.e. θ̇x = (ΔK/H) θy − (λ/H) θx,
  which is Hu 5-68, α̇ = K_q β − K_φ α, with α = θx, β = θy, the quadrature stiffness K_q = ΔK/H and the
  in-phase stiffness K_φ = λ/H (rate sense; in torque sense ΔK is the direct and λ the quadrature spring).

Loop, in rate-equivalent units (deg/h). Channel c ∈ {X, Y} commands u_c = S_nom·i_c (the indicated rate,
conventions §4, records' current_x_mA / current_y_mA). Its torquer makes the rotor precess at the rates
p = T·u, T = [[1 + E_SF_X, μ_XY], [μ_YX, 1 + E_SF_Y]] (scale-factor errors in ppm, μ the torquer cross-coupling
from misalignment, rad), i.e. applies M = H·(p_Y, −p_X). The commands are

    u_X = −k_X·L(s)·θx + g_n·W(s)·θy,   u_Y = −k_Y·L(s)·θy − g_n·W(s)·θx,   i.e.  u = −G(s)·θ,

with k_c = S_nom·K_amp_c·K_pickoff (deg/h per rad) and L(s) = (τ_lead s + 1)/(τ_lag s + 1) the cross-feed
(pickoff X → torquer about Y), and W(s) = s/(τ_nut s + 1) the direct-channel term (pickoff X → torquer about X):
a band-limited electronic damping −K_nut·W(s)·θ (g_n = K_nut/(H·deg/h)) that damps the nutation, which the
cross-feed alone destabilises. A drift torque that reads as d (deg/h, per channel) is M_d = −H·(d_Y, −d_X).

Closed loop, with P(s) = (A s² + D s + ΔK)·I + (H s + λ)·J, J = [[0, 1], [−1, 0]], H' = H·(rad/s per deg/h):

    u = G (P + H' J T G)⁻¹ · [ (A s·I + H J)·ω + H J·d ]·(rad/s per deg/h)

and at DC (the quasi-static balance; Hu 5-64..5-67 for one axis): S·u = ω + d, S = T + [[ℓ/k_X, −κ/k_Y],
[κ/k_X, ℓ/k_Y]], κ = ΔK/H', ℓ = λ/H' (deg/h per rad). The offsets θ = −u/k times the springs are the static
cross-coupling Hu warns of after 5-67.

Not modelled: the 2N-frequency gimbal terms and anisoinertia (second order in rates), ω_z, torquer nonlinearity
and asymmetry, pickoff misalignment.
Units: public inputs and outputs deg/h, s; state SI (rad, rad/s).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.dynamics.discretize import zoh
from gyrojax.dynamics.loops import array_pytree, lead_lag_centred

DPH = units.DEG_PER_H

__all__ = [
    "TDFParams",
    "default_tdf",
    "tdf_state_space",
    "tdf_closed_loop_tf",
    "tdf_static_matrix",
    "tdf_nutation_frequency",
    "simulate_tdf",
    "tdf_indicated_rates",
]


@array_pytree
class TDFParams:
    """Physical parameters of a DTG and its two capture loops (floats or arrays; vmap over a leading axis).

    Attributes:
        H: rotor angular momentum, N·m·s.
        A: rotor transverse inertia (with the gimbal's share), kg·m²; nutation ω_n = H/A (rad/s).
        D: rotor damping relative to the case, N·m·s/rad.
        dK: residual (mistuning) direct spring ΔK, N·m/rad.
        lam: quadrature spring λ, N·m/rad (λ = D_h·N for hinge damping D_h at spin rate N).
        K_pickoff: pickoff sensitivity, V/rad (both axes).
        K_amp_X, K_amp_Y: cross-feed DC gains of channels X and Y, mA/V.
        tau_lead, tau_lag: cross-feed lead-lag L(s) = (τ_lead s + 1)/(τ_lag s + 1), s.
        K_nut: direct-channel (nutation) damping gain, N·m·s/rad, through W(s) = s/(τ_nut s + 1).
        tau_nut: roll-off time constant of the direct-channel term, s.
        S_nom: nominal torquer scale factor, deg/h per mA (both channels).
        E_SF_X, E_SF_Y: torquer scale-factor errors of channels X and Y, ppm.
        mu_XY: precession about X per unit command of channel Y (torquer cross-coupling), rad.
        mu_YX: precession about Y per unit command of channel X, rad.
    """

    H: float
    A: float
    D: float
    dK: float
    lam: float
    K_pickoff: float
    K_amp_X: float
    K_amp_Y: float
    tau_lead: float
    tau_lag: float
    K_nut: float
    tau_nut: float
    S_nom: float
    E_SF_X: float
    E_SF_Y: float
    mu_XY: float
    mu_YX: float


_J = np.array([[0.0, 1.0], [-1.0, 0.0]])


def tdf_nutation_frequency(p: TDFParams):
    """Free-rotor nutation frequency ω_n = H/A, rad/s (Titterton 4.7 with equal transverse inertias)."""
    return p.H / p.A


def _torquer_matrix(p, xp=jnp):
    """T: precession rates (deg/h) about (X, Y) per unit command (u_X, u_Y) (deg/h)."""
    return xp.array([[1.0 + units.PPM * p.E_SF_X, p.mu_XY], [p.mu_YX, 1.0 + units.PPM * p.E_SF_Y]])


def tdf_static_matrix(p: TDFParams):
    """S (2×2, dimensionless) of the quasi-static balance S·u = ω + d (deg/h).

    S = T + [[ℓ/k_X, −κ/k_Y], [κ/k_X, ℓ/k_Y]], κ = ΔK/(H·DPH), ℓ = λ/(H·DPH), k_c = S_nom·K_amp_c·K_pickoff: the
    steady offsets θ_c = −u_c/k_c times the residual springs (Hu 5-67, 5-68).
    """
    hp = p.H * DPH
    kx = p.S_nom * p.K_amp_X * p.K_pickoff
    ky = p.S_nom * p.K_amp_Y * p.K_pickoff
    kap, ell = p.dK / hp, p.lam / hp
    return _torquer_matrix(p) + jnp.array([[ell / kx, -kap / ky], [kap / kx, ell / ky]])


def _open_loop_gain(crossover_hz, lead_ratio):
    """k·DPH (1/s) that puts the precession loop k·DPH·L(s)/s at unit gain at the crossover."""
    wc = 2 * math.pi * crossover_hz
    tl, tg = lead_lag_centred(wc, lead_ratio)
    return wc / abs((1j * wc * tl + 1) / (1j * wc * tg + 1)), tl, tg


def default_tdf(
    crossover_hz: float = 30.0,
    lead_ratio: float = 10.0,
    spin_hz: float = 200.0,
    nutation_ratio: float = 1.5,
    **overrides,
) -> TDFParams:
    """A plausible DTG in a stable capture loop (choices, not data from a datasheet).

    Rotor: H = 0.02 N·m·s at ``spin_hz`` (12 000 rpm: polar inertia C = H/N = 1.6e-5 kg·m²), transverse inertia
    A = C/``nutation_ratio`` so that the nutation ω_n = H/A = 1.5·N (300 Hz; a flat ring rotor has C/A between 1 and
    2); damping D = C/200 s (a 200 s rotor time constant, gas-filled case) all placed in the hinges, so λ = D·N;
    mistuning ΔK = 0.01·H (a 100 s tuning time constant H/ΔK).
    Loop: cross-feed lead-lag centred on ``crossover_hz`` (pole/zero ratio ``lead_ratio``) with the precession
    loop crossing unit gain there; direct-channel damping K_nut = 2·H·(cross-feed gain at nutation)/ω_n, rolled
    off at 4·ω_n, which gives all closed-loop modes a damping ratio above ~0.2. S_nom = 17.171 deg/h/mA (as the SDF).
    """
    h = 0.02
    n = 2 * math.pi * spin_hz
    c_polar = h / n
    a = c_polar / nutation_ratio
    d = c_polar / 200.0
    kdph, tl, tg = _open_loop_gain(crossover_hz, lead_ratio)
    s_nom, k_po = 17.171, 10.0
    k_amp = kdph / (DPH * s_nom * k_po)
    wn = h / a
    hf_gain = kdph * abs((1j * wn * tl + 1) / (1j * wn * tg + 1))
    base = dict(
        H=h,
        A=a,
        D=d,
        dK=0.01 * h,
        lam=d * n,
        K_pickoff=k_po,
        K_amp_X=k_amp,
        K_amp_Y=k_amp,
        tau_lead=tl,
        tau_lag=tg,
        K_nut=2.0 * h * hf_gain / wn,
        tau_nut=0.25 / wn,
        S_nom=s_nom,
        E_SF_X=0.0,
        E_SF_Y=0.0,
        mu_XY=0.0,
        mu_YX=0.0,
    )
    base.update(overrides)
    return TDFParams(**{k: float(v) for k, v in base.items()})


def _command_rows(p):
    """(Cu (2, 8), r) with u = Cu·x for the state x = [θx, θy, qx, qy, zX, zY, nX, nY] (see tdf_state_space)."""
    r = p.tau_lead / p.tau_lag
    kx = p.S_nom * p.K_amp_X * p.K_pickoff
    ky = p.S_nom * p.K_amp_Y * p.K_pickoff
    gn = p.K_nut / (p.H * DPH) / p.tau_nut  # W(s)θ = (θ − n)/τ_nut
    z = jnp.zeros_like(r)
    # u_X = −k_X (r θx + (1 − r) zX) + g_n (θy − nY)/τ_nut
    ux = jnp.stack([-kx * r, gn, z, z, -kx * (1 - r), z, z, -gn])
    # u_Y = −k_Y (r θy + (1 − r) zY) − g_n (θx − nX)/τ_nut
    uy = jnp.stack([-gn, -ky * r, z, z, z, -ky * (1 - r), gn, z])
    return jnp.stack([ux, uy])


def tdf_state_space(p: TDFParams):
    """Continuous closed-loop (A, B, C, D) of the two capture loops.

    State (8): θx, θy (rad, rotor relative to case); vx, vy (rad) = q/ω_n, the rotor's inertial tilt rate
    q = θ̇ + ω (rad/s) over the nutation frequency ω_n = H/A (this scaling keeps every entry of A within a few
    ω_n, so that expm is accurate for any step); zX, zY (rad, lead-lag lag states, τ_lag ż = θ − z);
    nX, nY (rad, direct-term states, τ_nut ṅ = θ − n).
    Inputs (4, deg/h): [ωx, ωy, d_X, d_Y], the case's inertial rate and the rate-equivalent drift of each channel.
    Outputs (2, deg/h): [u_X, u_Y] = S_nom·(i_X, i_Y).
    Using q as a state lets the A ω̇ term enter without differentiating the (held) rate input.
    """
    hp = p.H * DPH
    wn = p.H / p.A
    cu = _command_rows(p)
    t = _torquer_matrix(p)
    # torque = H'·J·T·u = H'·J·T·Cu·x, entering q̇ = torque/A, i.e. v̇ = torque/(A ω_n) = torque/H
    tq = hp * (jnp.asarray(_J) @ t @ cu) / p.H  # (2, 8)
    zero = jnp.zeros_like(p.H)
    one = jnp.ones_like(p.H)
    dh, kh, lh = p.D / p.A, p.dK / p.H, p.lam / p.H  # 1/s (D/A), and spring rates over H (1/s)
    rows = jnp.array(
        [
            [zero, zero, wn, zero, zero, zero, zero, zero],
            [zero, zero, zero, wn, zero, zero, zero, zero],
            # A q̇x = −H qy − D(qx − ωx) − ΔK θx − λ θy + M_x, divided by A·ω_n = H
            [-kh, -lh, -dh, -wn, zero, zero, zero, zero],
            # A q̇y = H qx − D(qy − ωy) − ΔK θy + λ θx + M_y
            [lh, -kh, wn, -dh, zero, zero, zero, zero],
            [one / p.tau_lag, zero, zero, zero, -one / p.tau_lag, zero, zero, zero],
            [zero, one / p.tau_lag, zero, zero, zero, -one / p.tau_lag, zero, zero],
            [one / p.tau_nut, zero, zero, zero, zero, zero, -one / p.tau_nut, zero],
            [zero, one / p.tau_nut, zero, zero, zero, zero, zero, -one / p.tau_nut],
        ]
    )
    a = rows.at[2:4].add(tq)
    # inputs [ωx, ωy, d_X, d_Y] in deg/h
    b = jnp.array(
        [
            [-DPH * one, zero, zero, zero],
            [zero, -DPH * one, zero, zero],
            [p.D / p.H * DPH, zero, zero, -DPH * one],  # M_dx = −H' d_Y
            [zero, p.D / p.H * DPH, DPH * one, zero],  # M_dy = +H' d_X
        ]
    )
    b = jnp.concatenate([b, jnp.zeros((4, 4))], axis=0)
    return a, b, cu, jnp.zeros((2, 4))


def tdf_closed_loop_tf(p: TDFParams, s, input: str = "rate"):
    """Closed-loop transfer matrix at complex s (numpy), shape s.shape + (2, 2): [u_X, u_Y] per [ωx, ωy]
    (``input="rate"``) or per [d_X, d_Y] (``input="drift"``), from the block diagram (module docstring):

        u = G (P + H' J T G)⁻¹ R,   R = (A s·I + H J)·DPH for rates, H J·DPH for drifts.
    """
    s = np.asarray(s, dtype=complex)[..., None, None]
    eye = np.eye(2)
    hp = p.H * DPH
    kx = p.S_nom * p.K_amp_X * p.K_pickoff
    ky = p.S_nom * p.K_amp_Y * p.K_pickoff
    ll = (p.tau_lead * s + 1) / (p.tau_lag * s + 1)
    w = p.K_nut / hp * s / (p.tau_nut * s + 1)
    g = np.concatenate([np.concatenate([kx * ll, -w], axis=-1), np.concatenate([w, ky * ll], axis=-1)], axis=-2)
    plant = (p.A * s * s + p.D * s + p.dK) * eye + (p.H * s + p.lam) * _J
    t = np.asarray(_torquer_matrix(p, np))
    if input == "rate":
        r = (p.A * s * eye + p.H * _J) * DPH
    elif input == "drift":
        r = p.H * _J * DPH + 0 * s
    else:
        raise ValueError(f"input must be 'rate' or 'drift', not {input!r}")
    return g @ np.linalg.solve(plant + hp * (_J @ t) @ g, r)


def simulate_tdf(p: TDFParams, omega_deg_per_h, dt: float, drift_deg_per_h=None, x0=None):
    """Indicated rates u_k = S_nom·(i_X, i_Y)(t_k) (deg/h), shape (n, 2), of both capture loops at the rate 1/dt.

    ``omega_deg_per_h`` (n, 2): case inertial rate (ωx, ωy), deg/h; ``drift_deg_per_h`` (n, 2): rate-equivalent
    drift of each channel, deg/h (zero if None). Inputs are held over [t_k, t_k + dt) (ZOH, exact for the linear
    loop at any dt); u_k is read at t_k before input k acts (dlsim convention). Starts at the equilibrium of the
    first input unless ``x0`` (8,) is given. jit/vmap/grad-safe.
    """
    a, b, c, _ = tdf_state_space(p)
    ad, bd, c, _ = zoh(a, b, c, jnp.zeros((2, 4)), dt)
    w = jnp.asarray(omega_deg_per_h, dtype=jnp.float64)
    d = jnp.zeros_like(w) if drift_deg_per_h is None else jnp.asarray(drift_deg_per_h, dtype=jnp.float64)
    inp = jnp.concatenate([w, d], axis=1)
    if x0 is None:
        x0 = jnp.linalg.solve(a, -b @ inp[0])

    def step(x, uk):
        return ad @ x + bd @ uk, c @ x

    _, u = jax.lax.scan(step, x0, inp)
    return u


def tdf_indicated_rates(params: TDFParams, omega_XY_deg_per_h, dt: float, drift_deg_per_h=None):
    """Both channels' indicated rates (deg/h), (n, 2), at the *end* of each sample's hold interval.

    The TDF counterpart of ``loops.loop_indicated_rate``: ``omega_XY_deg_per_h`` (n, 2) is the case rate about
    X and Y per sample (deg/h), ``drift_deg_per_h`` (n, 2) the channels' drifts (deg/h), each held for ``dt`` s.
    A constant input reads S⁻¹(ω + d) (``tdf_static_matrix``) with no sample delay; a varying one lags by the loops.
    """
    w = jnp.asarray(omega_XY_deg_per_h, dtype=jnp.float64)
    d = jnp.zeros_like(w) if drift_deg_per_h is None else jnp.asarray(drift_deg_per_h, dtype=jnp.float64)
    return simulate_tdf(params, jnp.concatenate([w, w[-1:]]), dt, jnp.concatenate([d, d[-1:]]))[1:]
