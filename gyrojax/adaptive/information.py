"""Fisher information of the records so far and of a candidate test, on one *universe* of effects.

The universe U holds the current model, the watched candidates and any alias group: every requirement
(:mod:`gyrojax.adaptive.requirements`) is a σ read in a sub-model of U, so one information matrix serves them all.

*The records.* F_rec = Σ_r J_rᵀ J_r Δt/(60 N_r)² / κ (:func:`gyrojax.planning.fisher.record_fisher`, record by
record), J_r the Jacobian of the measurement model on U, N_r the record's white noise as the fit estimated it
(deg/√h; the current fit, or the fit of the whole universe when the current one finds colour that may be a missing
effect's misfit: :func:`gyrojax.adaptive.step.next_test`). A fit's standard errors are honest under coloured drift
(GLS, Student-t widening); the white-noise information is not, so it is divided by κ ≥ 1, the median over that
fit's coefficients of (σ_fit/σ_F)², σ_F the standard error the white-noise information predicts for the same
model: the prediction then agrees with what the fit states.

*A candidate test.* Static positions held T_k seconds, the k-th starting at the campaign time of the test's start
plus its predecessors and gaps: F_new = Σ_channels Hᵀ Σ⁻¹ H, H the regressor rows of the positions at the
mounting and angles tried (:func:`gyrojax.physics.model.jacobian`), Σ the covariance of the position means under
the fitted noise (white, Gauss–Markov; :meth:`gyrojax.noise.spec.NoiseSpec.mean_covariance`), as
:func:`gyrojax.planning.fisher.static_fisher` does, with the mounting, the positions' campaign times (for a trend
term) and θ as arguments so that the search can ``vmap`` over mountings and posterior draws.
"""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.noise.spec import NoiseSpec
from gyrojax.noise.whiten import first_difference_std
from gyrojax.physics.kept_model import kept_jit
from gyrojax.physics.model import Model, jacobian
from gyrojax.planning.fisher import Table, position_times, record_fisher


def record_white(record) -> float:
    """White noise N (deg/√h) of a record from the first differences of its output within segments: the fallback
    when no fit states it (a model the records cannot identify)."""
    y = np.asarray(record.indicated, dtype=float)
    y = y[:, 0] if y.ndim == 2 else y  # a TDF gyro: its X channel
    dt = float(np.median(np.diff(record.time_s))) if record.n > 1 else 1.0
    return max(first_difference_std(y, record.segment_id), 1e-12) * np.sqrt(dt) / 60.0


def record_information(universe: Model, records, fit=None, theta=None) -> tuple[np.ndarray, float]:
    """(F_rec, κ) on ``universe`` (module doc), report units; ``fit`` the current fit (its noise and σ; None: the
    white noise of each record from its first differences and κ = 1; coefficients the fit leaves without a finite σ
    do not enter κ); ``theta`` (universe order, report units) the
    point of the Jacobian for nonlinear effects (default 0)."""
    whites = [float(nz.white) for nz in fit.noise] if fit is not None else [record_white(r) for r in records]
    whites = [w if w > 0 else record_white(r) for w, r in zip(whites, records)]
    th = np.zeros(universe.size) if theta is None else np.asarray(theta, dtype=float)
    f = np.zeros((universe.size, universe.size))
    for r, w in zip(records, whites):
        f += record_fisher(universe, [r], NoiseSpec(white=w), th)
    kappa = 1.0
    if fit is not None:
        idx = [universe.coefficient_names.index(c) for c in fit.model.coefficient_names]
        sub = f[np.ix_(idx, idx)]
        d = np.sqrt(np.maximum(np.diag(sub), 1e-300))
        # estimable coefficients: e_iᵀ F⁺ e_i is their variance also where others are aliased
        pred = np.diag(np.linalg.pinv(sub / np.outer(d, d), rcond=1e-10, hermitian=True)) / d**2
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.asarray(fit.std, dtype=float) ** 2 / pred
        ratio = ratio[np.isfinite(ratio) & (ratio > 0)]
        kappa = max(1.0, float(np.median(ratio))) if ratio.size else 1.0
    return f / kappa, kappa


RESOLVED_CORRELATION_TIMES = 10.0
"""Correlation times τ a Gauss–Markov term must fit in the records' longest continuous segment to be resolved."""


def longest_segment_s(records) -> float:
    """The longest continuous segment (s) of the records: the span over which a correlation time can be seen."""
    out = 0.0
    for r in records:
        t, seg = np.asarray(r.time_s, dtype=float), np.asarray(r.segment_id)
        for s in np.unique(seg):
            ts = t[seg == s]
            out = max(out, float(ts[-1] - ts[0]) if ts.size else 0.0)
    return out


def test_noise(fit, records) -> tuple[NoiseSpec, tuple]:
    """(noise, unresolved) of a new static test: the fitted white noise (rms over the records) and the first
    Gauss–Markov term the fit found, if it is *resolved* — τ at most the records' longest continuous segment over
    :data:`RESOLVED_CORRELATION_TIMES` — in deg/√h and (deg/h, s); ``unresolved`` the (σ, τ) left out. Over a few
    correlation times a record cannot tell a slow drift from chance structure (the relative error of the drift's
    low-frequency power σ²τ is about √(2τ/T) over a span T), and for the long dwells of a test that power is all
    that matters (a position mean over T ≫ τ has variance 2σ²τ/T): an unresolved term would set the test's hours
    from one noisy number. The next test's records, fitted with all before, resolve it or not."""
    if fit is None:
        return NoiseSpec(white=float(np.sqrt(np.mean([record_white(r) ** 2 for r in records])))), ()
    whites = [float(nz.white) for nz in fit.noise if nz.white > 0] or [record_white(r) for r in records]
    gm = next((tuple(nz.gauss_markov) for nz in fit.noise if nz.gauss_markov), ())[:1]
    span = longest_segment_s(records)
    unresolved = tuple((float(s), float(tau)) for s, tau in gm if tau * RESOLVED_CORRELATION_TIMES > span)
    gm = tuple(x for x in gm if (float(x[0]), float(x[1])) not in unresolved)
    return NoiseSpec(white=float(np.sqrt(np.mean(np.square(whites)))), gauss_markov=gm), unresolved


def rows(universe: Model, table, triad, angles_rad, times_s, theta):
    """Regressor rows (channels, n, p) of static positions ``angles_rad`` (n, k) of ``table`` (a
    :class:`gyrojax.planning.fisher.Table`) at mounting ``triad`` (3, 3), read at campaign times ``times_s`` (n,) s,
    at θ = ``theta`` (universe order, report units); traceable."""
    n = angles_rad.shape[0]
    data = replace(table.positions_data(angles_rad), triad=triad, time_s=times_s)
    return jacobian(universe, jnp.asarray(theta, dtype=jnp.float64), data).reshape(-1, n, universe.size)


def test_information(universe: Model, table, noise: NoiseSpec, triad, angles_rad, dwell_s, start_s, gap_s, theta):
    """F_new (p, p) of static positions ``angles_rad`` (n, k) held ``dwell_s`` (n,) s at mounting ``triad`` (3, 3),
    the first starting at campaign time ``start_s`` (s), ``gap_s`` s apart, at θ = ``theta`` (universe order, report
    units); ``table`` a :class:`gyrojax.planning.fisher.Table`. Traceable in every array argument."""
    dwell = jnp.asarray(dwell_s, dtype=jnp.float64)
    starts = position_times(dwell, gap_s)
    h = rows(universe, table, triad, angles_rad, start_s + starts + 0.5 * dwell, theta)
    chol = jnp.linalg.cholesky(noise.mean_covariance(starts, dwell))
    w = jax.vmap(lambda x: jax.scipy.linalg.solve_triangular(chol, x, lower=True))(h)
    return jnp.einsum("cnp,cnq->pq", w, w)


@lru_cache(maxsize=16)
def compiled_information(universe: Model, noise: NoiseSpec):
    """:func:`test_information` of ``universe`` and ``noise`` compiled (kept across processes,
    :func:`gyrojax.physics.kept_model.kept_jit`): f(template, triad, angles_rad, dwell_s, start_s, gap_s, theta), the
    table given by its template record (:class:`gyrojax.planning.fisher.Table`)."""

    def f(template, triad, angles_rad, dwell_s, start_s, gap_s, theta):
        table = Table.of_template(template)
        return test_information(universe, table, noise, triad, angles_rad, dwell_s, start_s, gap_s, theta)

    return kept_jit("test_information", universe, f, noise)
