"""DTG capture loops, both channels (gyrojax.tdfloop). References: closed forms derived by hand below from the rotor
equations (Hu 3-94, 5-64..5-68; Titterton 4.7, 6.4), scipy.signal, finite differences."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg as sl
import scipy.signal as sig

from gyrojax import units
from gyrojax.dynamics import tdfloop
from gyrojax.dynamics.discretize import zoh

DPH = units.DEG_PER_H
DT = 1e-3
SIM = jax.jit(tdfloop.simulate_tdf, static_argnums=2)


def _k(p):
    """Cross-feed DC gains k_X, k_Y (deg/h per rad): u_c = −k_c·θ_c at DC."""
    return p.S_nom * p.K_amp_X * p.K_pickoff, p.S_nom * p.K_amp_Y * p.K_pickoff


def _steady(p, levels, hold=1500):
    """Last reading (deg/h) of each constant (ωx, ωy) level held ``hold`` steps of DT (the slowest mode, ~28 /s,
    has decayed by e⁻⁴⁰ after 1.5 s)."""
    w = np.repeat(np.asarray(levels, dtype=float), hold, axis=0)
    return np.asarray(SIM(p, w, DT, None, jnp.zeros(8)))[hold - 1 :: hold]


LEVELS = [(100.0, 0.0), (0.0, 100.0), (15.04, -40.0), (-300.0, 250.0), (1800.0, 900.0)]


def test_static_balance_closed_form_with_all_couplings():
    """Steady readings = S⁻¹ω with S built by hand from the balance (Hu 3-94 with springs and offsets 5-67/5-68):
    y-axis:  ΔK θy − λ θx = −H p_X + H ωx,  x-axis:  ΔK θx + λ θy = H p_Y − H ωy,  p = T u,  θ = −u/k."""
    p = tdfloop.default_tdf(E_SF_X=150.0, E_SF_Y=-80.0, mu_XY=2e-3, mu_YX=-1e-3, dK=0.1 * 0.02, lam=5e-4)
    kx, ky = _k(p)
    kap, ell = p.dK / (p.H * DPH), p.lam / (p.H * DPH)
    s = np.array([[1 + 150e-6 + ell / kx, 2e-3 - kap / ky], [-1e-3 + kap / kx, 1 - 80e-6 + ell / ky]])
    u = _steady(p, LEVELS)
    expect = np.linalg.solve(s, np.asarray(LEVELS).T).T
    np.testing.assert_allclose(u, expect, rtol=0, atol=1e-9 * np.abs(expect).max())
    # the module's own static matrix is the same
    np.testing.assert_allclose(np.asarray(tdfloop.tdf_static_matrix(p)), s, rtol=1e-13)
    # and the couplings are far above the tolerance: the cross-axis reading is real
    assert abs(u[0, 1]) > 0.02 and abs(u[1, 0]) > 0.02


def test_each_channel_reads_its_own_axis_within_the_static_error():
    """Defaults (no SF error, no misalignment): u ≈ ω, off by at most the spring/offset static error
    (|ΔK| + |λ|)/(H·k) per unit rate, which is small (< 3e-4) but not zero."""
    p = tdfloop.default_tdf()
    kx, ky = _k(p)
    bound = (abs(p.dK) + abs(p.lam)) / (p.H * DPH) / min(kx, ky)
    assert 1e-5 < bound < 3e-4
    u = _steady(p, LEVELS)
    w = np.asarray(LEVELS)
    err = np.abs(u - w).max(axis=1)
    assert np.all(err <= bound * np.abs(w).sum(axis=1) + 1e-9)
    assert err.max() > 0.1 * bound * np.abs(w).max()


def test_steady_torques_are_hu_3_94_and_offsets_are_5_67():
    """Ideal loop (no springs): torque about Y = −H ωx, about X = H ωy (Hu 3-94, Titterton 6.4); the pickoff
    angles hold at θ_c = −u_c/k_c, Hu 5-67's θ_g = M_d/(K_tg K_sg K) per channel."""
    p = tdfloop.default_tdf(dK=0.0, lam=0.0, D=0.0)
    a, b, c, _ = map(np.asarray, tdfloop.tdf_state_space(p))
    w = np.array([15.04, -7.5])
    x = np.linalg.solve(a, -b @ np.r_[w, 0.0, 0.0])
    u = c @ x
    np.testing.assert_allclose(u, w, rtol=1e-12)
    kx, ky = _k(p)
    np.testing.assert_allclose(x[:2], -u / np.array([kx, ky]), rtol=1e-12)
    # the torque the torquers apply: M_x = H' p_Y, M_y = −H' p_X with p = u (T = I)
    m_x, m_y = p.H * DPH * u[1], -p.H * DPH * u[0]
    assert m_y == pytest.approx(-p.H * w[0] * DPH, rel=1e-12) and m_x == pytest.approx(p.H * w[1] * DPH, rel=1e-12)
    # one Earth rate leaves the rotor < 1 arcsec off null (Hu's gain rule after 5-67)
    assert abs(x[0]) < units.ARCSEC * abs(w[0]) / units.OMEGA_IE_DEG_PER_H


@pytest.mark.parametrize(
    "coupling",
    ["dK", "mu_YX", "lam"],
)
def test_cross_coupling_reading_closed_form(coupling):
    """One coupling at a time, rate ωx = W only (S from the balance in the first test, by hand):
    - mistuning ΔK (Hu 5-68 quadrature stiffness K_q = ΔK/H): u_X = W/Δ, u_Y = −(κ/k_X)·W/Δ, Δ = 1 + κ²/(k_X k_Y);
    - torquer cross-coupling μ_YX: u_X = W, u_Y = −μ_YX·W;
    - quadrature spring λ (Hu 5-68 in-phase stiffness K_φ = λ/H): no cross reading, u_X = W/(1 + ℓ/k_X)."""
    clean = dict(dK=0.0, lam=0.0, mu_XY=0.0, mu_YX=0.0)
    value = {"dK": 0.05 * 0.02, "mu_YX": 3e-3, "lam": 2e-3}[coupling]
    p = tdfloop.default_tdf(**{**clean, coupling: value})
    kx, ky = _k(p)
    big = 1000.0
    u = _steady(p, [(big, 0.0)])[0]
    if coupling == "dK":
        kap = value / (p.H * DPH)
        det = 1 + kap * kap / (kx * ky)
        expect = (big / det, -kap / kx * big / det)
    elif coupling == "mu_YX":
        expect = (big, -value * big)
    else:
        expect = (big / (1 + value / (p.H * DPH) / kx), 0.0)
    np.testing.assert_allclose(u, expect, rtol=0, atol=1e-9 * big)
    assert abs(u[1]) > 0.5 or coupling == "lam"
    assert abs(u[0] - big) > 0.1 or coupling != "lam"


def _fit(y, t, f):
    m = np.column_stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t), np.ones_like(t)])
    c = np.linalg.lstsq(m, y, rcond=None)[0]
    return complex(c[0], c[1])


def test_simulated_frequency_response_matches_transfer_matrix():
    """Sine in ωx (then ωy), least-squares sine/cosine of the steady outputs: all four entries of the 2×2 closed-loop
    matrix, gain and phase to 1 %, at 5 frequencies. dt = 50 µs so that the held input's images (near 20 kHz)
    alias negligibly; the fundamental carries the ZOH factor (1 − e^{−sT})/(sT)."""
    p = tdfloop.default_tdf(E_SF_X=2000.0, mu_XY=5e-3)
    dt = 5e-5
    freqs = np.array([2.0, 6.0, 20.0, 45.0, 100.0])
    n = 30_000  # 1.5 s: 0.5 s to settle (slowest mode ~28 /s), then 1 s = an integer number of cycles
    t = np.arange(n) * dt
    sine = np.sin(2 * np.pi * freqs[:, None] * t[None, :])
    zeros = np.zeros_like(sine)
    inputs = np.concatenate([np.stack([sine, zeros], -1), np.stack([zeros, sine], -1)])  # (10, n, 2)
    y = np.asarray(jax.jit(jax.vmap(lambda w: tdfloop.simulate_tdf(p, w, dt, None, jnp.zeros(8))))(inputs))
    keep = slice(10_000, None)
    s = 2j * np.pi * freqs
    ref = tdfloop.tdf_closed_loop_tf(p, s) * ((1 - np.exp(-s * dt)) / (s * dt))[:, None, None]
    for j in range(2):  # input axis
        for i, f in enumerate(freqs):
            x_amp = _fit(inputs[j * 5 + i, keep, j], t[keep], f)
            for k in range(2):  # output channel
                got = _fit(y[j * 5 + i, keep, k], t[keep], f) / x_amp
                assert abs(got / ref[i, k, j] - 1) < 0.01, (j, f, k, got, ref[i, k, j])
    # direct and cross terms really vary over the band
    assert np.ptp(np.abs(ref[:, 0, 0])) > 0.2 and np.ptp(np.abs(ref[:, 1, 0])) > 0.05


@pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")
def test_transfer_matrix_equals_scipy_freqresp_and_zoh_equals_cont2discrete():
    p = tdfloop.default_tdf(E_SF_Y=500.0, mu_YX=1e-3, dK=1e-3)
    a, b, c, d = map(np.asarray, tdfloop.tdf_state_space(p))
    w = 2 * np.pi * np.array([0.05, 3.0, 30.0, 300.0, 3000.0])
    for kind, cols in (("rate", (0, 1)), ("drift", (2, 3))):
        mat = tdfloop.tdf_closed_loop_tf(p, 1j * w, kind)
        # exact resolvent C (jωI − A)⁻¹ B (scipy.linalg)
        res = np.stack([c @ sl.solve(1j * wk * np.eye(8) - a, b[:, cols]) for wk in w])
        np.testing.assert_allclose(mat, res, rtol=1e-10, atol=1e-12)
        # scipy.signal.freqresp goes through a polynomial form of this stiff 8-state system: ~1e-6 agreement
        for jj, col in enumerate(cols):
            for out in range(2):
                ss = sig.StateSpace(a, b[:, col : col + 1], c[out : out + 1], d[out : out + 1, col : col + 1])
                _, h = sig.freqresp(ss, w)
                np.testing.assert_allclose(mat[:, out, jj], h, rtol=2e-5, atol=1e-7 * np.abs(mat).max())
    ad, bd, *_ = sig.cont2discrete((a, b, c, d), DT, method="zoh")
    jad, jbd, *_ = jax.jit(zoh)(a, b, c, d, DT)
    np.testing.assert_allclose(np.asarray(jad), ad, rtol=0, atol=1e-11 * np.abs(ad).max())
    np.testing.assert_allclose(np.asarray(jbd), bd, rtol=0, atol=1e-11 * np.abs(bd).max())


def test_closed_loop_eigenvalues_stable_and_are_block_diagram_poles():
    p = tdfloop.default_tdf()
    a = np.asarray(tdfloop.tdf_state_space(p)[0])
    ev = np.linalg.eigvals(a)
    assert ev.real.max() < -10.0
    assert (-ev.real / np.abs(ev)).min() > 0.2  # every mode damped (nutation included)
    # each eigenvalue zeroes the block-diagram characteristic det(P + H'·J·T·G) (independent of the realisation)
    kx, ky = _k(p)
    jm = np.array([[0.0, 1.0], [-1.0, 0.0]])
    for s in ev:
        ll = (p.tau_lead * s + 1) / (p.tau_lag * s + 1)
        wn = p.K_nut / (p.H * DPH) * s / (p.tau_nut * s + 1)
        g = np.array([[kx * ll, -wn], [wn, ky * ll]])
        pl = (p.A * s * s + p.D * s + p.dK) * np.eye(2) + (p.H * s + p.lam) * jm
        m = pl + p.H * DPH * jm @ g
        scale = np.abs(pl).max() + np.abs(p.H * DPH * jm @ g).max()
        assert abs(np.linalg.det(m)) < 1e-9 * scale**2, s


def test_free_rotor_nutates_at_H_over_A_and_cross_feed_alone_is_unstable():
    """Open loop, no springs or damping: rotor modes 0, 0, ±j·H/A (Titterton 4.7 with I_ig = I_og = A). Closing only
    the cross-feed (no direct-channel term) drives the nutation unstable; the direct term damps it."""
    p = tdfloop.default_tdf(K_amp_X=0.0, K_amp_Y=0.0, K_nut=0.0, D=0.0, dK=0.0, lam=0.0)
    ev = np.linalg.eigvals(np.asarray(tdfloop.tdf_state_space(p)[0]))
    rotor = ev[np.abs(ev.real) < 1e-6]
    wn = p.H / p.A
    np.testing.assert_allclose(np.sort(np.abs(rotor.imag)), [0.0, 0.0, wn, wn], atol=1e-6 * wn)
    assert float(tdfloop.tdf_nutation_frequency(p)) == pytest.approx(wn)
    assert wn / (2 * np.pi) == pytest.approx(1.5 * 200.0)  # default: 1.5 × the 200 Hz spin
    cross_only = tdfloop.default_tdf(K_nut=0.0)
    ev = np.linalg.eigvals(np.asarray(tdfloop.tdf_state_space(cross_only)[0]))
    assert ev.real.max() > 0 and abs(ev[np.argmax(ev.real)].imag) > 0.5 * wn


def test_vmap_over_gyros_and_grad_against_finite_differences():
    base = tdfloop.default_tdf(E_SF_X=150.0, E_SF_Y=-60.0, mu_XY=1e-3, mu_YX=-2e-3)
    w = jnp.concatenate([jnp.tile(jnp.array([[50.0, -20.0]]), (60, 1)), jnp.tile(jnp.array([[400.0, 300.0]]), (60, 1))])

    def loss(q):
        u = tdfloop.simulate_tdf(q, w, DT)
        return jnp.sum(u[-60:] ** 2) / 1e4

    loss = jax.jit(loss)
    batch = jax.tree_util.tree_map(lambda v: jnp.array([v, 1.1 * v, 0.9 * v]), base)
    got = jax.jit(jax.vmap(lambda q: tdfloop.simulate_tdf(q, w, DT)))(batch)
    for i in range(3):
        one = jax.tree_util.tree_map(lambda v: v[i], batch)
        np.testing.assert_allclose(got[i], SIM(one, w, DT), rtol=1e-12, atol=1e-9)
    g = jax.jit(jax.grad(loss))(base)
    l0 = float(loss(base))
    for f in dataclasses.fields(base):
        v = getattr(base, f.name)
        h = 1e-2 * abs(v) if v else 1e-2

        def at(x, name=f.name):
            return float(loss(dataclasses.replace(base, **{name: x})))

        fd = (-at(v + 2 * h) + 8 * at(v + h) - 8 * at(v - h) + at(v - 2 * h)) / (12 * h)  # 5-point stencil
        # D barely moves the output (its rate D/A is 0.008 /s): its difference quotient is rounding-limited
        rel = 1e-4 if f.name == "D" else 1e-5
        assert float(getattr(g, f.name)) == pytest.approx(fd, rel=rel, abs=1e-9 * (1 + l0)), f.name
    # the steady output depends on the loop gain through the static error (nonzero gradient)
    assert abs(float(g.K_amp_X)) > 0 and abs(float(g.dK)) > 0


def test_indicated_rates_glue_at_record_interval():
    """At a record's 1 s interval a constant input reads S⁻¹ω at every sample (no sample delay)."""
    p = tdfloop.default_tdf(E_SF_X=300.0, mu_XY=1e-3)
    w = np.tile([[15.04, -8.0]], (5, 1))
    d = np.tile([[0.5, -0.2]], (5, 1))
    u = np.asarray(jax.jit(tdfloop.tdf_indicated_rates, static_argnums=2)(p, w, 1.0, d))
    expect = np.linalg.solve(np.asarray(tdfloop.tdf_static_matrix(p)), w[0] + d[0])
    np.testing.assert_allclose(u, np.tile(expect, (5, 1)), rtol=1e-11)
    # a step: the loops settle within one 1 s sample (slowest mode ~28 /s)
    w2 = np.concatenate([w, np.tile([[100.0, 50.0]], (3, 1))])
    u2 = np.asarray(tdfloop.tdf_indicated_rates(p, w2, 1.0))
    np.testing.assert_allclose(
        u2[5:], np.tile(np.linalg.solve(np.asarray(tdfloop.tdf_static_matrix(p)), [100.0, 50.0]), (3, 1)), rtol=1e-9
    )
