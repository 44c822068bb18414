"""Loops: exact ZOH, analog rebalance, pulse rebalance, table servo (Hu 2-50..2-63, 5-8..5-21, 5-36/37, 5-51,
5-62..5-76). References: scipy.signal, closed forms derived from the block diagrams, the book's formulas.

Misprints met in the seed (002) while reading these sections:
- 2-50 writes the torquer torque M_zg; 2-51 and the symbol list call it M_tg.
- after 2-56, "H 对 C_(CF)x 之比" (the angle gain): the damping is about OA, C_(CF)y.
- 2-63 (float response to case motion about OA) is garbled: the stiffnesses K_(FW)x K_(FW)y C stand in a
  numerator over Δ(s); only its limits 2-64/2-65 are usable. "传递函数 (2-64) 的幅值比" should cite 2-65.
- the example after 5-73 says T > 0.01 s; N/ω_d1 gives 0.01 h (test_pulse_resolution_example_misprint_5_73).
- 5-76 gives ΔK = +(ΔI⁺ + ΔI⁻)/2; its sign depends on Fig. 5-44 (absent), only the magnitude is checked.
"""

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.signal as sig

from gyrojax import units
from gyrojax.dynamics import loops
from gyrojax.dynamics.discretize import zoh

DT = 1e-3


def _rand_system(seed, n=4, m=2, p=3):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, n)) - 2.0 * np.eye(n)
    return a, rng.normal(size=(n, m)), rng.normal(size=(p, n)), rng.normal(size=(p, m))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_zoh_matches_scipy_cont2discrete(seed):
    a, b, c, d = _rand_system(seed)
    for dt in (1e-3, 0.1, 1.7):
        ad, bd, cd, dd, _ = sig.cont2discrete((a, b, c, d), dt, method="zoh")
        jad, jbd, jc, jd = zoh(a, b, c, d, dt)
        np.testing.assert_allclose(np.asarray(jad), ad, rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.asarray(jbd), bd, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(np.asarray(jc), c)
        np.testing.assert_array_equal(np.asarray(jd), d)


def test_zoh_of_the_loops_matches_scipy():
    # the loop matrices are stiff and badly scaled (entries up to 1e8): compare relative to each block's size
    for a, b, c, d in (
        loops.rebalance_state_space(loops.default_rebalance()),
        loops.rebalance_state_space(loops.default_rebalance(), third_order=True),
        loops.servo_state_space(loops.default_servo()),
    ):
        a, b, c, d = map(np.asarray, (a, b, c, d))
        ad, bd, *_ = sig.cont2discrete((a, b, c, d), DT, method="zoh")
        jad, jbd, *_ = jax.jit(zoh)(a, b, c, d, DT)
        np.testing.assert_allclose(np.asarray(jad), ad, rtol=0, atol=1e-12 * np.abs(ad).max())
        np.testing.assert_allclose(np.asarray(jbd), bd, rtol=0, atol=1e-12 * np.abs(bd).max())


# ----------------------------------------------------------------------------------------------------- rebalance

SIM = jax.jit(loops.simulate_rebalance, static_argnums=(2, 3))


def test_rebalance_static_balance_reproduces_sf_effects():
    """Steady current × S_nom = ω + E_SF·ω + E_A·|ω| + E_2·ω·(ω in deg/s) (conventions §4/§6), for both signs."""
    e_sf, e_a, e_2 = 150.0, 40.0, 25.0
    p = loops.default_rebalance(E_SF=e_sf, E_A=e_a, E_2=e_2)
    levels = np.array([0.0, 15.04, -15.04, 300.0, -300.0, 1800.0, -1800.0, 3600.0])
    hold = 1500  # 1.5 s per level: 47 time constants of the slowest closed-loop pole (31 rad/s)
    w = np.repeat(levels, hold)
    u = np.asarray(SIM(p, w, DT))[hold - 1 :: hold]
    expect = levels + 1e-6 * (e_sf * levels + e_a * np.abs(levels) + e_2 * levels * levels / 3600.0)
    # the loop is type 1 (the float integrates): no static error for a constant rate
    np.testing.assert_allclose(u, expect, rtol=0, atol=1e-9 * 3600)
    # and the effects are far above that tolerance (the test can fail)
    assert np.abs(expect - levels).max() > 0.5


def test_rebalance_slow_input_within_loop_static_error():
    """A slow sine (0.01 Hz) reads ω_I(1 + E_SF) up to the loop's lag error |1 − T(jω)|·amplitude."""
    p = loops.default_rebalance(E_SF=300.0)
    f, amp = 0.01, 200.0
    t = np.arange(40_000) * DT
    w = amp * np.sin(2 * np.pi * f * t)
    u = np.asarray(SIM(p, w, DT))
    bound = abs(1 - loops.rebalance_closed_loop_tf(p, 2j * np.pi * f)) * amp + 1e-9
    err = u[5000:] - w[5000:] * (1 + 300e-6)
    assert np.abs(err).max() < 1.2 * bound + 2 * np.pi * f * amp * DT  # + one sample of input slope (ZOH)
    assert bound < 0.005 * amp  # quasi-static: the loop's lag error is < 0.5 % of the input


def _fit_gain(y, x, t, f):
    m = np.column_stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t), np.ones_like(t)])
    cy = np.linalg.lstsq(m, y, rcond=None)[0]
    cx = np.linalg.lstsq(m, x, rcond=None)[0]
    return complex(cy[0], cy[1]) / complex(cx[0], cx[1])


@pytest.mark.parametrize("third_order", [False, True])
def test_rebalance_frequency_response_matches_transfer_function(third_order):
    p = loops.default_rebalance()
    freqs = np.array([0.5, 2.0, 5.0, 10.0, 20.0, 40.0, 80.0])
    n = 4000
    t = np.arange(n) * DT
    x = np.sin(2 * np.pi * freqs[:, None] * t[None, :])
    y = np.asarray(jax.vmap(lambda w: loops.simulate_rebalance(p, w, DT, third_order))(x))
    keep = slice(2000, None)  # 2 s of settled response: an integer number of cycles at every frequency
    s = 2j * np.pi * freqs
    zoh_factor = (1 - np.exp(-s * DT)) / (s * DT)  # the sampled-and-held input's fundamental
    ref = loops.rebalance_closed_loop_tf(p, s, third_order) * zoh_factor
    got = np.array([_fit_gain(y[i, keep], x[i, keep], t[keep], f) for i, f in enumerate(freqs)])
    np.testing.assert_array_less(np.abs(got / ref - 1), 0.01)  # gain to 1 % and phase to 0.01 rad
    # the response really varies over the band (not a trivially flat loop)
    assert np.abs(ref).max() / np.abs(ref).min() > 1.5 and np.ptp(np.angle(ref)) > 0.5


@pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")  # scipy's ss→tf step; 1e-9 agreement below
def test_block_diagram_tf_equals_scipy_freqresp_of_state_space():
    for third in (False, True):
        p = loops.default_rebalance()
        a, b, c, d = map(np.asarray, loops.rebalance_state_space(p, third))
        w = 2 * np.pi * np.array([0.1, 3.0, 30.0, 300.0])
        _, h = sig.freqresp((a, b[:, :1], c, d[:, :1]), w)
        np.testing.assert_allclose(h, loops.rebalance_closed_loop_tf(p, 1j * w, third), rtol=1e-9)


def test_float_offset_angle_5_67():
    """Float angle θ_g ≈ M_d/(K_tg·K_sg·K) at steady state (Hu 5-66/5-67), here M_d = H·ω."""
    p = loops.default_rebalance()
    a, b, c, d = map(np.asarray, loops.rebalance_state_space(p))
    omega = units.OMEGA_IE_DEG_PER_H
    x = np.linalg.solve(a, -b[:, 0] * omega)
    k_tg = p.H * p.S_nom * units.DEG_PER_H  # N·m/mA
    expect = p.H * omega * units.DEG_PER_H / (k_tg * p.K_pickoff * p.K_amp)  # G_c(0) = K_amp
    assert x[0] == pytest.approx(expect, rel=1e-9)
    assert x[0] / units.ARCSEC < 1.0  # Hu: choose K so that one Earth rate gives ≤ 1″


def test_rebalance_vmap_over_gyros_and_grad_against_finite_differences():
    base = loops.default_rebalance(E_SF=150.0, E_A=40.0, E_2=25.0, K_fw_x=20.0, K_fw_y=50.0)
    w = jnp.concatenate([jnp.full(60, 50.0), jnp.full(60, 400.0)])

    def loss(p, third):
        u = loops.simulate_rebalance(p, w, DT, third)
        return jnp.sum(u[-80:] ** 2) / 1e4

    loss = jax.jit(loss, static_argnums=1)

    # vmap over a batch of gyros equals one-by-one
    batch = jax.tree_util.tree_map(lambda v: jnp.array([v, 1.1 * v, 0.9 * v]), base)
    got = jax.jit(jax.vmap(lambda q: loops.simulate_rebalance(q, w, DT)))(batch)
    for i in range(3):
        one = jax.tree_util.tree_map(lambda v: v[i], batch)
        np.testing.assert_allclose(got[i], SIM(one, w, DT), rtol=1e-13, atol=1e-10)

    for third in (False, True):
        g = jax.jit(jax.grad(loss), static_argnums=1)(base, third)
        for f in dataclasses.fields(base):
            v = getattr(base, f.name)
            h = 1e-3 * abs(v) if v else 1e-3
            fd = (
                loss(dataclasses.replace(base, **{f.name: v + h}), third)
                - loss(dataclasses.replace(base, **{f.name: v - h}), third)
            ) / (2 * h)
            gv = float(getattr(g, f.name))
            if f.name in ("K_fw_x", "K_fw_y") and not third:
                assert gv == 0.0
                continue
            assert gv == pytest.approx(float(fd), rel=1e-5, abs=1e-9 * (1 + abs(float(loss(base, third))))), f.name


# --------------------------------------------------------------------------------------------------------- pulse

PULSE = jax.jit(loops.simulate_pulse, static_argnums=(2, 3))
TS, M = 1e-3, 200  # f_s = 1 kHz sawtooth, f_q = 200 kHz data pulses


def test_pulse_quantum_5_70_and_indicated_rate():
    pp = loops.default_pulse()
    g = pp.gyro
    k_tq = g.H * g.S_nom * units.DEG_PER_H  # torquer N·m/mA
    n_rad = loops.pulse_quantum(g.H, k_tq, pp.I_pulse, M / TS)
    # Hu 5-70 by hand: N = I·K/(H·f_q); here K/H = S_nom in rad/s per mA, so N = I·S_nom/(3600·f_q) deg
    assert n_rad / units.DEG == pytest.approx(pp.I_pulse * g.S_nom / 3600 / (M / TS), rel=1e-12)
    omega = 123.456
    n = 20_000
    # skip the first 2 s: the float takes up a standing angle ∝ ω (5-67) that the counts do not see
    counts = np.asarray(PULSE(pp, np.full(n, omega), TS, M))[2000:]
    t_acc = counts.size * TS
    rate = n_rad * counts.sum() / t_acc / units.DEG_PER_H  # 5-71/5-73: ω = N·(n₊ − n₋)/T
    resolution = n_rad / t_acc / units.DEG_PER_H  # ω_d1 = N/T (5-73)
    assert abs(rate - omega) < 3 * resolution
    assert resolution < 1e-3  # a meaningful test: 3 quanta ≪ the rate


def test_pulse_resolution_example_misprint_5_73():
    """Hu's example after 5-73: N = 1e-6 deg/pulse, drift ~1e-4 deg/h. T > N/ω_d1 = 0.01 **h** (36 s);
    the book prints "0.01 秒" (s): a unit misprint."""
    t_h = 1e-6 / 1e-4
    assert t_h == pytest.approx(0.01) and t_h * 3600 == pytest.approx(36.0)


def test_pulse_zero_bias_current_5_74():
    """I_0 = −(ΔI⁺ − ΔI⁻)/2 + 2·I·ΔT(0)/T_s (Hu 5-74), with the counted current I·(n₊ − n₋)/(M) averaged."""
    pp = loops.default_pulse(dI_plus=0.3, dI_minus=0.1, dT=1e-7)
    n = 20_000
    counts = np.asarray(PULSE(pp, np.zeros(n), TS, M))[2000:]
    i0 = pp.I_pulse * counts.mean() / M
    expect = -(pp.dI_plus - pp.dI_minus) / 2 + 2 * pp.I_pulse * pp.dT / TS
    assert i0 == pytest.approx(expect, rel=0.01)
    # without the errors the loop has no bias (to its resolution)
    c0 = np.asarray(PULSE(loops.default_pulse(), np.zeros(n), TS, M))[2000:]
    assert abs(pp.I_pulse * c0.mean() / M) < 0.01 * abs(expect)


def _oadev(rate, dt, ms):
    theta = np.concatenate([[0.0], np.cumsum(rate) * dt])
    out = []
    for m in ms:
        tau = m * dt
        d = theta[2 * m :] - 2 * theta[m:-m] + theta[: -2 * m]
        out.append(np.sqrt(0.5 * np.mean(d * d)) / tau)
    return np.array(out)


def test_pulse_rate_allan_deviation_has_quantisation_slope():
    """The pulse output's ADEV falls as τ⁻¹ at short τ (angle quantisation, IEEE 952 annex C)."""
    pp = loops.default_pulse()
    n = 40_000
    rng = np.random.default_rng(3)
    w = 100.0 + 5.0 * np.cumsum(rng.normal(size=n)) / np.sqrt(n)  # a slowly wandering input keeps it aperiodic
    counts = np.asarray(PULSE(pp, w, TS, M))[1000:]
    n_deg = pp.I_pulse * pp.gyro.S_nom / 3600 / (M / TS)
    rate = counts * n_deg / TS  # deg/s
    ms = np.array([2, 4, 8, 16, 32])
    ad = _oadev(rate, TS, ms)
    slope = np.polyfit(np.log(ms), np.log(ad), 1)[0]
    assert -1.25 < slope < -0.8
    # and the level is the quantum's: σ(τ) is of order N/τ (√3·Q/τ for a uniform angle error, Q ~ N/√12..N)
    ratio = ad * ms * TS / n_deg
    assert np.all((ratio > 0.05) & (ratio < 5))


# --------------------------------------------------------------------------------------------------------- servo

SERVO = jax.jit(loops.simulate_servo, static_argnums=(4,))


def test_servo_static_error_is_M_over_KT_5_18():
    p = loops.default_servo()
    # K_T from the block diagram at DC (Hu 5-15/5-18): angle → float angle H/C (2-56) → pickoff K_sg →
    # amplifier K_1·G_1(0) → motor K_m: torque per radian of table error
    k_t = p.H / p.C_damp * p.K_pickoff * p.K_amp * p.K_motor
    m = 0.05  # N·m, ~510 g·cm, a constant disturbance (M_DC of 5-37)
    n = 3000
    th, om, thg = SERVO(p, np.zeros(n), np.zeros(n), np.full(n, m), DT)
    assert float(th[-1]) == pytest.approx(m / k_t, rel=0.01)
    assert abs(float(om[-1])) < 1e-12
    # Hu 5-19 text: achievable stiffness is a few thousand to a few hundred thousand g·cm/″
    kt_gcm_per_arcsec = k_t / (units.G0 * 1e-5) * units.ARCSEC
    assert 1e3 < kt_gcm_per_arcsec < 1e6


def test_servo_follows_commanded_rate_and_earth_rate_3_59():
    """θ̇_T = S_nom·i − ω_IB − drift (Hu 3-59 with a commanded current); the loop has no rate error."""
    p = loops.default_servo()
    n = 20_000
    w_ib = units.OMEGA_IE_DEG_PER_H * math.sin(math.radians(40.0))
    drift, i_cmd = 0.37, 10.0
    th, om, _ = SERVO(p, np.full(n, w_ib), np.full(n, drift - p.S_nom * i_cmd), np.zeros(n), DT)
    th = np.asarray(th)
    rate = (th[-1] - th[10_000]) / ((n - 1 - 10_000) * DT) / units.DEG_PER_H
    assert rate == pytest.approx(p.S_nom * i_cmd - w_ib - drift, rel=1e-9)


def test_servo_unbalance_tracking_error_5_36():
    """At a slow table rate the tracking error is quasi-static: ε = [G·m·cos φ·sin θ − K_m·K_e·θ̇]/K_T."""
    p = loops.default_servo(G_m=0.8, phi_axis=math.radians(30.0))
    k_t = loops.servo_stiffness(p)
    n = 40_000
    rate_dps = 10.0
    th, om, _ = SERVO(p, np.zeros(n), np.full(n, -rate_dps * 3600.0), np.zeros(n), DT)
    th, om = np.asarray(th), np.asarray(om)
    t = np.arange(n) * DT
    # ideal angle: rate × time, offset by the constant lag; compare the periodic part
    err = th - np.radians(rate_dps) * t
    model = (p.G_m * np.cos(p.phi_axis) * np.sin(th) - p.K_motor * p.K_emf * om) / k_t
    sel = slice(5000, None)
    resid = (err - model)[sel]
    amp = p.G_m * np.cos(p.phi_axis) / k_t
    assert np.abs(resid - resid.mean()).max() < 0.02 * amp
    assert np.ptp(err[sel]) > 1.5 * amp  # the unbalance error is really there


def test_inductosyn_readout():
    q = 0.36 * units.ARCSEC
    th = np.random.default_rng(1).uniform(0.0, 2 * np.pi, 100_000)
    r = np.asarray(loops.inductosyn_readout(th, q=q))
    assert np.abs(r - th).max() <= q / 2 + 1e-15
    assert np.std(r - th) == pytest.approx(q / np.sqrt(12), rel=0.02)  # uniform quantisation error
    # within-pitch error 5-51: period 180°/p mechanical (2pα), zero at α = 0, ½(Δα_0 + Δe) at 2pα = π/2
    p, da0, de = 360, 0.5 * units.ARCSEC, 0.3 * units.ARCSEC
    e = lambda a: float(loops.inductosyn_readout(a, pole_pairs=p, electrical=(da0, de, 0.0)) - a)
    a0 = np.pi / (4 * p)
    assert e(0.0) == pytest.approx(0.0, abs=1e-15)
    assert e(a0) == pytest.approx(0.5 * (da0 + de), rel=1e-6)
    assert e(a0 + np.pi / p) == pytest.approx(e(a0), rel=1e-6)


def test_lifted_dlsim_equals_scipy_dlsim():
    a, b, c, d = _rand_system(5, n=5, m=3, p=2)
    ad, bd, cd, dd, _ = sig.cont2discrete((a, b, c, d), 0.05, method="zoh")
    rng = np.random.default_rng(0)
    u = rng.normal(size=(64 * 20, 3))
    x0 = rng.normal(size=5)
    _, y_ref, _ = sig.dlsim((ad, bd, cd, dd, 0.05), u, x0=x0)
    y, xf = loops.lifted_dlsim(jnp.asarray(ad), jnp.asarray(bd), jnp.asarray(cd), jnp.asarray(dd), u, x0, block=64)
    np.testing.assert_allclose(np.asarray(y), y_ref, rtol=0, atol=1e-10 * np.abs(y_ref).max())


def test_loop_indicated_rate_glue_at_record_interval():
    """With the record's 1 s interval as the step, every sample reads the balance value of its own input
    (the loop settles in ≪ 1 s): the quasi-static model of conventions §4, with no sample delay."""
    e_sf, e_a, e_2 = 150.0, 40.0, 25.0
    p = loops.default_rebalance(E_SF=e_sf, E_A=e_a, E_2=e_2)
    rng = np.random.default_rng(7)
    w = rng.uniform(-3000.0, 3000.0, 200)
    u = np.asarray(jax.jit(loops.loop_indicated_rate, static_argnums=(2, 3))(p, w, 1.0))
    expect = w + 1e-6 * (e_sf * w + e_a * np.abs(w) + e_2 * w * w / 3600.0)
    np.testing.assert_allclose(u, expect, rtol=0, atol=1e-6)  # the effects are ~0.1-1 deg/h


def test_pulse_scale_factor_error_5_76():
    """Current-amplitude errors change the loop scale factor by (ΔI⁺ + ΔI⁻)/2 relative to I (Hu 5-76, first
    term; the timing term vanishes for a rate-independent ΔT). Our ΔI± make the pulses stronger, so the counts
    (and the indicated rate) fall: E_SF = −(ΔI⁺ + ΔI⁻)/(2I). The book's sign belongs to its Fig. 5-44, which the
    seed lacks; the magnitude is the check."""
    pp = loops.default_pulse(dI_plus=0.3, dI_minus=0.1)
    n, skip = 22_000, 2000
    n_deg_h = pp.I_pulse * pp.gyro.S_nom / (M / TS)  # the quantum N (5-70) in deg/h·s: I·S_nom/f_q
    rates = []
    for omega in (500.0, -500.0):
        counts = np.asarray(PULSE(pp, np.full(n, omega), TS, M))[skip:]
        rates.append(n_deg_h * counts.sum() / (counts.size * TS))
    e_sf = (rates[0] - rates[1]) / 1000.0 - 1.0
    book = (pp.dI_plus + pp.dI_minus) / 2 / pp.I_pulse
    assert -e_sf == pytest.approx(book, rel=0.01)


def test_servo_disturbance_response_5_15_and_stiffness_gradient():
    """Angle error per disturbance torque, θ_T/M = 1/[s(Js + K_m(K_e + K_tach)) + K_m·K_1·G_1(s)·K_sg·(H/C)/(τs+1)]
    (Hu 5-15 integrated, with G_g from 2-59), at 5 frequencies to 1 %; and ∂ε/∂K_1 = −ε/K_1 from ε = M/K_T."""
    p = loops.default_servo(K_tach=0.5)
    freqs = np.array([0.3, 2.0, 10.0, 30.0, 80.0])
    n = 6000
    t = np.arange(n) * DT
    x = np.sin(2 * np.pi * freqs[:, None] * t[None, :])
    z = np.zeros(n)
    th = np.asarray(jax.jit(jax.vmap(lambda m: loops.simulate_servo(p, z, z, m, DT)[0]))(x))
    keep = slice(2667, None)  # the last 3.333 s (one cycle at 0.3 Hz); least squares copes with partial cycles
    s = 2j * np.pi * freqs
    g1 = (p.tau_lead * s + 1) / (p.tau_lag * s + 1)
    den = s * (p.J_table * s + p.K_motor * (p.K_emf + p.K_tach)) + p.K_motor * p.K_amp * g1 * p.K_pickoff * (
        p.H / p.C_damp
    ) / (p.I_float / p.C_damp * s + 1)
    ref = (1 / den) * (1 - np.exp(-s * DT)) / (s * DT)
    got = np.array([_fit_gain(th[i, keep], x[i, keep], t[keep], f) for i, f in enumerate(freqs)])
    np.testing.assert_array_less(np.abs(got / ref - 1), 0.01)

    m, q0, n2 = 0.05, loops.default_servo(), 1500

    def eps(q):
        return loops.simulate_servo(q, jnp.zeros(n2), jnp.zeros(n2), jnp.full(n2, m), DT)[0][-1]

    e, g = jax.jit(jax.value_and_grad(eps))(q0)
    assert float(e) == pytest.approx(m / loops.servo_stiffness(q0), rel=0.01)
    assert float(g.K_amp) == pytest.approx(-float(e) / q0.K_amp, rel=0.01)
    assert float(g.J_table) == pytest.approx(0.0, abs=1e-3 * abs(float(e)) / q0.J_table)  # static: no inertia


def test_simulate_with_loop_dynamics_matches_quasi_static_at_low_frequency():
    """Every rebalance plan runs through the loop; at the plans' (low) input frequencies the loop output equals
    the quasi-static balance equation within the loop's static error (Hu 3-55, 5-64 to 5-67)."""
    from gyrojax import simulate
    from gyrojax.data import plans

    truth = {"coefficients": {"D_F": 0.4, "D_I": 0.6, "E_SF": 120.0}}
    for plan in (
        plans.multiposition(8, minutes=0.5, dt_s=1.0),
        plans.rate_ladder(rates_dps=(5, 50), seconds=4),
        plans.tumble(revolutions=0.1, dt_s=10.0),
    ):
        qs = simulate(plan, truth)
        lp = simulate(plan, truth, dynamics="loop")
        for a, b in zip(qs, lp):
            # the first sample of each segment carries the step from the table moving between segments
            seg = a.segment_id
            keep = np.diff(seg, prepend=-1) == 0
            scale = np.abs(a.indicated).max()
            np.testing.assert_allclose(b.indicated[keep], a.indicated[keep], rtol=0, atol=1e-6 * scale + 1e-9)
