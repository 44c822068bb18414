"""The CSV half of a record (conventions §5): reading it fast (numpy's reader for a plain all-number file of common
size, a memory map parsed by pandas' C parser for a larger one) while naming the row and column of the first bad
cell, and writing it in chunks at full float64 precision.
"""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path

import numpy as np

from gyrojax.data.schema import err, must_be_numeric


def read_csv_bytes(csv_path: Path) -> bytes:
    """The bytes of a record's CSV file; :class:`~gyrojax.errors.RecordError` naming the file when it cannot be
    read."""
    try:
        with open(csv_path, "rb") as fh:
            raw = fh.read()
    except OSError as e:
        raise err(csv_path, f"cannot read: {e.strerror} (a record is NAME.csv + NAME.json, both files)") from None
    if not raw.isascii():
        try:
            raw.decode("utf-8")
        except UnicodeDecodeError as e:
            row = raw[: e.start].count(b"\n") + 1
            raise err(
                csv_path, f"row {row} is not UTF-8 (byte {e.start}: 0x{raw[e.start]:02x}); save the file as UTF-8"
            ) from None
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]  # a UTF-8 byte-order mark is fine
    if b"\x00" in raw[:65536]:
        row = raw[: raw.index(b"\x00")].count(b"\n") + 1
        raise err(csv_path, f"row {row} holds a NUL byte: this is not a text file; records are UTF-8 CSV")
    if not raw[:4096].strip() and not raw.strip():
        raise err(csv_path, "is empty; a header row and at least one sample are required")
    return raw


def parse_csv_header(csv_path: Path, raw: bytes) -> list[str]:
    """Column names of the first row of ``raw`` (a record CSV); :class:`~gyrojax.errors.RecordError` naming the file
    and what is wrong (empty header, wrong separator, unnamed or duplicate columns)."""
    import csv

    end = raw.find(b"\n")
    line = (raw if end < 0 else raw[:end]).decode("utf-8").rstrip("\r")
    try:
        header = [h.strip() for h in next(csv.reader([line]))] if line.strip() else []
    except csv.Error as e:
        raise err(csv_path, f"row 1 (header) is not a comma-separated line ({e}); a stray carriage return?") from None
    if not header:
        raise err(csv_path, "row 1 (header) is empty; it must name the columns (time_s, angle_<axis>_deg, …)")
    if len(header) == 1:
        for sep in (";", "\t", "|"):
            if sep in header[0]:
                raise err(
                    csv_path,
                    f"row 1 (header) is one column {header[0][:60]!r}: the file looks {sep!r}-separated; "
                    "records must be comma separated (conventions §5)",
                )
    for j, h in enumerate(header):
        if not h:
            raise err(csv_path, f"row 1 (header), column {j + 1} has no name; every column must be named")
        if header.count(h) > 1:
            k = header.index(h, j + 1)
            raise err(
                csv_path,
                f"row 1 (header) names column {h!r} twice (columns {j + 1} and {k + 1}); column names must be unique",
            )
    return header


def _numbered_rows(csv_path, reader):
    """(file row number, fields) of each CSV row, streamed; a malformed line is an error naming its row."""
    import csv

    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as e:
            raise err(
                csv_path, f"row {reader.line_num} is not a valid CSV row ({e}); a stray carriage return or quote?"
            ) from None
        yield reader.line_num, row


def diagnose_csv(csv_path: Path, raw: bytes, header: list[str], strict: bool) -> None:
    """Stream the rows and raise at the first row of the wrong length or the first bad numeric cell.

    ``strict``: check every column (else only the columns of conventions §5).
    """
    import csv
    import io

    check = [j for j, h in enumerate(header) if strict or must_be_numeric(h)]
    rows = _numbered_rows(csv_path, csv.reader(io.StringIO(raw.decode("utf-8")), skipinitialspace=True))
    next(rows, None)  # the header
    n = len(header)
    for i, row in rows:
        if not row:
            continue
        if len(row) < n:
            raise err(
                csv_path,
                f"row {i} has {len(row)} of {n} fields: column {header[len(row)]!r} is missing "
                "(is the file truncated?); every row needs one value per header column",
            )
        if len(row) > n:
            raise err(
                csv_path,
                f"row {i} has {len(row)} fields but the header names {n} columns; "
                "every row needs one value per header column",
            )
        for j in check:
            v = row[j].strip()
            if v == "":
                raise err(csv_path, f"row {i}, column {header[j]!r} is empty; a finite number is required")
            try:
                x = float(v)
            except ValueError:
                raise err(
                    csv_path,
                    f"row {i}, column {header[j]!r} holds {v[:40]!r}, not a number; a finite number is required",
                ) from None
            if not math.isfinite(x):
                raise err(csv_path, f"row {i}, column {header[j]!r} holds {v!r}; values must be finite numbers")


def _mapped_plain_csv(csv_path: Path):
    """The CSV memory-mapped (read-only) when it is the common case: plain ASCII (so valid UTF-8, no byte-order
    mark), no NUL byte in its first 64 KiB, a non-blank start and a header line. ``None`` otherwise, and when it
    cannot be mapped: :func:`read_csv_bytes` then reads it, checks it and names what is wrong. Parsing the map
    spares a copy of the whole file in memory (for 10⁶ samples, 37 MB of fresh pages per load)."""
    import mmap

    try:
        with open(csv_path, "rb") as fh:
            if os.fstat(fh.fileno()).st_size == 0:
                return None
            mm = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
    except (OSError, ValueError):
        return None
    view = np.frombuffer(mm, dtype=np.uint8)
    plain = int(view.max()) < 128
    del view  # the map can only be closed once no array looks at it
    if plain and b"\x00" not in mm[:65536] and mm[:4096].strip() and mm.find(b"\n") >= 0:
        return mm
    mm.close()
    return None


NUMPY_READ_MAX_BYTES = 16 * 2**20
"""Plain CSV files up to this size are read by numpy (:func:`_numpy_columns`): its reader is slower per byte than
pandas', but importing pandas costs a process more than that below this size."""


def _numpy_columns(csv_path: Path, n_columns: int):
    """All cells as float64 by numpy's reader (Python's correctly rounded parse: exact round trip), one contiguous
    row per column (n_columns, rows), or ``None`` when it is not the plain case: a cell that is not a finite number
    (quoted, empty, text), a row whose length is not the header's, no sample row. The caller then takes the paths
    that name what is wrong."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "input contained no data": refused below
            table = np.loadtxt(
                csv_path, delimiter=",", skiprows=1, comments=None, dtype=np.float64, ndmin=2, encoding="ascii"
            )
    except (ValueError, OSError, UnicodeDecodeError):
        return None
    if table.shape[0] == 0 or table.shape[1] != n_columns or not np.all(np.isfinite(table)):
        return None
    return np.ascontiguousarray(table.T)


def _float_table(source, header: list[str]):
    """All cells as float64 by pandas' C parser (exact round trip), or ``None`` when some cell is not a number:
    first without ``skipinitialspace`` (the float parser skips blanks around a number itself; a quoted or ``inf``
    cell after a blank fails there), then with it. ``source`` is re-read from its start each time."""
    import pandas as pd

    for skip in (False, True):
        source.seek(0)
        try:
            return pd.read_csv(source, dtype=np.float64, na_filter=False, names=header, header=0, skipinitialspace=skip)
        except (ValueError, pd.errors.ParserError):
            continue
    return None


def parse_csv(csv_path: Path) -> tuple[list[str], dict[str, np.ndarray]]:
    """Header and columns of a record CSV, naming the row and column of the first bad cell.

    Fast path: a plain ASCII file memory-mapped (:func:`_mapped_plain_csv`) and every cell parsed to float64, by
    numpy up to :data:`NUMPY_READ_MAX_BYTES` (:func:`_numpy_columns`), else by pandas (:func:`_float_table`).
    Otherwise, or on any failure, the bytes are read and checked (:func:`read_csv_bytes`)
    and the rows streamed again to name the first bad row and column; extra columns that are not numeric are kept
    as text.
    """
    import io

    df = raw = None
    mm = _mapped_plain_csv(csv_path)
    if mm is not None:
        with mm:
            header = parse_csv_header(csv_path, mm[: mm.find(b"\n") + 1])
            table = _numpy_columns(csv_path, len(header)) if len(mm) <= NUMPY_READ_MAX_BYTES else None
            if table is not None:
                return header, dict(zip(header, table))
            df = _float_table(mm, header)
    import pandas as pd

    if df is None:
        raw = read_csv_bytes(csv_path)
        header = parse_csv_header(csv_path, raw)
        if mm is None:  # a mapped file that failed holds the same bytes: no second try
            df = _float_table(io.BytesIO(raw), header)
    if df is None:
        diagnose_csv(csv_path, raw, header, strict=False)
        dtypes = {h: (np.float64 if must_be_numeric(h) else str) for h in header}
        try:
            df = pd.read_csv(
                io.BytesIO(raw), dtype=dtypes, keep_default_na=False, skipinitialspace=True, names=header, header=0
            )
        except (ValueError, pd.errors.ParserError) as e:
            raise err(csv_path, f"is not a valid comma-separated table: {str(e).strip()}") from None
    if len(df) == 0:
        raise err(csv_path, "has a header but no samples; at least one sample row is required")
    cols = {}
    for h in header:
        col = df[h].to_numpy()
        if col.dtype == np.float64 and must_be_numeric(h) and not np.all(np.isfinite(col)):
            diagnose_csv(csv_path, read_csv_bytes(csv_path) if raw is None else raw, header, strict=False)
            i = int(np.flatnonzero(~np.isfinite(col))[0])
            raise err(csv_path, f"row {i + 2}, column {h!r} holds {float(col[i])}; values must be finite numbers")
        cols[h] = col if col.dtype == np.float64 else col.astype(str)
    return header, cols


def _fmt(x) -> str:
    if isinstance(x, str):  # an extra text column, kept as read
        return x if not any(c in x for c in ',"\n\r') else '"' + x.replace('"', '""') + '"'
    return repr(float(x)) if x != 0 else "0"


CSV_CHUNK_ROWS = 100_000


def record_csv_chunks(record, rows: int = CSV_CHUNK_ROWS):
    """The CSV text of a record in pieces of ``rows`` rows (full float64 precision), header first."""
    header = list(record.columns)
    cols = [record.columns[h] for h in header]
    yield ",".join(header) + "\n"
    for s in range(0, record.n, rows):
        part = zip(*(c[s : s + rows] for c in cols))
        yield "\n".join(",".join(_fmt(v) for v in row) for row in part) + "\n"
