"""The statistics of a diagnosis, written once for every instrument: the score test, Holm's step-down procedure, the
order of the evidence and the aliases between candidates.

**Score test.** With the model's whitened regressors J₀ and a candidate's (or a shape's) whitened regressors X,

    X⊥ = X − P₀ X,    S = r̃ᵀ X⊥ (X⊥ᵀ X⊥)⁺ X⊥ᵀ r̃ / σ̃²,   S / k  ~  F(k, ν)   under "the effect is absent",

P₀ the projection on the columns the test is made beside, k = rank X⊥ and σ̃² the variance of the whitened residual
r̃ᵀ(I − P₀)r̃ / ν with ν = n − rank J₀ degrees of freedom: F(k, ν), which tends to χ²(k) for long records and does not
overstate significance for short ones (the small-sample logic of the fit's Student-t p-values). A test whose σ̃² comes
from elsewhere (after every shape, where no deterministic structure can inflate it) is referred to χ²(k). One
Jacobian of the model extended by every candidate, evaluated at (θ̂, 0), serves them all: no refit per candidate.

**Holm** adjusts the p-values of a family of tests for testing them all at once, in log form, so that p-values below
the float range still order and adjust. **Aliases**: two candidates whose X⊥ are collinear (a canonical
correlation above :data:`COLLINEAR`) cannot be told apart in this plan; a candidate whose X⊥ vanishes is a
combination of the model's own regressors (:data:`UNSEEN`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gyrojax.inference.lstsq import lstsq
from gyrojax.inference.subspace import UNSEEN, basis, perp, perp_basis
from gyrojax.inference.verdict import Candidate
from gyrojax.physics import effects as fx
from gyrojax.tails import chi2_logsf, f_logsf_many

ALPHA = 0.01
"""The significance level of every decision the diagnosis takes (family-wise, Holm) and of the fit's per-coefficient
``significant`` flag: one level, reported in both JSONs as ``alpha``."""
COLLINEAR = 0.999
"""Canonical correlation above which two candidates are aliases in this plan."""
DIRECTION_TOL = 1e-7
"""A direction of X⊥ shorter than this fraction of X's own columns is rounding, not a direction the data can show."""
SPAN_WEIGHT = 1e-3
"""A model column whose weight in the least-squares fit to a spanned candidate exceeds this fraction of the largest
names an alias of that candidate."""
_RCOND = float(np.finfo(float).eps)  # per row or column: LAPACK's default cut of a least-squares solve
TIE_RTOL = 1e-9
"""Relative difference of log10 p below which two candidates tie: exact aliases (D_II and D_SS in a 1 g tumble) have
equal statistics whose last digits depend on the BLAS threads and on whether the records were read from CSV."""


@dataclass(frozen=True)
class Score:
    """The score test of one set of regressors X (k columns): ``statistic`` ~ χ²(``df``) or ``df`` · F(``df``, ν),
    ``log10_p``; ``basis`` the orthonormal basis of X⊥ (dimensionless; empty when X lies in the model's span, then
    ``df`` is 0 and ``spanned_by`` holds the model columns that span it); ``coefficients`` β̂ (k,) of X⊥ fitted to
    r̃⊥, the one-step estimate in X's units; ``model_part`` B (p₀, k), the model's least-squares fit to X."""

    statistic: float
    df: int
    log10_p: float
    basis: np.ndarray
    coefficients: np.ndarray | None = None
    model_part: np.ndarray | None = None
    spanned_by: tuple = ()

    @property
    def p_value(self) -> float:
        """The unadjusted p-value (0 where it underflows; :attr:`log10_p` does not)."""
        return 10.0**self.log10_p


@dataclass(frozen=True)
class ScoreTests:
    """The score tests of several regressor sets against one whitened residual: ``scores[i]`` for ``xs[i]`` (None
    where X is zero: not excited), and the residual variance σ̃² with its ``dof`` degrees of freedom."""

    scores: list
    sigma2: float
    dof: int


def residual_variance(u: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, float, int]:
    """(r̃⊥ = r̃ − U Uᵀ r̃, σ̃² = |r̃⊥|² / ν, ν = n − rank U ≥ 1) beside the orthonormal columns ``u``."""
    r_perp = perp(u, r)
    dof = max(len(r) - u.shape[1], 1)
    return r_perp, float(r_perp @ r_perp) / dof, dof


def log10_p(statistic: float, df: int, dof: int | None = None) -> float:
    """log10 of the upper tail of S ~ χ²(df) (``dof`` None) or S/df ~ F(df, ``dof``), finite however far."""
    if dof is None:
        return float(chi2_logsf(statistic, df)) / math.log(10)
    return f_logsf_many([statistic / df], [df], dof)[0] / math.log(10)


def score(
    u: np.ndarray, r_perp: np.ndarray, x: np.ndarray, sigma2: float, dof: int | None = None, tol: float = DIRECTION_TOL
) -> Score | None:
    """The score test of ``x`` (n, k) beside the orthonormal columns ``u`` (module doc): r̃⊥ is the residual
    orthogonal to ``u``, σ̃² its variance with ``dof`` degrees of freedom (None: σ̃² from elsewhere, χ² law);
    directions of X⊥ below ``tol`` of X's columns are not tested. None when X⊥ has no direction."""
    uc = perp_basis(u, x, tol=tol)
    if uc.shape[1] == 0:
        return None
    proj = uc.T @ r_perp
    stat = float(proj @ proj) / sigma2
    return Score(stat, uc.shape[1], log10_p(stat, uc.shape[1], dof), uc)


def score_tests(r: np.ndarray, j0: np.ndarray, xs: list) -> ScoreTests:
    """The score test (F law) of each regressor set ``xs[i]`` (n, k_i) beside the model's regressors ``j0`` (n, p₀),
    all whitened alike, against the whitened residual ``r`` at the fit (module doc)."""
    u0 = basis(j0)
    r_perp, sigma2, dof = residual_variance(u0, r)
    widths = [x.shape[1] for x in xs]
    x_all = np.column_stack(xs) if xs else np.zeros((len(r), 0))
    # the model's least-squares fit to every candidate column at once (one factorisation of J₀, many right sides)
    b_all = lstsq(j0, x_all, rank_tol=_RCOND * max(j0.shape))[0] if j0.shape[1] else np.zeros((0, x_all.shape[1]))
    col_norms = np.sqrt((j0 * j0).sum(axis=0))
    scores, pending = [], []
    for x, lo, k in zip(xs, np.cumsum([0] + widths[:-1]), widths):
        xn = float(np.sqrt((x * x).sum()))
        if xn == 0.0:
            scores.append(None)
            continue
        b = b_all[:, lo : lo + k]
        xp = perp(u0, x)
        if float(np.sqrt((xp * xp).sum())) / xn < UNSEEN:
            weight = np.abs(b).max(axis=1) * col_norms
            spanned = tuple(int(i) for i in np.flatnonzero(weight > SPAN_WEIGHT * weight.max()))
            scores.append(Score(0.0, 0, 0.0, np.zeros((len(r), 0)), None, b, spanned))
            continue
        uc = perp_basis(u0, x, tol=DIRECTION_TOL)
        proj = uc.T @ r_perp
        # β̂ of minimum norm over the directions the test sees: X⊥ = U_c C, so C β = U_cᵀ r̃⊥ (a direction of X below
        # DIRECTION_TOL of its columns is rounding, whatever its own scale, and gets no coefficient)
        c = uc.T @ xp
        beta = c.T @ np.linalg.solve(c @ c.T, proj)
        scores.append(Score(float(proj @ proj) / sigma2, uc.shape[1], 0.0, uc, beta, b))
        pending.append(len(scores) - 1)
    # σ̃² estimated with ν degrees of freedom: F(k, ν) tails, all in one call
    logs = f_logsf_many([scores[i].statistic / scores[i].df for i in pending], [scores[i].df for i in pending], dof)
    for i, lp in zip(pending, logs):
        s = scores[i]
        scores[i] = Score(s.statistic, s.df, lp / math.log(10), s.basis, s.coefficients, s.model_part)
    return ScoreTests(scores, sigma2, dof)


def score_beside(r: np.ndarray, j0: np.ndarray, x: np.ndarray, others: list) -> Score | None:
    """The score test (F law) of ``x`` beside the model's columns ``j0`` and the regressors ``others`` (stronger
    candidates, unexplained shapes), all whitened alike, σ̃² after them all: whether a candidate still holds when
    what explains the residual better is in the model. None when X has no direction beside them."""
    u = basis(np.column_stack([j0, *others])) if others else basis(j0)
    r_perp, sigma2, dof = residual_variance(u, r)
    return score(u, r_perp, x, sigma2, dof)


def rms_after(r_raw: np.ndarray, j0_raw: np.ndarray, x_raw: np.ndarray, s: Score) -> float:
    """The RMS of the raw residual ``r_raw`` after adding the candidate with its one-step estimate: the candidate's
    raw regressors ``x_raw`` less the model's fit to them, multiplied by β̂ (in units of the residual: deg/h for
    gyros, g for accelerometers)."""
    if not len(r_raw):
        return float("nan")
    delta = (x_raw - j0_raw @ s.model_part) @ s.coefficients
    return float(np.sqrt(np.mean((r_raw - delta) ** 2)))


def candidates(names: list, tests: ScoreTests, coefficients: list, units: list, raw: tuple, aliases, rms_spanned):
    """The :class:`~gyrojax.inference.verdict.Candidate` of each score test ``tests.scores[i]`` of ``names[i]`` (None
    where not excited), and the orthonormal basis of each tested candidate's X⊥ (name -> basis). A candidate in the
    model's span has df 0, the ``aliases(spanned_by)`` that span it and ``rms_spanned``; the others their statistic,
    p-value, one-step estimate (``coefficients[i]`` -> value in ``units[i]``) and :func:`rms_after` from ``raw`` =
    (raw residual, the model's raw regressors, [each candidate's raw regressors])."""
    out, perps = [], {}
    for i, (name, sc) in enumerate(zip(names, tests.scores)):
        if sc is None or sc.df == 0:
            out.append(None if sc is None else Candidate(name, 0.0, 0, 1.0, 1.0, aliases(sc.spanned_by), rms_spanned))
            continue
        rms = rms_after(raw[0], raw[1], raw[2][i], sc)
        est = {n: {"value": float(v), "unit": u} for n, v, u in zip(coefficients[i], sc.coefficients, units[i])}
        out.append(Candidate(name, sc.statistic, sc.df, sc.p_value, 1.0, [], rms, est, log10_p=sc.log10_p))
        perps[name] = sc.basis
    return out, perps


def holm_log10(log10_p) -> np.ndarray:
    """Holm step-down adjusted p-values, as log10 (so that p-values below the float range still order and adjust):
    adj_(i) = max_{j ≤ i} min(1, (m − j + 1) p_(j))."""
    lp = np.asarray(log10_p, dtype=float)
    m = len(lp)
    adj = np.empty(m)
    running = -np.inf
    for rank, i in enumerate(np.argsort(lp, kind="stable")):
        running = max(running, min(0.0, math.log10(m - rank) + lp[i]))
        adj[i] = running
    return adj


def collinear(a: np.ndarray, b: np.ndarray, level: float = COLLINEAR) -> bool:
    """Whether the spans of the orthonormal ``a`` and ``b`` share a direction (largest canonical correlation above
    ``level``)."""
    s = np.linalg.svd(a.T @ b, compute_uv=False)
    return bool(s.size and s[0] > level)


def alias_pairs(perps: dict) -> list[tuple[str, str]]:
    """The pairs of names whose X⊥ (``perps``: name -> orthonormal basis, in order) are collinear."""
    names = list(perps)
    return [(a, b) for i, a in enumerate(names) for b in names[i + 1 :] if collinear(perps[a], perps[b])]


def spanned(perps: dict, name: str, taken: list) -> bool:
    """Whether ``name`` is in ``taken``, or its X⊥ lies in the span of those of ``taken`` (every canonical
    correlation above :data:`COLLINEAR`: an exact alias of what was taken, D_II after D_SS in a 1 g tumble): taking
    it would leave the noise fit's column space as it is."""
    if name in taken:
        return True
    if name not in perps or not taken or any(e not in perps for e in taken):
        return False
    u = perps[name]
    span = basis(np.column_stack([perps[e] for e in taken]))
    s = np.linalg.svd(u.T @ span, compute_uv=False)
    return bool(u.shape[1] and s.size >= u.shape[1] and s[u.shape[1] - 1] > COLLINEAR)


def by_evidence(cands: list, kind: str) -> list:
    """Candidates by evidence, strongest first: log10 p (never underflows; 0 for the untested), then the statistic;
    ties within :data:`TIE_RTOL` (exact aliases) in the order of :func:`gyrojax.physics.effects.names`, so that the
    proposal between aliases is the same on every machine and every reading of the same data."""
    order = {n: i for i, n in enumerate(fx.names(kind))}
    key = lambda c: c.log10_p if c.df > 0 else 0.0  # noqa: E731
    ranked = sorted(cands, key=lambda c: (key(c), -c.statistic))
    out, i = [], 0
    while i < len(ranked):
        j = i + 1
        while j < len(ranked) and _tie(key(ranked[i]), key(ranked[j])):
            j += 1
        out += sorted(ranked[i:j], key=lambda c: order.get(c.name, len(order)))
        i = j
    return out


def _tie(a: float, b: float) -> bool:
    """Whether two log10 p tie (:data:`TIE_RTOL`); an underflowed −inf ties only with −inf."""
    if not (math.isfinite(a) and math.isfinite(b)):
        return a == b
    return abs(b - a) <= TIE_RTOL * max(abs(a), 1.0)
