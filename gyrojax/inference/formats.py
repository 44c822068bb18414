"""The format tags of saved fits (:mod:`gyrojax.protocol`): one tag and integer version per kind of fit, and which
kind a parsed file holds, so that each reader can say what a file of the other kind is."""

from __future__ import annotations

from gyrojax.data.triad import TRIAD_KIND

RESULT_FORMAT = "gyrojax-fit"
"""The ``format`` of a saved turntable fit (:meth:`gyrojax.inference.result.FitResult.save`)."""
RESULT_VERSION = 2
"""The ``format_version`` of :data:`RESULT_FORMAT` this gyrojax writes; it reads 1 to this one (version 2 added the
exact noise models, the Satterthwaite degrees of freedom and strict JSON)."""
TRIAD_FORMAT = "gyrojax-triad-fit"
"""The ``format`` of a saved imu-triad fit (:meth:`gyrojax.inference.triad_result.TriadFit.save`)."""
TRIAD_VERSION = 1
"""The ``format_version`` of :data:`TRIAD_FORMAT` this gyrojax writes."""
LEGACY_FORMAT = "gyrojax-fit-1"
"""The ``format`` of 0.2's saved fits, turntable and imu-triad alike (the version was part of the tag)."""


def fit_kind(doc) -> str | None:
    """``"triad"`` or ``"turntable"`` for a parsed fit file (also the legacy ``gyrojax-fit-1`` ones, told apart by
    their ``instrument``), ``None`` for anything else."""
    if not isinstance(doc, dict):
        return None
    tag = doc.get("format")
    if tag == TRIAD_FORMAT or (tag == LEGACY_FORMAT and doc.get("instrument") == TRIAD_KIND):
        return "triad"
    if tag in (RESULT_FORMAT, LEGACY_FORMAT):
        return "turntable"
    return None
