"""The order of a diagnosis' candidates: by evidence, exact aliases in the conventions' order."""

from __future__ import annotations

import math

from gyrojax.physics import effects as fx

TIE_RTOL = 1e-9
"""Relative difference of log10 p below which two candidates tie: exact aliases (D_II and D_SS in a 1 g tumble) have
equal statistics whose last digits depend on the BLAS threads and on whether the records were read from CSV."""


def by_evidence(cands: list, kind: str) -> list:
    """Candidates by evidence, strongest first: log10 p (never underflows; 0 for the untested), then the statistic;
    ties within :data:`TIE_RTOL` (exact aliases) in the order of :func:`gyrojax.physics.effects.names`, so that the
    proposal between aliases is the same on every machine and every reading of the same data."""
    names = fx.names(kind)
    order = {n: i for i, n in enumerate(names)}
    key = lambda c: c.log10_p if c.df > 0 else 0.0
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
