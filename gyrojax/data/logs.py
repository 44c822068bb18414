"""Logs as people write them: delimited text tables (the delimiter given or detected, compressed files too), their
numeric columns checked cell by cell, and their clock — a time column in s/ms/µs or a gap-free sample counter with
its rate — with a note when the time steps jitter. Used by the importers (:mod:`gyrojax.data.importers`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gyrojax.errors import RecordError

DELIMITERS = {",": ",", ";": ";", "tab": "\t", "\t": "\t", "\\t": "\t"}
"""The delimiters of ``--delimiter`` (``auto``: detected from the file's first lines)."""


def sniff_delimiter(path, lines: int = 20) -> str:
    """The delimiter (``,``, ``;`` or tab) that splits the first ``lines`` non-empty lines of a text file into the
    same number (≥ 2) of fields, the most fields when several do; :class:`RecordError` naming the file otherwise."""
    import bz2
    import gzip
    import lzma

    opener = {".gz": gzip.open, ".bz2": bz2.open, ".xz": lzma.open}.get(Path(path).suffix.lower(), open)
    try:
        with opener(path, "rt", encoding="utf-8") as fh:
            head = [ln for ln in (fh.readline() for _ in range(4 * lines)) if ln.strip()][:lines]
    except (OSError, UnicodeDecodeError, EOFError, lzma.LZMAError) as e:
        raise RecordError(f"{path}: not a readable text table ({str(e).strip()[:120]})") from None
    best, fields = None, 1
    for d in (",", ";", "\t"):
        counts = {ln.count(d) for ln in head}
        if len(counts) == 1 and (c := counts.pop()) + 1 > fields:
            best, fields = d, c + 1
    if best is None:
        raise RecordError(
            f"{path}: cannot tell its delimiter (none of ',', ';', tab splits its first lines alike); give --delimiter"
        )
    return best


def file_stem(path) -> str:
    """A file's name without its extension and a compression suffix (``log.tsv.gz`` → ``log``)."""
    p = Path(path)
    if p.suffix.lower() in (".gz", ".bz2", ".xz"):
        p = Path(p.stem)
    return p.stem


def read_table(path, delimiter: str | None = None, notes: list | None = None):
    """A delimited text file as a pandas DataFrame; ``delimiter`` one of :data:`DELIMITERS` or None/``"auto"``
    (detected, and said in ``notes``). :class:`RecordError` naming the file when it is not a readable table."""
    import pandas as pd

    if delimiter in (None, "auto"):
        sep = sniff_delimiter(path)
        if notes is not None:
            notes.append(f"delimiter {'tab' if sep == chr(9) else repr(sep)} detected (--delimiter to choose another)")
    elif delimiter in DELIMITERS:
        sep = DELIMITERS[delimiter]
    else:
        raise RecordError(f"--delimiter {delimiter!r}: give ',', ';', 'tab' or 'auto'")
    try:
        return pd.read_csv(path, sep=sep)
    except (UnicodeDecodeError, ValueError, pd.errors.ParserError, pd.errors.EmptyDataError) as e:
        raise RecordError(f"{path}: not a readable {sep!r}-separated table ({str(e).strip()[:120]})") from None


def numeric_columns(df, cols: list, where: str):
    """The columns ``cols`` of ``df`` as an (n, k) float array; :class:`RecordError` naming the first row and column
    that is not a finite number (rows counted as in the file, the header being row 1)."""
    import pandas as pd

    arr = df[cols].apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
    bad = ~np.isfinite(arr)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        cell = df[cols[j]].iloc[i]
        hint = " (a decimal comma? the file's numbers need a '.')" if isinstance(cell, str) and "," in cell else ""
        raise RecordError(f"{where}: row {i + 2}, column {cols[j]!r} is not a finite number: {cell!r}{hint}")
    return arr


TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6}


def time_from_counter(c: np.ndarray, rate_hz: float | None, where: str) -> np.ndarray:
    """Times (s) from a gap-free sample counter at ``rate_hz`` counts per second: every step the same positive
    integer (a counter that wraps to 0 is unwrapped); :class:`RecordError` naming the row of a gap otherwise."""
    if not rate_hz or not rate_hz > 0:
        raise RecordError(f"{where}: a sample counter needs its rate: give --rate-hz (counts per second)")
    c = np.asarray(c, dtype=float)
    if np.any(c != np.round(c)):
        i = int(np.flatnonzero(c != np.round(c))[0])
        raise RecordError(f"{where}: row {i + 2}: the sample counter holds {c[i]!r}, not an integer")
    d = np.diff(c)
    if d.size and np.any(d < 0):  # a wrapping counter: modulo the largest value seen + 1
        period = c.max() + 1
        d = np.where(d < 0, d + period, d)
    step = float(np.median(d)) if d.size else 1.0
    bad = np.flatnonzero(d != step)
    if step <= 0 or bad.size:
        i = int(bad[0]) if bad.size else 0
        raise RecordError(
            f"{where}: row {i + 3}: the sample counter steps from {c[i]:g} to {c[i + 1]:g} (its step is {step:g}): "
            "a gap or repeat; a gap-free counter is needed"
        )
    return np.concatenate([[0.0], np.cumsum(d)]) / float(rate_hz)


def jitter_note(t: np.ndarray, where: str) -> str | None:
    """A note when the time steps of ``t`` (s) jitter (rms deviation from their median above 1 % of it, or a step off
    by more than a quarter of it; None otherwise): the fit takes a segment's samples as evenly spaced between its
    ends, so a receive-time jitter enters the moves' durations."""
    dt = np.diff(np.asarray(t, dtype=float))
    med = float(np.median(dt))
    dev = np.abs(dt - med)
    if med <= 0 or (np.sqrt(np.mean(dev**2)) <= 0.01 * med and dev.max() <= 0.25 * med):
        return None
    return (
        f"{where} jitters: steps {1e3 * dt.min():.3g}–{1e3 * dt.max():.3g} ms around a median of {1e3 * med:.3g} ms "
        f"({100 * np.mean(dev > 0.05 * med):.2g} % of the steps off by > 5 %, rms {1e3 * np.sqrt(np.mean(dev**2)):.2g} "
        "ms); the fit spaces each segment's samples evenly between its ends: a sample counter (sample=COL with "
        "--rate-hz) is the better clock if the log has one"
    )
