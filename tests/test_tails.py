"""The χ² and F log tails of the diagnosis (gyrojax.tails) against closed forms nobody here wrote: χ²₁ by
scipy's log_ndtr (P = 2Φ(−√x)), χ²₂ exactly −x/2, F(2, d) exactly −(d/2)·ln(1 + 2x/d), and scipy itself where its
value is finite; far beyond where scipy's logsf returns −inf."""

import math

import numpy as np
import pytest
from scipy import special, stats

from gyrojax.tails import chi2_logsf, f_logsf, f_logsf_many, log_incomplete_beta, log_upper_gamma

REL = 1e-12  # continued fractions stop at 1e-15 per step; a few hundred steps and the logs of Γ, B keep this


@pytest.mark.parametrize("x", [50.0, 300.0, 1818.0, 5e3, 1e5, 1e7])
def test_chi2_tails_match_closed_forms(x):
    one = float(special.log_ndtr(-math.sqrt(x))) + math.log(2.0)
    assert chi2_logsf(x, 1) == pytest.approx(one, rel=REL)
    assert log_upper_gamma(0.5, x / 2) == pytest.approx(one, rel=REL)
    assert chi2_logsf(x, 2) == pytest.approx(-x / 2, rel=REL)
    assert math.isfinite(chi2_logsf(x, 7))


@pytest.mark.parametrize("x", [50.0, 1000.0, 1818.0, 1e5])
@pytest.mark.parametrize("d", [50.0, 8600.0, 1e6])
def test_f_tails_match_closed_form_of_two_numerator_dof(x, d):
    exact = -(d / 2) * math.log1p(2 * x / d)
    assert f_logsf(x, 2, d) == pytest.approx(exact, rel=REL)
    w = d / (d + 2 * x)
    if w < (d / 2 + 1) / (d / 2 + 3):
        assert log_incomplete_beta(w, d / 2, 1.0) == pytest.approx(exact, rel=REL)


def test_scipy_is_kept_where_finite_and_the_tail_continues_it():
    """Where scipy's logsf is finite it is returned unchanged; across the point where it underflows the tail is
    smooth (the fraction agrees with scipy in the deep but finite tail, where both are computed)."""
    for df, dfd in ((1, 8600.0), (4, 8600.0), (3, 400.0)):
        xs = np.geomspace(5.0, 5e3, 60)
        ours = np.array([f_logsf(x, df, dfd) for x in xs])
        theirs = stats.f.logsf(xs, df, dfd)
        fin = np.isfinite(theirs)
        assert np.array_equal(ours[fin], theirs[fin])
        assert np.all(np.isfinite(ours)) and np.all(np.diff(ours) < 0)
        deep = fin & (theirs < -200)
        for x in xs[deep]:
            w = dfd / (dfd + df * x)
            assert log_incomplete_beta(w, dfd / 2, df / 2) == pytest.approx(stats.f.logsf(x, df, dfd), rel=1e-10)
        for x in (20.0, 60.0, 400.0):
            assert log_upper_gamma(df / 2, x / 2) == pytest.approx(stats.chi2.logsf(x, df), rel=1e-10)


def test_a_strong_candidate_has_a_finite_log10_p():
    """A score statistic of ~1800 on one degree of freedom (the D_IS campaign of test_diagnose) has p ≈ 1e-360:
    its log10 p is finite, so the JSON holds a number (not null) and the ranking compares it."""
    v = f_logsf(1818.24, 1, 8600.0) / math.log(10)
    assert math.isfinite(v) and -400 < v < -300


def test_the_batched_f_tail_is_the_scalar_one():
    """:func:`f_logsf_many` (one scipy call for a diagnosis' candidates) returns exactly what :func:`f_logsf` returns
    for each, on both sides of where scipy underflows, with mixed numerator degrees of freedom and a zero."""
    xs = np.concatenate([np.geomspace(0.01, 5e3, 40), [0.0, 1818.24]])
    dfn = np.resize([1, 2, 3, 6], xs.size)
    many = f_logsf_many(xs, dfn, 8600.0)
    assert many == [f_logsf(float(x), float(n), 8600.0) for x, n in zip(xs, dfn)]
    assert np.all(np.isfinite(many)) and not np.all(np.isfinite(stats.f.logsf(xs, dfn, 8600.0)))
    assert f_logsf_many([], [], 10.0) == []


def test_the_laws_from_scipy_special_are_scipy_stats_bit_for_bit():
    """The tails and quantiles taken from scipy.special (no scipy.stats import) are scipy.stats' own values, bit for
    bit, on both sides of the median and at the support's edges (0, below 0, +∞, NaN)."""
    from gyrojax import tails

    rng = np.random.default_rng(0)
    x = np.concatenate([[0.0, -1.0, -0.0, np.inf, np.nan, 1e-300, 1e300], 10 ** rng.uniform(-6, 4, 3000)])
    df = np.concatenate([np.ones(7), rng.integers(1, 400, 3000)])
    dfd = 10 ** rng.uniform(0, 4, x.size)
    t = np.concatenate([[0.0, np.inf, -np.inf, np.nan], rng.standard_normal(3000) * 10])
    nu = np.concatenate([np.ones(4), 10 ** rng.uniform(0, 6, 3000)])
    q = rng.uniform(0.001, 0.999, nu.size)
    pairs = [
        (tails.chi2_log_sf(x, df), stats.chi2.logsf(x, df)),
        (tails.f_log_sf(x, df, dfd), stats.f.logsf(x, df, dfd)),
        (tails.f_log_sf(x, df, 37.5), stats.f.logsf(x, df, 37.5)),
        (tails.f_sf(x, df, dfd), stats.f.sf(x, df, dfd)),
        (tails.t_sf(t, nu), stats.t.sf(t, nu)),
        (tails.norm_sf(t), stats.norm.sf(t)),
        (tails.t_ppf(q, nu), stats.t.ppf(q, nu)),
        (tails.norm_ppf(q), stats.norm.ppf(q)),
        (tails.chi2_isf(q, df[: q.size]), stats.chi2.isf(q, df[: q.size])),
        (tails.chi2_sf(x, df), stats.chi2.sf(x, df)),
        (tails.chi2_ppf(q, df[: q.size]), stats.chi2.ppf(q, df[: q.size])),
        (tails.chi2_pdf(x[7:], df[7:]), stats.chi2.pdf(x[7:], df[7:])),
        (tails.norm_isf(q), stats.norm.isf(q)),
        (tails.norm_cdf(t), stats.norm.cdf(t)),
        (tails.norm_pdf(np.delete(t, 3)), stats.norm.pdf(np.delete(t, 3))),  # NaN in: a NaN of another sign bit
    ]
    for i, (got, want) in enumerate(pairs):
        np.testing.assert_array_equal(np.asarray(got).view(np.int64), np.asarray(want).view(np.int64), err_msg=str(i))
