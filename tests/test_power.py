"""The power helper of the detection tests (tests/power.py) against closed forms."""

import numpy as np
import pytest
from scipy import stats

from gyrojax import simulate
from gyrojax.data import plans

from . import power as pw


def test_trend_beside_a_bias_has_the_least_squares_noncentrality():
    """A trend D_T beside D_F at one position: Var(D̂_T) = σ² / Σ(t_h − t̄_h)² (straight-line regression), so
    λ = D_T² Σ(t_h − t̄_h)² / σ², σ = 60 N / √Δt; the score form is n λ / (n + λ)."""
    recs = simulate(plans.fixed_position(hours=0.5, dt_s=2.0), {"coefficients": {"D_F": 0.1}})
    t_h = np.asarray(recs[0].columns["time_s"]) / 3600
    n, sigma, d_t = len(t_h), 60 * 0.001 / np.sqrt(2.0), 0.02
    lam = d_t**2 * np.sum((t_h - t_h.mean()) ** 2) / sigma**2
    got = pw.noncentrality(recs, ["D_F"], "bias_trend", {"D_F": 0.1, "D_T": d_t}, 0.001)
    assert got == pytest.approx(n * lam / (n + lam), rel=1e-9)


def test_inputs_at_rest_are_earth_rate_and_gravity():
    """IA Up at rest: ω_I = ω_ie sin φ (15.04107 deg/h · sin φ), a_I = g_site / g0 (conventions §1–§2)."""
    plan = plans.fixed_position(hours=0.01, dt_s=1.0, ia=(0, 0, 1), oa=(1, 0, 0))
    rec = simulate(plan, {"coefficients": {}})[0]
    x = pw.inputs(rec)
    lat = np.deg2rad(rec.meta["site"]["latitude_deg"])
    np.testing.assert_allclose(x["w_I"], 15.041067 * np.sin(lat), rtol=1e-6)
    np.testing.assert_allclose(x["a_I"], rec.meta["site"]["gravity_mps2"] / 9.80665, rtol=1e-12)
    np.testing.assert_allclose([x["a_O"], x["a_S"], x["w_O"]], 0.0, atol=1e-12)


def test_power_is_the_noncentral_chi2_tail_at_the_first_holm_step():
    crit = stats.chi2.isf(0.01 / 30, 1)
    assert pw.power(50.0, 1, 0.01, 30, margin=1.0) == pytest.approx(stats.ncx2.sf(crit, 1, 50.0))
    assert pw.power(100.0, 1, 0.01, 30) == pytest.approx(pw.power(50.0, 1, 0.01, 30, margin=1.0))  # half of λ
    z = stats.norm.isf(0.01 / 30 / 2)  # χ²₁(λ) > z² ⇔ |N(√λ, 1)| > z
    assert pw.power(50.0, 1, 0.01, 30, margin=1.0) == pytest.approx(
        stats.norm.sf(z - np.sqrt(50)) + stats.norm.cdf(-z - np.sqrt(50))
    )
    assert pw.margin("bias_temperature") == pw.SLOW_MARGIN < pw.margin("D_O") == pw.MARGIN <= 1.0
