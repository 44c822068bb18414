"""Logs as people write them: delimited text tables (the delimiter given or detected, compressed files too), their
numeric columns checked cell by cell, and their clock — a time column in s/ms/µs or a gap-free sample counter with
its rate — with a note when the time steps jitter. Used by the importers (:mod:`gyrojax.data.importers`)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from gyrojax.errors import RecordError

DELIMITERS = {",": ",", ";": ";", "tab": "\t", "\t": "\t", "\\t": "\t"}
"""The delimiters of ``--delimiter`` (``auto``: detected from the file's first lines)."""


MAX_PREAMBLE = 50
"""Lines a log may carry before its table's header (a logger's ``Fs,100``, a device name, units) that are skipped."""


def _head(path, count: int) -> list:
    """The first ``count`` non-empty lines of a text file (plain or ``.gz``/``.bz2``/``.xz``) as (line index from 0,
    counting blank lines; text without its line end); :class:`RecordError` naming the file when it cannot be read."""
    import bz2
    import gzip
    import lzma

    opener = {".gz": gzip.open, ".bz2": bz2.open, ".xz": lzma.open}.get(Path(path).suffix.lower(), open)
    head = []
    try:
        with opener(path, "rt", encoding="utf-8") as fh:
            for k, ln in enumerate(fh):
                if ln.strip():
                    head.append((k, ln.rstrip("\r\n")))
                    if len(head) >= count:
                        break
    except (OSError, UnicodeDecodeError, EOFError, lzma.LZMAError) as e:
        raise RecordError(f"{path}: not a readable text table ({str(e).strip()[:120]})") from None
    return head


def _names_a_column(line: str, sep: str) -> bool:
    """Whether a line split by ``sep`` has a field that is not a number (a header's column name)."""
    for field in line.split(sep):
        try:
            float(field)
        except ValueError:
            return True
    return False


def sniff_layout(
    path, lines: int = 20, max_preamble: int = MAX_PREAMBLE, delimiters=(",", ";", "\t")
) -> tuple[str, int, list]:
    """(delimiter, header line, preamble) of a delimited text file: the delimiter of ``delimiters`` that splits
    ``lines`` consecutive non-empty lines into the same number (≥ 2) of fields (the most fields when several do),
    from the first line where one does (at most ``max_preamble`` lines in) and whose first line, the header, names
    a column (a field that is not a number). The header line is counted from 0 in the file (blank lines included),
    as pandas' ``skiprows``; the preamble is the non-empty lines before it. :class:`RecordError` naming the file
    when no such table starts within ``max_preamble`` lines."""
    head = _head(path, max_preamble + lines)
    alike = None  # a delimiter that splits some lines alike, though no header line names a column above them
    for s in range(min(max_preamble, max(len(head) - 1, 0)) + 1):
        window = [ln for _, ln in head[s : s + lines]]
        best, fields = None, 1
        for d in delimiters:
            counts = {ln.count(d) for ln in window}
            if len(counts) == 1 and (c := counts.pop()) + 1 > fields:
                best, fields = d, c + 1
        if best is not None and _names_a_column(window[0], best):
            return best, head[s][0], [ln for _, ln in head[:s]]
        alike = alike or best
    if alike is not None:
        raise RecordError(
            f"{path}: no header line naming its columns within its first {max_preamble} lines (its lines split "
            f"alike by {'tab' if alike == chr(9) else repr(alike)} hold numbers only): the column mapping needs a "
            f"header, split like the {lines} lines after it (a row among them with a field too many or too few "
            "breaks that)"
        )
    raise RecordError(
        f"{path}: cannot tell its delimiter (none of ',', ';', tab splits a header and the lines after it alike "
        f"within its first {max_preamble} lines); give --delimiter"
    )


def file_stem(path) -> str:
    """A file's name without its extension and a compression suffix (``log.tsv.gz`` → ``log``)."""
    p = Path(path)
    if p.suffix.lower() in (".gz", ".bz2", ".xz"):
        p = Path(p.stem)
    return p.stem


_DECIMAL_COMMA = re.compile(r"^[+-]?\d+,\d+([eE][+-]?\d+)?$")


def _decimal_commas(path, skip: int, sep: str, lines: int = 20) -> bool:
    """Whether the data lines after the header (line ``skip``, from 0) write their numbers with a decimal comma
    (``0,125``): some field of them does, and none with a decimal point."""
    rows = [ln for k, ln in _head(path, skip + lines + 1) if k > skip]
    fields = [f.strip() for ln in rows for f in ln.split(sep)]
    return any(_DECIMAL_COMMA.match(f) for f in fields) and not any("." in f for f in fields)


MAT_MAGIC = b"MATLAB"
"""The first bytes of a MATLAB ``.mat`` file (level 5, v6, v7 and the v7.3 HDF5 form all start with its text
header)."""


def is_mat_file(path) -> bool:
    """Whether ``path`` is a MATLAB ``.mat`` file (by its header, whatever its name: imu_tk's text files are named
    ``.mat`` too)."""
    try:
        with open(path, "rb") as fh:
            return fh.read(len(MAT_MAGIC)) == MAT_MAGIC
    except OSError:
        return False


def read_mat(path) -> dict:
    """The numeric variables of a MATLAB ``.mat`` file (scipy.io: levels 4 and 5, MATLAB's v6 and v7), name →
    float array; :class:`RecordError` naming the file otherwise (a v7.3 file is HDF5: save it with ``-v7``)."""
    from scipy import io

    try:
        raw = io.loadmat(path, squeeze_me=False)
    except NotImplementedError:
        raise RecordError(f"{path}: a MATLAB v7.3 (HDF5) file; save it with MATLAB's save -v7 to read it") from None
    except Exception as e:  # a damaged file raises anything from scipy's parser (MatReadError, zlib, struct …)
        raise RecordError(
            f"{path}: not a readable MATLAB .mat file ({type(e).__name__}: {str(e).strip()[:120]})"
        ) from None
    out = {}
    for k, v in raw.items():
        if k.startswith("__") or not isinstance(v, np.ndarray) or v.dtype.kind not in "biuf" or v.ndim != 2:
            continue
        out[k] = np.asarray(v, dtype=float)
    if not out:
        raise RecordError(f"{path}: a MATLAB file without a numeric matrix or vector; it holds {sorted(raw)}")
    return out


def mat_table(path):
    """A MATLAB file as a table: each vector variable a column of its name, each matrix variable of k columns the
    columns ``NAME:1`` … ``NAME:k`` (samples along the longer side), all of one length; each scalar a line of the
    preamble, ``NAME = value`` (``fs = 100`` states the rate in Hz, :func:`preamble_rate`)."""
    import pandas as pd

    cols, preamble = {}, []
    for k, v in read_mat(path).items():
        if v.size == 1:
            preamble.append(f"{k} = {float(v.flat[0])!r}")
            continue
        v = v.T if v.shape[0] < v.shape[1] else v
        if v.shape[1] == 1:
            cols[k] = v[:, 0]
        else:
            cols.update({f"{k}:{j + 1}": v[:, j] for j in range(v.shape[1])})
    lengths = {k: len(v) for k, v in cols.items()}
    if len(set(lengths.values())) > 1:
        raise RecordError(f"{path}: its variables differ in length ({lengths}); a log's channels share one length")
    if not cols:
        raise RecordError(f"{path}: a MATLAB file of scalars only ({', '.join(preamble)}); a log needs its samples")
    df = pd.DataFrame(cols)
    df.attrs.update(first_line=1, preamble=preamble)
    return df


def table_layout(path, delimiter: str | None = None, notes: list | None = None) -> tuple[str, int, list, str]:
    """(separator, header line counted from 0, preamble lines, decimal mark) of a delimited text file, as
    :func:`read_table` reads it (the delimiter detected or given, the preamble skipped, decimal commas), what it
    found said in ``notes``."""
    if delimiter in (None, "auto"):
        sep, skip, preamble = sniff_layout(path)
        if notes is not None:
            notes.append(f"delimiter {'tab' if sep == chr(9) else repr(sep)} detected (--delimiter to choose another)")
    elif delimiter in DELIMITERS:
        sep = DELIMITERS[delimiter]
        try:  # the header: the first line that names columns and that the delimiter splits like the lines after it
            _, skip, preamble = sniff_layout(path, delimiters=(sep,))
        except RecordError:
            skip, preamble = 0, []  # pandas names what is wrong with the file
    else:
        raise RecordError(f"--delimiter {delimiter!r}: give ',', ';', 'tab' or 'auto'")
    decimal = "," if sep != "," and _decimal_commas(path, skip, sep) else "."
    if decimal == "," and notes is not None:
        notes.append("decimal commas read (numbers such as 0,125 between the delimiters)")
    if preamble and notes is not None:
        shown = "; ".join(repr(ln[:40]) for ln in preamble[:3]) + (" …" if len(preamble) > 3 else "")
        said = preamble_rate(preamble)
        rate = f"its sample rate {said[0]:g} Hz read from {said[1]!r}" if said else "no sample rate among them"
        notes.append(f"{len(preamble)} line(s) before the table's header (line {skip + 1}) skipped: {shown} ({rate})")
    return sep, skip, preamble, decimal


def read_table(path, delimiter: str | None = None, notes: list | None = None):
    """A delimited text file as a pandas DataFrame; ``delimiter`` one of :data:`DELIMITERS` or None/``"auto"``
    (detected, and said in ``notes``). Lines before the table's header (a logger's preamble: ``Fs,100``, a device
    name) are skipped and said in ``notes``; ``df.attrs["first_line"]`` is the file line (from 1) of the first data
    row, for error messages. :class:`RecordError` naming the file when it is not a readable table. A MATLAB file is
    read as :func:`mat_table` (its rows numbered from 1)."""
    import pandas as pd

    if is_mat_file(path):
        if notes is not None:
            notes.append("read as a MATLAB .mat file: its variables are the columns (a matrix's as NAME:1 … NAME:k)")
        return mat_table(path)
    sep, skip, preamble, decimal = table_layout(path, delimiter, notes)
    try:  # spaces after a delimiter ("t, gx, gy") are no part of a name or a number
        df = pd.read_csv(path, sep=sep, skiprows=skip, skipinitialspace=True, decimal=decimal)
    except (UnicodeDecodeError, ValueError, pd.errors.ParserError, pd.errors.EmptyDataError) as e:
        raise RecordError(f"{path}: not a readable {sep!r}-separated table ({str(e).strip()[:120]})") from None
    names = [str(c).strip() for c in df.columns]
    if len(set(names)) == len(names):
        df.columns = names
    df.attrs["first_line"] = skip + 2
    df.attrs["preamble"] = list(preamble)
    return df


_PREAMBLE_RATE = re.compile(
    r"^\s*[#%;/]*\s*(fs|sample[ _-]?rate|sampling[ _-]?(rate|frequency)|rate|odr|data[ _-]?rate)"
    r"\s*(\[?hz\]?)?\s*[,;:=\t ]\s*([0-9]+(\.[0-9]*)?([eE][+-]?[0-9]+)?)\s*(hz)?\s*[,;]*\s*$",
    re.IGNORECASE,
)


def preamble_rate(preamble) -> tuple[float, str] | None:
    """The sample rate (Hz) a logger wrote before its table — ``Fs,100``, ``Sample rate: 200 Hz``,
    ``# rate = 1000`` — and the line that says it; None when no line of ``preamble`` does (or two disagree)."""
    found = []
    for line in preamble:
        m = _PREAMBLE_RATE.match(line)
        if m and float(m.group(4)) > 0:
            found.append((float(m.group(4)), line.strip()))
    if not found or len({f for f, _ in found}) > 1:
        return None
    return found[0]


def numeric_columns(df, cols: list, where: str):
    """The columns ``cols`` of ``df`` as an (n, k) float array; :class:`RecordError` naming the first row and column
    that is not a finite number (rows counted as lines of the file: ``df.attrs["first_line"]`` is the first data
    row's, :func:`read_table`; 2 when absent, the header being line 1)."""
    import pandas as pd

    def numbers(col):  # a number too large for a float (400 digits) is not finite, not an OverflowError
        try:
            return pd.to_numeric(col, errors="coerce")
        except OverflowError:
            return pd.Series([_float_or_nan(v) for v in col], index=col.index, dtype=float)

    arr = df[cols].apply(numbers).to_numpy(dtype=float)
    bad = ~np.isfinite(arr)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        cell = df[cols[j]].iloc[i]
        hint = " (a decimal comma? the file's numbers need a '.')" if isinstance(cell, str) and "," in cell else ""
        row = i + df.attrs.get("first_line", 2)
        if not isinstance(cell, str) and pd.isna(cell):  # an empty cell, or a row a field short
            raise RecordError(f"{where}: row {row}, column {cols[j]!r} is empty (a field missing from the row?)")
        shown = repr(cell) if isinstance(cell, str) else repr(_float_or_nan(cell))
        shown = shown if len(shown) <= 40 else shown[:37] + "..."
        raise RecordError(f"{where}: row {row}, column {cols[j]!r} is not a finite number: {shown}{hint}")
    return arr


def _float_or_nan(v) -> float:
    """``float(v)``: inf when it overflows, nan when it is no number."""
    try:
        return float(v)
    except OverflowError:
        return float("inf")
    except (TypeError, ValueError):
        return float("nan")


TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9}

RATE_TOL = 0.02
"""Largest relative difference between two statements of a log's sample rate (a time column's mean rate, a
logger's preamble, ``--rate-hz``) taken as the same rate: a logger's crystal and its rounding (99.5 Hz said as
100) are well inside; a wrong unit (10³) or a halved rate is not."""
PLAUSIBLE_RATE_HZ = (1.0, 5e4)
"""Sample rates of IMU logs (Hz): MEMS and navigation IMUs log at 10 Hz–10 kHz (the fastest MEMS output rates
are 32 kHz). A clock outside this range comes from a wrong unit (a time column in ms read as s gives 0.1 Hz for a
100 Hz log), and is refused."""


def unit_hint(ratio: float, time_column: bool) -> str:
    """The flag a rate ``ratio`` = stated / from the clock (Hz over Hz, dimensionless) points to: 10³, 10⁶, 10⁹ (or
    their inverses) a time unit, anything else the stated rate."""
    for k, unit in ((1e3, "ms"), (1e6, "us"), (1e9, "ns")):
        for r, word in ((k, f"is the time column in {unit} (--time-unit {unit})?"), (1 / k, "is --time-unit right?")):
            if abs(ratio / r - 1.0) < 0.05 and time_column:
                return word
    return "is --rate-hz right?" if time_column else "which rate is right (--rate-hz)?"


def log_clock(n: int, where: str, *, times=None, time_source=None, rate_hz=None, preamble=(), counter=None, span=None):
    """The sample times (s, from 0) of a log of ``n`` samples and where they came from, every statement of its
    rate checked against the others (:data:`RATE_TOL`) and against :data:`PLAUSIBLE_RATE_HZ`.

    ``times``: a time column already in s (``time_source`` says which and in what unit); ``counter``: (gap-free
    counter values, its description); ``rate_hz`` the rate given (``--rate-hz``); ``preamble`` the lines before the
    table (:func:`preamble_rate`); ``span``: the (first, last) time of a time column read in chunks, in place of
    ``times`` (the times returned are then None). Returns (times, ``clock``: ``rate_hz``, ``duration_s``,
    ``n_samples``, ``rate_from``, ``checked_against``). :class:`RecordError` naming the contradiction and the flag
    it points to."""
    said = preamble_rate(preamble)
    stated = [(float(rate_hz), "--rate-hz")] if rate_hz is not None else []
    stated += [(said[0], f"the preamble line {said[1]!r}")] if said else []
    checked = []
    if times is not None or span is not None:
        t = None if times is None else np.asarray(times, dtype=float)
        first, last = (t[0], t[-1]) if t is not None else span
        span = float(last - first) if n > 1 else 0.0
        rate = (n - 1) / span if span > 0 else float("inf")
        source = time_source
        for r, name in stated:
            if abs(r / rate - 1.0) > RATE_TOL:
                raise RecordError(
                    f"{where}: {name} says {r:g} Hz but {time_source} gives {rate:.6g} Hz ({n} samples over "
                    f"{span:.6g} s): {unit_hint(r / rate, True)}"
                )
            checked.append(name)
    else:
        if len(stated) == 2 and abs(stated[0][0] / stated[1][0] - 1.0) > RATE_TOL:
            raise RecordError(
                f"{where}: --rate-hz {stated[0][0]:g} contradicts {stated[1][1]} ({stated[1][0]:g} Hz): "
                "which rate is right? (--rate-hz)"
            )
        if not stated:
            what = f"the sample counter {counter[1]}" if counter is not None else "the samples"
            raise RecordError(
                f"{where}: {what} need a rate: give --rate-hz (or map a time column, time=COL); no preamble line "
                "states one"
            )
        rate, source = stated[0]
        checked = [name for _, name in stated[1:]]
        if counter is not None:
            t = time_from_counter(counter[0], rate, f"{where}, column {counter[1]!r}", counter[2])
            source = f"sample counter {counter[1]!r} at {source}"
        else:
            t = np.arange(n) / rate
    lo, hi = PLAUSIBLE_RATE_HZ
    if not lo <= rate <= hi:
        fix = "is the time column's unit right (--time-unit)?" if time_source else "is --rate-hz right?"
        raise RecordError(
            f"{where}: the clock ({source}) gives {rate:.4g} Hz, {n} samples over {(n - 1) / rate:.6g} s "
            f"({(n - 1) / rate / 3600:.3g} h): no IMU log is sampled outside {lo:g} Hz–{hi:g} Hz; {fix}"
        )
    clock = {
        "n_samples": int(n),
        "rate_hz": float(rate),
        "duration_s": float((n - 1) / rate),
        "rate_from": source,
        "checked_against": checked,
    }
    return (None if t is None else t - t[0]), clock


def time_column(df, col: str, unit: str | None, where: str) -> tuple[np.ndarray, str | None]:
    """A time column of ``df`` in s: numbers in ``unit`` (:data:`TIME_UNITS`, default s), or — with no unit given —
    ISO 8601 date-times (``2026-03-01T12:00:00.125``, a phone logger's or a spreadsheet's), as seconds since the
    first; returns (times, a note saying how they were read, or None). :class:`RecordError` naming the first cell
    that is neither (:func:`numeric_columns`)."""
    import pandas as pd

    raw = df[col]
    if unit is None and not pd.api.types.is_numeric_dtype(raw):
        try:
            stamps = pd.to_datetime(raw, format="ISO8601")
        except (ValueError, TypeError):
            stamps = None
        if stamps is not None and not stamps.isna().any():
            ns = stamps.to_numpy(dtype="datetime64[ns]").astype(np.int64)
            note = f"time column {col!r} read as ISO 8601 date-times (s since the first, {raw.iloc[0]!s})"
            return (ns - ns[0]) * 1e-9, note
    return numeric_columns(df, [col], where)[:, 0] * TIME_UNITS[unit or "s"], None


def time_from_counter(c: np.ndarray, rate_hz: float | None, where: str, first_line: int = 2) -> np.ndarray:
    """Times (s) from a gap-free sample counter at ``rate_hz`` counts per second: every step the same positive
    integer (a counter that wraps to 0 is unwrapped); :class:`RecordError` naming the row of a gap otherwise (rows
    counted as lines of the file, ``first_line`` the first sample's)."""
    if not rate_hz or not rate_hz > 0:
        raise RecordError(f"{where}: a sample counter needs its rate: give --rate-hz (counts per second)")
    c = np.asarray(c, dtype=float)
    if np.any(c != np.round(c)):
        i = int(np.flatnonzero(c != np.round(c))[0])
        raise RecordError(f"{where}: row {i + first_line}: the sample counter holds {float(c[i])!r}, not an integer")
    d = np.diff(c)
    if d.size and np.any(d < 0):  # a wrapping counter: modulo the largest value seen + 1
        period = c.max() + 1
        d = np.where(d < 0, d + period, d)
    step = float(np.median(d)) if d.size else 1.0
    bad = np.flatnonzero(d != step)
    if step <= 0 or bad.size:
        i = int(bad[0]) if bad.size else 0
        raise RecordError(
            f"{where}: row {i + first_line + 1}: the sample counter steps from {c[i]:g} to {c[i + 1]:g} "
            f"(its step is {step:g}): a gap or repeat; a gap-free counter is needed"
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
