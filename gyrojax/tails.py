"""Tails and quantiles of the χ², F, t and normal laws, and log tails of the χ² and F laws that never underflow.

``scipy.stats.chi2.logsf`` and ``scipy.stats.f.logsf`` take the log of a survival function computed in double
precision, so beyond p ≈ 1e-308 they return −inf: a strong missing effect (a score statistic of ~1800 on one degree of
freedom) would print ``log10_p`` null and tie with every other underflowed candidate. Here the tail is evaluated in
log space by the continued fractions of the regularised incomplete gamma and beta functions (Abramowitz & Stegun
6.5.31 and 26.5.8, evaluated by the modified Lentz method) wherever scipy's value is not finite; elsewhere scipy's
value is returned as it is.

scipy's values are taken from ``scipy.special`` as ``scipy.stats`` evaluates them (the same functions, the same
branches, so the same bits), without importing ``scipy.stats`` (a costly import for a command-line process). Every
module takes its tails and quantiles from here.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special

_EPS = 1e-15
_TINY = 1e-300
_MAX_TERMS = 10_000


def _lentz(a_of, b_of, b0: float) -> float:
    """The continued fraction b0 + a1/(b1 + a2/(b2 + …)) by the modified Lentz method; ``a_of(i)``, ``b_of(i)`` the
    i-th partial numerator and denominator (i ≥ 1)."""
    f = b0 if b0 != 0 else _TINY
    c, d = f, 0.0
    for i in range(1, _MAX_TERMS):
        a, b = a_of(i), b_of(i)
        d = b + a * d
        d = 1.0 / (d if d != 0 else _TINY)
        c = b + a / c
        c = c if c != 0 else _TINY
        step = c * d
        f *= step
        if abs(step - 1.0) < _EPS:
            return f
    raise ArithmeticError("continued fraction did not converge")  # not reached in the tail these are used for


def log_upper_gamma(s: float, z: float) -> float:
    """ln Q(s, z) = ln Γ(s, z)/Γ(s), the regularised upper incomplete gamma, for z > s + 1 (A&S 6.5.31:
    Γ(s, z) = e^{−z} z^s · 1/(z + 1 − s − 1·(1 − s)/(z + 3 − s − 2·(2 − s)/(z + 5 − s − …))))."""
    cf = _lentz(lambda i: -i * (i - s), lambda i: z + 2 * i + 1 - s, z + 1 - s)
    return -z + s * math.log(z) - math.log(cf) - special.gammaln(s)


def log_incomplete_beta(x: float, a: float, b: float) -> float:
    """ln I_x(a, b), the regularised incomplete beta, for x < (a + 1)/(a + b + 2) (A&S 26.5.8:
    I_x(a, b) = x^a (1 − x)^b / (a B(a, b)) · 1/(1 + d1/(1 + d2/(1 + …))),
    d_{2m+1} = −(a + m)(a + b + m) x / ((a + 2m)(a + 2m + 1)), d_{2m} = m (b − m) x / ((a + 2m − 1)(a + 2m)))."""

    def d(i: int) -> float:
        m = i // 2
        if i % 2:
            return -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1))
        return m * (b - m) * x / ((a + 2 * m - 1) * (a + 2 * m))

    cf = _lentz(d, lambda i: 1.0, 1.0)
    return a * math.log(x) + b * math.log1p(-x) - math.log(a) - special.betaln(a, b) - math.log(cf)


def _log_sf(x, shape_ok, median, sf, cdf):
    """ln P(X > x) of a law on [0, ∞) as ``scipy.stats``' continuous laws evaluate it: ln sf(x) above the median,
    ln(1 − cdf(x)) at or below it; 0 at or below 0, −∞ at +∞, NaN where x is NaN or a shape parameter is not
    admissible (``shape_ok`` False)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.where(x > median, np.log(sf), np.log1p(-cdf))
    v = np.where(x <= 0, 0.0, np.where(np.isposinf(x), -np.inf, v))
    return np.where(np.isnan(x) | ~shape_ok, np.nan, v)


def chi2_log_sf(x, df):
    """``scipy.stats.chi2.logsf(x, df)`` from ``scipy.special`` (module doc): median 2·P⁻¹(df/2, ½)."""
    x, df = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(df, dtype=float))
    with np.errstate(invalid="ignore"):
        median = 2 * special.gammaincinv(df / 2, 0.5)
        return _log_sf(x, df > 0, median, special.chdtrc(df, x), special.chdtr(df, x))


def f_log_sf(x, dfn, dfd):
    """``scipy.stats.f.logsf(x, dfn, dfd)`` from ``scipy.special`` (module doc)."""
    x, dfn, dfd = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, dfn, dfd)))
    with np.errstate(invalid="ignore"):
        median = special.fdtri(dfn, dfd, 0.5)
        return _log_sf(x, (dfn > 0) & (dfd > 0), median, special.fdtrc(dfn, dfd, x), special.fdtr(dfn, dfd, x))


def f_sf(x, dfn, dfd):
    """P(F_{dfn, dfd} > x), ``scipy.stats.f.sf`` from ``scipy.special.fdtrc`` (1 at or below 0)."""
    x = np.asarray(x, dtype=float)
    with np.errstate(invalid="ignore"):
        return np.where(x <= 0, 1.0, special.fdtrc(dfn, dfd, x))


def chi2_isf(p, df):
    """The χ²_df value exceeded with probability p (0 < p < 1), ``scipy.stats.chi2.isf``: ``scipy.special.chdtri``."""
    return special.chdtri(df, p)


def chi2_sf(x, df):
    """P(χ²_df > x), ``scipy.stats.chi2.sf`` from ``scipy.special.chdtrc`` (1 at or below 0)."""
    x = np.asarray(x, dtype=float)
    with np.errstate(invalid="ignore"):
        return np.where(x <= 0, 1.0, special.chdtrc(df, x))


def chi2_ppf(q, df):
    """The χ²_df quantile at q (0 < q < 1), ``scipy.stats.chi2.ppf``: 2·P⁻¹(df/2, q)."""
    return 2 * special.gammaincinv(np.asarray(df, dtype=float) / 2, q)


def chi2_pdf(x, df):
    """The χ²_df density at x > 0, ``scipy.stats.chi2.pdf``: exp((df/2 − 1) ln x − x/2 − ln Γ(df/2) − (df/2) ln 2)."""
    x, df = np.asarray(x, dtype=float), np.asarray(df, dtype=float)
    return np.exp(special.xlogy(df / 2.0 - 1, x) - x / 2.0 - special.gammaln(df / 2.0) - (np.log(2) * df) / 2.0)


def score_power(lam, df, alpha):
    """Power of the χ²_df score test at level ``alpha`` for noncentrality ``lam`` (dimensionless): the noncentral χ²
    tail above the central law's 1 − α quantile (``scipy.stats.ncx2``, imported on first use)."""
    from scipy import stats

    return float(stats.ncx2.sf(chi2_isf(alpha, df), df, lam))


def t_sf(x, df):
    """P(t_df > x), ``scipy.stats.t.sf``: ``scipy.special.stdtr(df, −x)``."""
    return special.stdtr(df, -np.asarray(x, dtype=float))


def t_ppf(q, df):
    """The t_df quantile at q (0 < q < 1), ``scipy.stats.t.ppf``: ``scipy.special.stdtrit``."""
    return special.stdtrit(df, q)


def norm_sf(x):
    """P(Z > x) of the standard normal law, ``scipy.stats.norm.sf``: ``scipy.special.ndtr(−x)``."""
    return special.ndtr(-np.asarray(x, dtype=float))


def norm_ppf(q):
    """The standard normal quantile at q (0 < q < 1), ``scipy.stats.norm.ppf``: ``scipy.special.ndtri``."""
    return special.ndtri(q)


def norm_isf(q):
    """The standard normal value exceeded with probability q, ``scipy.stats.norm.isf``: −``scipy.special.ndtri(q)``."""
    return -special.ndtri(q)


def norm_cdf(x):
    """P(Z ≤ x) of the standard normal law, ``scipy.stats.norm.cdf``: ``scipy.special.ndtr``."""
    return special.ndtr(np.asarray(x, dtype=float))


def norm_pdf(x):
    """The standard normal density, ``scipy.stats.norm.pdf``: exp(−x²/2)/√(2π)."""
    x = np.asarray(x, dtype=float)
    return np.exp(-(x**2) / 2.0) / np.sqrt(2 * np.pi)


def chi2_logsf(x: float, df: float) -> float:
    """ln P(χ²_df > x), finite however far in the tail (module doc)."""
    v = float(chi2_log_sf(x, df))
    if math.isfinite(v) or not math.isfinite(x) or x <= df + 2:
        return v
    return log_upper_gamma(df / 2.0, x / 2.0)


def f_logsf(x: float, dfn: float, dfd: float) -> float:
    """ln P(F_{dfn, dfd} > x), finite however far in the tail (module doc): P = I_w(dfd/2, dfn/2) with
    w = dfd/(dfd + dfn·x)."""
    v = float(f_log_sf(x, dfn, dfd))
    if math.isfinite(v) or not math.isfinite(x) or x <= 0:
        return v
    a, b = dfd / 2.0, dfn / 2.0
    w = dfd / (dfd + dfn * x)
    if w >= (a + 1.0) / (a + b + 2.0):  # not in the tail (scipy is finite there): the fraction would converge slowly
        return v
    return log_incomplete_beta(w, a, b)


def f_logsf_many(x, dfn, dfd: float) -> list[float]:
    """:func:`f_logsf` of each ``x`` (with its ``dfn``; dimensionless): scipy called once on the arrays (one call
    per candidate cost more in overhead than in arithmetic), the continued fraction only where scipy's value is not
    finite."""
    x, dfn = np.asarray(x, dtype=float), np.asarray(dfn, dtype=float)
    if x.size == 0:
        return []
    v = np.atleast_1d(f_log_sf(x, dfn, dfd))
    return [float(a) if math.isfinite(a) else f_logsf(float(b), float(n), dfd) for a, b, n in zip(v, x, dfn)]
