"""Rows in chunks of a few fixed sizes: a compiled function of a record's rows is called chunk by chunk, so that it
has a few executables (:class:`gyrojax.runtime.kept.Kept` keeps them), never one per record length, and a campaign of
lengths never seen before calls what an earlier one compiled. A record of m rows is cut into chunks of
:data:`CHUNK_ROWS`, the last one padded by the caller (copies of a real row, :func:`clamped`) and the padding dropped
from the outputs (:func:`joined`); a record shorter than one chunk is one chunk of the next power of two (at least
:data:`MIN_ROWS`), so that a short record is not evaluated at many times its length.
"""

from __future__ import annotations

import numpy as np

CHUNK_ROWS = 1024
"""Rows of every compiled call: few enough that a short record's padding costs little, enough that a long one's
calls are few."""


MIN_ROWS = 64
"""The smallest chunk: a record of fewer rows is one chunk of this many."""


def chunks(m: int) -> list[tuple[int, int]]:
    """(first row, rows) of the chunks that cover m rows: :data:`CHUNK_ROWS` each, or one chunk of the next power
    of two (at least :data:`MIN_ROWS`) when m is less than :data:`CHUNK_ROWS`."""
    m = max(int(m), 1)
    if m < CHUNK_ROWS:
        return [(0, max(MIN_ROWS, 1 << (m - 1).bit_length()))]
    return [(k, CHUNK_ROWS) for k in range(0, m, CHUNK_ROWS)]


def clamped(first: int, rows: int, last: int) -> np.ndarray:
    """Indices ``first … first + rows − 1``, those past ``last`` set to ``last``: a chunk's rows, its padding copies
    of the last real row."""
    return np.minimum(np.arange(first, first + rows), last)


def joined(parts, sizes, m: int, blocks: int = 1) -> np.ndarray:
    """The outputs of the chunks (``parts[i]``: leading axis ``blocks · sizes[i]``, the chunk's rows of each of
    ``blocks`` stacked blocks, e.g. the two channels of a TDF gyro) as the outputs of m rows: each block's rows of
    every chunk in order, the padding dropped, the blocks stacked again."""
    out = []
    for b in range(blocks):
        rows = [np.asarray(p)[b * s : (b + 1) * s] for p, s in zip(parts, sizes)]
        out.append(np.concatenate(rows, axis=0)[:m])
    return out[0] if blocks == 1 else np.concatenate(out, axis=0)
