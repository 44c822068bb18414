"""Closed loops of a drift test as jitted JAX scans: torque rebalance (analog and pulse) and table servo.

Every loop is a continuous linear plant discretised exactly with a zero-order hold at the loop rate
(``discretize.zoh``) and stepped with ``lax.scan``; parameters are frozen pytrees of physical values, so one
call can be ``vmap``-ed over gyros and differentiated with respect to every parameter.

Float of the SDF floated gyro (Hu 2-50, with the torquer opposing the input; θ the float angle about OA
relative to the case, rad):

    I·θ̈ + C·θ̇ = H·(ω_I + ω_d) − M_tq                                              (Hu 2-50)

so θ = (H/C)/[s(τs+1)]·(ω_I + ω_d − M_tq/H), τ = I/C (Hu 2-52). With gimbal/bearing compliance about IA and
OA the rate input sees the third-order characteristic Δ(s) of Hu 2-57/2-58,

    θ/ω_I = (H/C) / [s·Δ(s)],  Δ(s) = H²I/(K_x K_y C)·s³ + H²/(K_x K_y)·s² + (I/C + H²/(K_x C))·s + 1,

which we realise by passing the rate through F(s) = (τs+1)/Δ(s) before the float (unity at DC; Δ → τs+1 as
K_x, K_y → ∞, the 2-60 limit). The torquer path keeps 2-52.

Units: the public inputs and outputs are deg/h (rates), mA (currents), N·m (table torques), s; state is SI.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.dynamics.discretize import zoh, zoh_ab

DPH = units.DEG_PER_H

__all__ = [
    "RebalanceParams",
    "PulseParams",
    "ServoParams",
    "default_rebalance",
    "default_pulse",
    "default_servo",
    "rebalance_state_space",
    "rebalance_closed_loop_tf",
    "torquer_rate",
    "simulate_rebalance",
    "loop_indicated_rate",
    "pulse_quantum",
    "simulate_pulse",
    "servo_state_space",
    "servo_stiffness",
    "simulate_servo",
    "disturbance_torque",
    "inductosyn_readout",
    "lifted_dlsim",
]


def array_pytree(cls):
    """Register a frozen dataclass whose fields are all array leaves."""
    cls = dataclasses.dataclass(frozen=True)(cls)
    names = [f.name for f in dataclasses.fields(cls)]
    jax.tree_util.register_pytree_node(
        cls, lambda p: ([getattr(p, n) for n in names], None), lambda _, leaves: cls(*leaves)
    )
    return cls


# ---------------------------------------------------------------------------------------------------------------
# Analog torque-rebalance (capture) loop, Hu 2-50..2-63 and 5-62..5-67
# ---------------------------------------------------------------------------------------------------------------


@array_pytree
class RebalanceParams:
    """Physical parameters of an SDF floated gyro in an analog rebalance loop (all floats or arrays).

    Attributes:
        H: rotor angular momentum, N·m·s (kg·m²/s).
        I_float: float inertia about OA, kg·m² (Hu's I_y / J_y).
        C_damp: float damping about OA, N·m·s/rad (Hu's C_(CF)y); τ = I/C.
        K_pickoff: pickoff sensitivity, V/rad (Hu's K_sg, 2-53).
        K_amp: compensator DC gain, mA/V.
        tau_lead: compensator zero time constant, s;  G_c(s) = K_amp·(τ_lead s + 1)/(τ_lag s + 1).
        tau_lag: compensator pole time constant, s.
        S_nom: nominal torquer scale factor, deg/h per mA (ω_ind = S_nom·i, conventions §4).
        E_SF: scale-factor error, ppm (effect ``sf_error``).
        E_A: scale-factor asymmetry, ppm (effect ``sf_asymmetry``).
        E_2: quadratic scale-factor nonlinearity, ppm per deg/s (effect ``sf_quadratic``).
        K_fw_x: rotor/gimbal stiffness about IA, N·m/rad (Hu 2-58); used only with ``third_order=True``.
        K_fw_y: rotor/gimbal stiffness about OA, N·m/rad (Hu 2-58); used only with ``third_order=True``.
    """

    H: float
    I_float: float
    C_damp: float
    K_pickoff: float
    K_amp: float
    tau_lead: float
    tau_lag: float
    S_nom: float
    E_SF: float
    E_A: float
    E_2: float
    K_fw_x: float
    K_fw_y: float


def _float_tf(p, s):
    """Float angle per deg/h of rate-equivalent torque, (H·DPH/I)/[s(s + C/I)] (Hu 2-52), at complex s."""
    return (p.H * DPH / p.I_float) / (s * (s + p.C_damp / p.I_float))


def lead_lag_centred(wc: float, lead_ratio: float) -> tuple[float, float]:
    """Lead-lag time constants whose zero and pole sit a factor √ratio either side of ω_c (maximum phase at ω_c)."""
    r = math.sqrt(lead_ratio)
    return r / wc, 1 / (r * wc)


FLOATED_GYRO = dict(H=1e-2, I_float=1e-5, C_damp=1e-2, K_pickoff=10.0, K_amp=1.0, tau_lead=0.0, tau_lag=0.0)
"""The floated gyro of the default loops: H (N·m·s), float inertia (kg·m²), damping C (N·m·s), pickoff gain (V/rad),
amplifier gain and lead-lag time constants (s) before tuning."""


def _tuned(params_type, base: dict, wc: float, lead_ratio: float, open_loop_gain, overrides: dict):
    """``params_type`` with a lead-lag centred at ω_c (rad/s) and the amplifier gain that makes the open-loop gain
    ``open_loop_gain(p)`` (dimensionless) one at ω_c; then ``overrides`` applied."""
    base = dict(base)
    base["tau_lead"], base["tau_lag"] = lead_lag_centred(wc, lead_ratio)
    base["K_amp"] = 1.0 / open_loop_gain(params_type(**base))
    base.update(overrides)
    return params_type(**{k: float(v) for k, v in base.items()})


def default_rebalance(crossover_hz: float = 30.0, lead_ratio: float = 10.0, **overrides) -> RebalanceParams:
    """A plausible floated gyro (H = 0.01 N·m·s, H/C = 1, τ = 1 ms, Hu's 17.171 deg/h/mA) in a loop whose
    open-loop gain crosses 1 at ``crossover_hz`` with a lead-lag centred there (pole/zero ratio ``lead_ratio``)."""
    base = dict(
        **FLOATED_GYRO,
        S_nom=17.171,
        E_SF=0.0,
        E_A=0.0,
        E_2=0.0,
        K_fw_x=20.0,
        K_fw_y=50.0,
    )
    wc = 2 * math.pi * crossover_hz

    def gain(p):
        lead_lag = (1j * wc * p.tau_lead + 1) / (1j * wc * p.tau_lag + 1)
        return abs(_float_tf(p, 1j * wc)) * p.K_pickoff * p.S_nom * abs(lead_lag)

    return _tuned(RebalanceParams, base, wc, lead_ratio, gain, overrides)


def torquer_rate(p: RebalanceParams, u):
    """Rate-equivalent torque (deg/h) that the torquer applies when the indicated rate is u = S_nom·i (deg/h).

    Exact inverse of the balance u = ω(1 + E_SF + E_A·sgn ω) + E_2·ω·(ω/3600) (conventions §6 ``sf_error``,
    ``sf_asymmetry``, ``sf_quadratic``; ppm), so that a quasi-static loop reads exactly those effects:
    ω = 2u / (b + √(b² + 4 q u)), b = 1 + E_SF + E_A·sgn u, q = E_2·1e-6/3600 per deg/h.
    """
    b = 1.0 + units.PPM * (p.E_SF + p.E_A * jnp.sign(u))
    q = units.PPM * p.E_2 / 3600.0
    return 2.0 * u / (b + jnp.sqrt(jnp.maximum(b * b + 4.0 * q * u, 1e-300)))


def _compliance_ss(p):
    """F(s) = (τs+1)/Δ(s) in scaled controllable canonical form (Hu 2-57/2-58): (A, B, C)."""
    h2 = p.H * p.H
    a3 = h2 * p.I_float / (p.K_fw_x * p.K_fw_y * p.C_damp)
    a2 = h2 / (p.K_fw_x * p.K_fw_y)
    a1 = p.I_float / p.C_damp + h2 / (p.K_fw_x * p.C_damp)
    tau = p.I_float / p.C_damp
    # states (z, t0·ż, t0²·z̈) with t0 = a1, so that no entry is of order 1/a3 (keeps expm well scaled)
    t0 = a1
    k = t0 * t0 / a3
    a = jnp.array([[0.0, 1.0 / t0, 0.0], [0.0, 0.0, 1.0 / t0], [-k, -k * a1 / t0, -k * a2 / (t0 * t0)]])
    b = jnp.array([[0.0], [0.0], [k]])
    c = jnp.array([[1.0, tau / t0, 0.0]])
    return a, b, c


def rebalance_state_space(p: RebalanceParams, third_order: bool = False):
    """Continuous closed-loop (A, B, C, D) of the analog rebalance loop with the nominal (linear) torquer.

    State: [θ (rad), θ̇ (rad/s), x_c (V, compensator lag state)] (+ 3 compliance states when ``third_order``).
    Inputs (deg/h): [ω_in = ω_I + ω_d, the rate-equivalent of all float torques but the torquer;
    δ = torquer_rate(u) − u, the torquer's departure from nominal]. Output: u = S_nom·i (deg/h).
    """
    k = p.H * DPH / p.I_float  # rad/s² per deg/h of torque
    r = p.tau_lead / p.tau_lag
    g = p.S_nom * p.K_amp * p.K_pickoff  # u = g·[r·θ + (1 − r)·x_c/K_pickoff]
    # u = cu · x
    cu = jnp.array([g * r, 0.0, p.S_nom * p.K_amp * (1.0 - r)])
    a_f = jnp.array(
        [[0.0, 1.0, 0.0], [0.0, -p.C_damp / p.I_float, 0.0], [p.K_pickoff / p.tau_lag, 0.0, -1.0 / p.tau_lag]]
    )
    a = a_f.at[1].add(-k * cu)
    b = jnp.array([[0.0, 0.0], [k, -k], [0.0, 0.0]])
    c = cu[None, :]
    d = jnp.zeros((1, 2))
    if not third_order:
        return a, b, c, d
    ac, bc, cc = _compliance_ss(p)
    # the float sees F(s)·ω_in instead of ω_in
    top = jnp.concatenate([a, jnp.zeros((3, 3)).at[1].set(k * cc[0])], axis=1)
    bot = jnp.concatenate([jnp.zeros((3, 3)), ac], axis=1)
    a6 = jnp.concatenate([top, bot], axis=0)
    b6 = jnp.concatenate([b.at[1, 0].set(0.0), jnp.concatenate([bc, jnp.zeros((3, 1))], axis=1)], axis=0)
    c6 = jnp.concatenate([c, jnp.zeros((1, 3))], axis=1)
    return a6, b6, c6, d


def rebalance_closed_loop_tf(p: RebalanceParams, s, third_order: bool = False):
    """u/ω_in at complex s (numpy), from the block diagram: L = G_float·K_sg·G_c·S_nom, T = F·L/(1 + L)."""
    s = np.asarray(s, dtype=complex)
    ell = _float_tf(p, s) * p.K_pickoff * p.K_amp * (p.tau_lead * s + 1) / (p.tau_lag * s + 1) * p.S_nom
    t = ell / (1 + ell)
    if third_order:
        h2 = p.H**2
        delta = (
            h2 * p.I_float / (p.K_fw_x * p.K_fw_y * p.C_damp) * s**3
            + h2 / (p.K_fw_x * p.K_fw_y) * s**2
            + (p.I_float / p.C_damp + h2 / (p.K_fw_x * p.C_damp)) * s
            + 1
        )
        t = t * (p.I_float / p.C_damp * s + 1) / delta
    return t


def simulate_rebalance(p: RebalanceParams, omega_in_deg_per_h, dt: float, third_order: bool = False, x0=None):
    """Indicated rate u_k = S_nom·i(t_k) (deg/h) of the analog rebalance loop at the loop rate 1/dt.

    ``omega_in_deg_per_h`` (n,): ω_I + drift (deg/h), held over [t_k, t_k + dt) (zero-order hold); u_k is read at
    t_k, before ω_k acts (the ``dlsim`` convention y_k = C x_k). The linear loop is exact for any dt (ZOH of the
    continuous closed loop). The torquer's ppm-level departure δ = torquer_rate(u) − u enters as an input held
    over the step, set implicitly to its end-of-step value (two fixed-point sweeps, contraction ~1e-4), so the
    steady state is exact whatever the step. Starts from the equilibrium at ω_in[0] unless ``x0`` is given.
    jit/vmap/grad-safe (``third_order`` static).
    """
    a, b, c, d = rebalance_state_space(p, third_order)
    ad, bd, c, _ = zoh(a, b, c, d, dt)
    w = jnp.asarray(omega_in_deg_per_h, dtype=jnp.float64)
    if x0 is None:
        # equilibrium with the nominal torquer: 0 = A x + B [w0, 0]
        x0 = jnp.linalg.solve(a, -b[:, 0] * w[0])
    cu = c[0]
    u0 = cu @ x0

    def step(carry, wk):
        x, delta = carry
        xf = ad @ x + bd[:, 0] * wk
        for _ in range(2):
            u_next = cu @ (xf + bd[:, 1] * delta)
            delta = torquer_rate(p, u_next) - u_next
        return (xf + bd[:, 1] * delta, delta), cu @ x

    _, u = jax.lax.scan(step, (x0, torquer_rate(p, u0) - u0), w)
    return u


def loop_indicated_rate(params: RebalanceParams, omega_I_deg_per_h, dt: float, third_order: bool = False):
    """Glue for ``simulate(dynamics="loop")``: indicated rate (deg/h) of the analog rebalance loop.

    ``omega_I_deg_per_h`` (n,) is the quasi-static rate the float senses (deg/h): the input-axis rate plus every
    drift torque expressed as a rate, one value per sample, each held for ``dt`` seconds (ZOH; dt may be the
    record's sample interval, the loop is discretised exactly). Returns (n,): u_k = S_nom·i at the *end* of
    sample k's hold interval, so a constant input reads its balance value with no sample delay. The output
    lags the input by the loop's dynamics and carries the torquer's E_SF, E_A, E_2 (set those to zero in
    ``params`` if the caller's effect model already applies them).
    """
    w = jnp.asarray(omega_I_deg_per_h, dtype=jnp.float64)
    return simulate_rebalance(params, jnp.concatenate([w, w[-1:]]), dt, third_order)[1:]


# ---------------------------------------------------------------------------------------------------------------
# Pulse (binary PWM) rebalance loop, Hu ch. 5 §4 (5-69..5-76)
# ---------------------------------------------------------------------------------------------------------------


@array_pytree
class PulseParams:
    """Binary pulse-width-modulated rebalance loop (Hu 5-69 to 5-76) around the float of ``RebalanceParams``.

    Attributes:
        gyro: RebalanceParams (float, pickoff, compensator; S_nom sets the torquer K = H·S_nom in SI).
        I_pulse: torquer current amplitude I, mA.
        dI_plus: amplitude error of the positive current pulse ΔI⁺, mA (actual +(I + ΔI⁺)).
        dI_minus: amplitude error of the negative current pulse ΔI⁻, mA (actual −(I + ΔI⁻)).
        dT: timing error ΔT, s: the positive current flows ΔT shorter than the counted n₊/f_q (Hu 5-74).
    The PWM period T_s (= the loop dt) and the data-pulse count per period M = f_q·T_s are static arguments.
    """

    gyro: RebalanceParams
    I_pulse: float
    dI_plus: float
    dI_minus: float
    dT: float


def default_pulse(crossover_hz: float = 30.0, I_pulse: float = 60.0, **overrides) -> PulseParams:
    """A binary PWM loop on ``default_rebalance`` with a 60 mA torquer current (≈ 1030 deg/h full scale)."""
    g = default_rebalance(crossover_hz)
    d = dict(gyro=g, I_pulse=I_pulse, dI_plus=0.0, dI_minus=0.0, dT=0.0)
    d.update(overrides)
    return PulseParams(**d)


def pulse_quantum(H, K_torquer, I_pulse, f_q):
    """Pulse weight N = I·K/(H·f_q) (Hu 5-70), rad per data pulse; K in N·m/mA, I in mA, H in N·m·s, f_q in Hz.

    The rate resolution over an accumulation time T is ω_d1 = N/T (Hu 5-73).
    """
    return I_pulse * K_torquer / (H * f_q)


def simulate_pulse(pp: PulseParams, omega_in_deg_per_h, t_s: float, m_per_period: int):
    """Binary PWM rebalance loop; returns the net data-pulse count n₊ − n₋ of each PWM period (int array).

    Each period of T_s = ``t_s`` s is split into M = ``m_per_period`` data pulses (f_q = M/T_s). At the start of a
    period the compensator output i_c (mA) sets the duty: n₊ = clip(round(M·(1 + i_c/I)/2), 0, M), n₋ = M − n₊.
    The torquer then carries +(I + ΔI⁺) for n₊/f_q − ΔT and −(I + ΔI⁻) for the rest; the float and the
    (analog) compensator are propagated exactly through both parts (ZOH with sub-step switching, tabulated
    over n₊). The indicated rate of a span T is N·Σ(n₊ − n₋)/T (Hu 5-71/5-73), N = ``pulse_quantum``.
    ``omega_in_deg_per_h``: (n,) ω_I + drift (deg/h) held over each period. jit/vmap-safe with
    ``t_s``, ``m_per_period`` static; the duty rounding makes the counts piecewise constant in the parameters,
    so gradients through this loop are zero (differentiate the analog loop instead).
    """
    p = pp.gyro
    f_q = m_per_period / t_s
    k = p.H * DPH / p.I_float
    r = p.tau_lead / p.tau_lag
    a = jnp.array(
        [[0.0, 1.0, 0.0], [0.0, -p.C_damp / p.I_float, 0.0], [p.K_pickoff / p.tau_lag, 0.0, -1.0 / p.tau_lag]]
    )
    # inputs: [ω_in (deg/h), torquer current (mA) → deg/h via S_nom]
    b = jnp.array([[0.0, 0.0], [k, -k * p.S_nom], [0.0, 0.0]])
    ci = jnp.array([p.K_amp * p.K_pickoff * r, 0.0, p.K_amp * (1.0 - r)])  # i_c = ci · x (mA)
    ad, bd = zoh_ab(a, b, t_s)
    # G(t1) = e^{A(T−t1)} Γ(t1): state change from unit current over [0, t1]
    t1 = jnp.clip(jnp.arange(m_per_period + 1) / f_q - pp.dT, 0.0, t_s)

    def g_of(t):
        e1, g1 = zoh_ab(a, b[:, 1:], t)
        e2, _ = zoh_ab(a, b[:, 1:], t_s - t)
        return (e2 @ g1)[:, 0]

    table = jax.vmap(g_of)(t1)  # (M+1, 3)
    gam = bd[:, 1]
    ip = pp.I_pulse + pp.dI_plus
    im = pp.I_pulse + pp.dI_minus

    def step(x, wk):
        ic = ci @ x
        n_plus = jnp.clip(jnp.round(m_per_period * 0.5 * (1.0 + ic / pp.I_pulse)), 0, m_per_period).astype(jnp.int32)
        x = ad @ x + bd[:, 0] * wk + (ip + im) * table[n_plus] - im * gam
        return x, 2 * n_plus - m_per_period

    w = jnp.asarray(omega_in_deg_per_h, dtype=jnp.float64)
    _, counts = jax.lax.scan(step, jnp.zeros(3), w)
    return counts


# ---------------------------------------------------------------------------------------------------------------
# Table servo loop, Hu 3-54/3-55 and 5-7..5-21, disturbances 5-36/5-37, Inductosyn readout 5-51
# ---------------------------------------------------------------------------------------------------------------


@array_pytree
class ServoParams:
    """Single-axis table servo slaved to the pickoff of an untorqued (or command-torqued) SDF gyro, IA ∥ axis.

    Attributes:
        H, I_float, C_damp, K_pickoff: the gyro (units as in ``RebalanceParams``).
        K_amp: servo amplifier DC gain, V/V (Hu's K_1).
        tau_lead, tau_lag: lead-lag compensator G_1(s) = (τ_lead s + 1)/(τ_lag s + 1), s.
        J_table: table inertia about the servo axis, kg·m².
        K_motor: torque-motor constant, N·m/V (G_M).
        K_emf: back-EMF constant, V/(rad/s) (Hu's K_e, 5-8).
        K_tach: tachometer feedback, V/(rad/s) (0 after acquisition, Hu ch. 5 §4).
        S_nom: gyro torquer scale factor, deg/h/mA (for a commanded current).
        G_m: unbalance moment G·m of the table, N·m (weight × c.g. offset; Hu 5-36).
        phi_axis: angle of the servo axis to the horizontal plane, rad (Hu's φ in 5-36).
    """

    H: float
    I_float: float
    C_damp: float
    K_pickoff: float
    K_amp: float
    tau_lead: float
    tau_lag: float
    J_table: float
    K_motor: float
    K_emf: float
    K_tach: float
    S_nom: float
    G_m: float
    phi_axis: float


def _servo_open_loop(p, s):
    gyro = (p.H / p.C_damp) / (p.I_float / p.C_damp * s + 1)  # float angle per table angle (Hu 2-59)
    comp = p.K_pickoff * p.K_amp * (p.tau_lead * s + 1) / (p.tau_lag * s + 1)
    table = p.K_motor / (s * (p.J_table * s + p.K_motor * (p.K_emf + p.K_tach)))
    return gyro * comp * table


def default_servo(crossover_hz: float = 40.0, lead_ratio: float = 10.0, **overrides) -> ServoParams:
    """The gyro of ``default_rebalance`` on a 5 kg·m² air-bearing table, loop crossover at ``crossover_hz``."""
    base = dict(
        **FLOATED_GYRO,
        J_table=5.0,
        K_motor=1.0,
        K_emf=0.1,
        K_tach=0.0,
        S_nom=17.171,
        G_m=0.0,
        phi_axis=0.0,
    )
    wc = 2 * math.pi * crossover_hz
    return _tuned(ServoParams, base, wc, lead_ratio, lambda p: abs(_servo_open_loop(p, 1j * wc)), overrides)


def servo_stiffness(p: ServoParams):
    """Static servo stiffness K_T = M/ε (Hu 5-18), N·m/rad: the DC loop gain from table angle to motor torque,
    K_T = (H/C)·K_sg·K_1·G_1(0)·K_motor (5-15 at s → 0 with G(0) = 1)."""
    return p.H / p.C_damp * p.K_pickoff * p.K_amp * p.K_motor


def servo_state_space(p: ServoParams):
    """Continuous (A, B, C, D) of the table servo (Hu 5-8 with a physical float, 2-50).

    State: [θ_g float angle (rad), θ̇_g (rad/s), x_c compensator lag state (V), ω_T table rate relative to the
    base (rad/s), θ_T table angle relative to the base (rad)].
    Inputs: [ω_IB base inertial rate along the axis (deg/h; Earth rate component + base motion),
             u_g gyro torque-equivalent rate (deg/h): drift − S_nom·i_cmd,
             M disturbance torque on the table (N·m)].
    Outputs: [θ_T (rad), ω_T (rad/s), θ_g (rad)].
    Float: I θ̈_g + C θ̇_g = H(ω_IB + ω_T + u_g); motor: J ω̇_T = K_m(v − K_e ω_T) + M,
    v = −K_1·G_1(s)·K_sg·θ_g − K_tach·ω_T.
    """
    r = p.tau_lead / p.tau_lag
    hi = p.H / p.I_float
    ci = p.C_damp / p.I_float
    # motor voltage v = cv · x
    cv = jnp.array([-p.K_amp * p.K_pickoff * r, 0.0, -p.K_amp * (1.0 - r), -p.K_tach, 0.0])
    a = jnp.array(
        [
            [0.0, 1.0, 0.0, 0.0, 0.0],
            [0.0, -ci, 0.0, hi, 0.0],
            [p.K_pickoff / p.tau_lag, 0.0, -1.0 / p.tau_lag, 0.0, 0.0],
            [0.0, 0.0, 0.0, -p.K_motor * p.K_emf / p.J_table, 0.0],
            [0.0, 0.0, 0.0, 1.0, 0.0],
        ]
    )
    a = a.at[3].add(p.K_motor / p.J_table * cv)
    b = jnp.array(
        [[0.0, 0.0, 0.0], [hi * DPH, hi * DPH, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0 / p.J_table], [0.0, 0.0, 0.0]]
    )
    c = jnp.array([[0.0, 0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0, 0.0], [1.0, 0.0, 0.0, 0.0, 0.0]])
    d = jnp.zeros((3, 3))
    return a, b, c, d


def disturbance_torque(p: ServoParams, theta, m_dc=0.0, noise=0.0):
    """Table disturbance torque M = M_DC + G·m·cos φ·sin θ + N_e (Hu 5-36, 5-37), N·m; θ the table angle, rad."""
    return m_dc + p.G_m * jnp.cos(p.phi_axis) * jnp.sin(theta) + noise


def simulate_servo(p: ServoParams, omega_ib_deg_per_h, u_gyro_deg_per_h, m_ext, dt: float, x0=None):
    """Table servo at the loop rate 1/dt: returns (θ_T (rad), ω_T (rad/s), θ_g (rad)) at each step.

    Inputs (n,), held over each step: base rate along the axis (deg/h), gyro torque-equivalent rate
    drift − S_nom·i (deg/h), external disturbance torque M_DC + N_e (N·m). The unbalance torque
    G·m·cos φ·sin θ_T (5-36) is evaluated from the current table angle inside the scan.
    """
    a, b, c, d = servo_state_space(p)
    ad, bd, c, _ = zoh(a, b, c, d, dt)
    w = jnp.stack([jnp.asarray(omega_ib_deg_per_h), jnp.asarray(u_gyro_deg_per_h), jnp.asarray(m_ext)], axis=1)
    x0 = jnp.zeros(5) if x0 is None else x0

    def step(x, wk):
        mk = wk[2] + disturbance_torque(p, x[4])
        y = c @ x
        return ad @ x + bd[:, :2] @ wk[:2] + bd[:, 2] * mk, y

    _, y = jax.lax.scan(step, x0, w)
    return y[:, 0], y[:, 1], y[:, 2]


def inductosyn_readout(theta, harmonics=(0.0, 0.0, 0.0, 0.0), pole_pairs=360, electrical=(0.0, 0.0, 0.0), q=0.0):
    """Angle read by an Inductosyn (rad): θ + low-order zero error + within-pitch electrical error, quantised.

    harmonics: (c1, s1, c2, s2) rad, the 1×/2× per-revolution zero error (conventions §6 ``encoder_harmonic``);
    electrical: (Δα_0, Δe, Δe_3 + Δe_5) rad in Δα_D = ½Δα_0(1 − cos 2pα) + ½Δe sin 2pα + (Δe_3+Δe_5) sin 4pα
    (Hu 5-51), p = ``pole_pairs``; q: quantum (rad; 0.36″ or 0.18″ in Hu), 0 for none (rounding to nearest).
    """
    c1, s1, c2, s2 = harmonics
    da0, de, de35 = electrical
    x = theta + c1 * jnp.cos(theta) + s1 * jnp.sin(theta) + c2 * jnp.cos(2 * theta) + s2 * jnp.sin(2 * theta)
    pa = pole_pairs * theta
    x = x + 0.5 * da0 * (1 - jnp.cos(2 * pa)) + 0.5 * de * jnp.sin(2 * pa) + de35 * jnp.sin(4 * pa)
    if q:
        x = q * jnp.round(x / q)
    return x


# ---------------------------------------------------------------------------------------------------------------
# Lifted (block) simulation of a discrete LTI system: the same recursion, L steps per scan iteration
# ---------------------------------------------------------------------------------------------------------------


def lifted_dlsim(ad, bd, c, d, u, x0, block: int = 64):
    """Outputs y_k = C x_k + D u_k of x_{k+1} = A_d x_k + B_d u_k, computed ``block`` steps at a time.

    Over a block of L steps, x_{b+1} = A^L x_b + Σ_j A^{L−1−j} B u_{b,j} and y_{b,j} = C A^j x_b + Σ_{i<j}
    C A^{j−1−i} B u_{b,i} + D u_{b,j}: the forced parts of all blocks are two batched matrix products, and only
    the L-fold smaller recursion x_{b+1} = A^L x_b + f_b is a sequential ``lax.scan``. Same result as a step
    scan up to rounding. u: (n, m) with n a multiple of ``block``; returns (y (n, p), x_final).
    """
    n_steps, m = u.shape
    nb = n_steps // block
    nx = ad.shape[0]
    pw = jnp.stack([jnp.linalg.matrix_power(ad, j) for j in range(block + 1)])  # A^0..A^L
    obs = jnp.einsum("pn,jnk->jpk", c, pw[:block])  # C A^j, (L, p, n)
    fwd = jnp.einsum("jnk,km->jnm", pw[block - 1 :: -1][:block], bd)  # A^{L-1-j} B, (L, n, m)
    # Toeplitz of Markov parameters: T[j, i] = C A^{j-1-i} B for j > i, D for j == i
    cab = jnp.einsum("pn,jnk,km->jpm", c, pw[:block], bd)  # C A^q B, q = 0..L-1
    jj, ii = np.meshgrid(np.arange(block), np.arange(block), indexing="ij")
    lag = jj - 1 - ii
    toe = jnp.where((lag >= 0)[:, :, None, None], cab[np.clip(lag, 0, block - 1)], 0.0)  # (L, L, p, m)
    toe = toe + jnp.where((jj == ii)[:, :, None, None], d[None, None], 0.0)
    ub = u.reshape(nb, block, m)
    f = jnp.einsum("jnm,bjm->bn", fwd, ub)
    al = pw[block]

    def step(x, fb):
        return al @ x + fb, x

    xf, xs = jax.lax.scan(step, x0, f)
    y = jnp.einsum("jpn,bn->bjp", obs, xs) + jnp.einsum("jipm,bim->bjp", toe, ub)
    del nx
    return y.reshape(n_steps, -1), xf
