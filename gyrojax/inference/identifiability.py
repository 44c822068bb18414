"""Identifiability of a plan: rank, condition number and the groups of effects a regressor matrix cannot tell apart.

The singular values of the column-normalised, whitened regressor matrix give the rank, the condition number and
the alias groups (for example D_F, D_II, D_OO and D_SS in any 1 g test, since a_I² + a_O² + a_S² is constant); a
column that is only floating-point residue marks an effect the plan does not excite. A fit that meets either raises
:class:`IdentifiabilityError` naming them, unless aliases are allowed.
"""

from __future__ import annotations

import math

import numpy as np

from gyrojax.errors import ModelError
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model

ALIAS_TOL = 1e-7  # singular value / largest below this: a direction the plan cannot see
RESIDUE_TOL = 1e-12
"""A whitened regressor column whose norm is below this fraction of the largest column's is floating-point residue
(cos 90° = 6e-17, not 0): the plan does not excite that coefficient. Legitimately weak columns (E_2 under the Earth
rate alone, ~1e-8) stay well above it; residue stays below ~1e-14."""


class IdentifiabilityError(ModelError):
    """The plan cannot separate some effects of the model; ``report`` holds the details."""

    def __init__(self, message, report):
        super().__init__(message)
        self.report = report


def residue_columns(jw: np.ndarray, tol: float = RESIDUE_TOL) -> np.ndarray:
    """Mask of the columns of a (whitened) regressor matrix that are only floating-point residue
    (:data:`RESIDUE_TOL`): their coefficients are not excited, and an estimate of them would be noise / 1e-16."""
    norms = np.sqrt((jw * jw).sum(axis=0))
    if norms.size == 0:
        return np.zeros(0, dtype=bool)
    return norms <= tol * max(float(norms.max()), 1e-300)


def identifiability(jw: np.ndarray, model: Model, tol: float = ALIAS_TOL) -> dict:
    """Rank, condition number and alias groups of a (whitened) regressor matrix whose columns are the coefficients
    of ``model``, grouped by effect (:func:`alias_analysis`)."""
    names = model.coefficient_names
    return alias_analysis(jw, names, [fx.effect_of_coefficient(c) for c in names], model.terms, tol)


def alias_analysis(jw: np.ndarray, names, labels, order=None, tol: float = ALIAS_TOL) -> dict:
    """Rank, condition number and alias groups of a (whitened) regressor matrix ``jw`` (m, p).

    Columns are normalised first, so the condition number measures correlation, not units. An alias group is the
    set of labels whose columns carry weight (|v| > 0.05) in a right singular vector whose singular value is
    below ``tol`` × the largest: a combination of their regressors that the plan leaves (nearly) unseen.
    ``names[k]`` names column k and ``labels[k]`` is what it is reported under (its effect, or the column itself);
    groups are listed in ``order`` (default: the labels' first appearance).
    """
    if jw.shape[1] == 0:
        return {"rank": 0, "size": 0, "condition": 1.0, "aliases": [], "unexcited": []}
    norms = np.sqrt((jw * jw).sum(axis=0))
    residue = residue_columns(jw)
    unexcited = [names[i] for i in np.flatnonzero(residue)]
    z = np.where(residue, 0.0, jw / np.where(norms > 0, norms, 1.0))
    _, s, vt = np.linalg.svd(z, full_matrices=False)
    smax = s[0] if s.size else 1.0
    small = s < tol * smax
    groups: list[set] = []
    coef_to_effect = dict(zip(names, labels))
    for i in np.flatnonzero(small):
        v = vt[i]
        members = {coef_to_effect[names[k]] for k in np.flatnonzero(np.abs(v) > 0.05)}
        merged = [g for g in groups if g & members]
        for g in merged:
            members |= g
            groups.remove(g)
        groups.append(members)
    order = {t: i for i, t in enumerate(dict.fromkeys(labels) if order is None else order)}
    alias_groups = [sorted(g, key=order.get) for g in groups if len(g) > 1 or g & set(unexcited)]
    positive = s[s > 0]
    return {
        "rank": int((~small).sum()),
        "size": len(names),
        "condition": float(smax / positive[-1]) if positive.size and positive[-1] > 0 else math.inf,
        "aliases": alias_groups,
        "unexcited": sorted({coef_to_effect[c] for c in unexcited}, key=order.get),
        "singular_values": s.tolist(),
    }


def alias_message(report: dict, remedy: str = "add positions/mountings that separate them") -> str:
    """The message of :class:`IdentifiabilityError` for a report of :func:`identifiability`: the alias groups, the
    unexcited effects, the rank, and what to do about them (``remedy``: what would separate them)."""
    parts = []
    for g in report["aliases"]:
        parts.append(" + ".join(g))
    msg = "this plan cannot tell apart: " + "; ".join(f"[{p}]" for p in parts) if parts else ""
    if report["unexcited"]:
        msg += ("; " if msg else "") + "not excited by this plan: " + ", ".join(report["unexcited"])
    return f"{msg} (rank {report['rank']} of {report['size']}); drop all but one effect of each group, or {remedy}"
