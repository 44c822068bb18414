"""A knee along a recorded input: the profile that starts the fit of a hinged effect, and the sup-score test of one.

A hinged effect of the registry (``Effect.knee``: ``temperature_hinge``, seed 001's two slopes about 20 °C,
001 §5.1 steps 1)–4)) contributes D·|u − k| along an input u. Once the knee k is fixed the model is linear in D and
in every other linear coefficient, and k is seen only when D ≠ 0: at D = 0 its derivative −D·sign(u − k) vanishes.

**Profile** (:func:`profile_start`). For each knee of a grid over the input's recorded range (:func:`grid`), the
model is solved with the knee held; the knee of least weighted residual, with its solution, starts the fit's
Gauss–Newton (Levenberg–Marquardt with the exact JAX Jacobian, ∂/∂k = −D·sign(u − k)), whose covariance at the
answer states the knee's σ like any coefficient's.

**Sup score** (:func:`sup_score`; Davies 1977, Biometrika 64, 247–254; 1987, Biometrika 74, 33–43). With h̃⊥(k)
the whitened hinge column beside the model and r̃⊥ the whitened residual,

    z(k) = h̃⊥(k)ᵀ r̃⊥ / (σ̃ |h̃⊥(k)|)    ~ N(0, 1) at each k under "no hinge",

jointly Gaussian over the grid with the correlations C(k, k') of the normalised h̃⊥. The knee is not identified under
that null, so S = max_k z(k)² has no χ² law: its tail P(S ≥ s) is drawn from N(0, C) (:data:`DRAWS` draws, fixed
seed), and where the draws cannot resolve it, bounded above by Bonferroni over the grid, G·P(χ²₁ ≥ s). The p-value
is the smaller of the two, never a χ²₁ tail as if the knee were known.
"""

from __future__ import annotations

import math

import numpy as np

from gyrojax.errors import ModelError
from gyrojax.inference.campaign import linearize
from gyrojax.inference.solver import solve, stack_whitened
from gyrojax.inference.subspace import perp
from gyrojax.tails import chi2_logsf

KNEES = 41
"""Knees of the grid over the input's recorded range."""
QUANTILES = (0.05, 0.95)
"""The grid spans these quantiles of the recorded input, so that both slopes hold data at every knee."""
DRAWS = 20000
"""Draws of the Gaussian score process that give the sup score's null tail."""
SEED = 20090101
"""Seed of those draws: one diagnosis of one record gives one p-value."""


def input_values(records, name: str) -> np.ndarray:
    """The recorded values of the instrument input ``name`` over every record (``temperature_C``: °C);
    :class:`ModelError` naming the record that lacks it."""
    if name != "temperature_C":
        raise ModelError(f"a knee along {name!r} is not supported (only along temperature_C)")
    out = []
    for r in records:
        if r.temperature_C is None:
            raise ModelError(f"{r.path or r.name}: a knee along temperature_C needs that column, which is absent")
        out.append(np.asarray(r.temperature_C, dtype=float))
    return np.concatenate(out)


def grid(values: np.ndarray, knees: int = KNEES) -> np.ndarray:
    """Knees evenly spaced over the :data:`QUANTILES` of ``values`` (in their unit); :class:`ModelError` when the
    input does not vary (no knee can be seen)."""
    lo, hi = np.quantile(values, QUANTILES)
    if not hi > lo:
        raise ModelError("the input of a knee does not vary over the records: no knee can be fitted")
    return np.linspace(lo, hi, knees)


def profile_start(model, campaign, theta: np.ndarray, scales) -> np.ndarray:
    """θ with each hinged effect's knee (and the linear coefficients) at the least residual over the knee grid
    (module doc), each record weighted by 1 / ``scales[i]`` (its noise level, in the output unit): the fit's start."""
    th = np.asarray(theta, dtype=float).copy()
    sl = model.slices()
    for e in model.effects:
        if e.knee is None:
            continue
        ik = sl[e.name].stop - 1
        best = None
        for k in grid(input_values(campaign.records, e.knee)):
            th[ik] = k
            rw, jw = stack_whitened(linearize(model, th, campaign), [None] * len(scales), scales)
            jw[:, ik] = 0.0  # the knee is held; the rest is one linear solve (a Gauss–Newton step if set-up effects)
            step, _ = solve(jw, rw)
            e_ = rw - jw @ step
            rss = float(e_ @ e_)
            if best is None or rss < best[0]:
                best = (rss, k, step)
        _, k, step = best
        th = th + step
        th[ik] = k
    return th


def sup_score(u0: np.ndarray, r_perp: np.ndarray, h: np.ndarray, sigma2: float, draws: int = DRAWS):
    """The sup score of the hinge columns ``h`` (n, G), one per knee of the grid, beside the orthonormal columns
    ``u0``, against the whitened residual ``r_perp`` orthogonal to them with variance ``sigma2`` (module doc):
    (S, index of the knee of the sup, log10 p, the per-knee statistics z²). A knee whose column lies in the span of
    ``u0`` is not tested; None when none is left."""
    hp = perp(u0, h)
    nrm = np.sqrt((hp * hp).sum(axis=0))
    scale = np.sqrt((h * h).sum(axis=0))
    live = nrm > 1e-9 * np.maximum(scale, 1e-300)
    if not live.any():
        return None
    hp, nrm = hp[:, live], nrm[live]
    z = (hp.T @ r_perp) / (nrm * math.sqrt(sigma2))
    z2 = np.full(len(live), np.nan)
    z2[live] = z * z
    i = int(np.nanargmax(z2))
    stat = float(z2[i])
    corr = (hp.T @ hp) / np.outer(nrm, nrm)
    w, vec = np.linalg.eigh(corr)
    root = vec * np.sqrt(np.clip(w, 0.0, None))
    sim = np.random.default_rng(SEED).standard_normal((draws, len(w))) @ root.T
    p_draws = (1.0 + float(np.sum(np.max(sim * sim, axis=1) >= stat))) / (1.0 + draws)
    log10_bonferroni = math.log10(len(w)) + float(chi2_logsf(stat, 1)) / math.log(10)
    return stat, i, min(math.log10(p_draws), log10_bonferroni, 0.0), z2
