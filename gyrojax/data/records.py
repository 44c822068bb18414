"""Record files: ``NAME.csv`` + ``NAME.json`` (CONVENTIONS §5).

A record is one test run. ``load_record`` validates everything at the boundary and raises
:class:`~gyrojax.errors.RecordError` naming the file and the key, or the row and the column; ``save_record``
writes both files atomically and never over a good file without ``force``.
"""

from __future__ import annotations

import copy
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyrojax.data.triad import is_triad, validate_triad_columns, validate_triad_meta
from gyrojax.errors import RecordError
from gyrojax.physics.effects import ACCEL, INSTRUMENT_KINDS, SDF, TDF
from gyrojax.protocol import is_finite_number

FORMAT = "gyrojax-record-1"
AXIS_TOL = 1e-6
GAP_FACTOR = 1.5  # a time step above 1.5 × the median step ends a continuous segment (CONVENTIONS §5)

TRIAD_KEYS = {
    SDF: ("ia", "oa", "sa"),
    TDF: ("x", "y", "z"),
    ACCEL: ("ia", "pa", "oa"),
    "fog": ("ia", "oa", "sa"),
    "rlg": ("ia", "oa", "sa"),
}


@dataclass
class Record:
    """One test run: metadata (the JSON, unknown keys kept) and columns (numpy arrays, every CSV column kept).

    Units are those of the files: s, deg, deg/s, mA, °C. Use the properties for the derived views.
    """

    meta: dict
    columns: dict[str, np.ndarray]
    path: str | None = None
    _rates_derived: bool | None = field(default=None, repr=False)

    # ---- metadata views ------------------------------------------------------------------------------------
    @property
    def name(self) -> str:
        """The record's name (the file stem)."""
        return self.meta["name"]

    @property
    def kind(self) -> str:
        """Instrument kind (CONVENTIONS §5): ``sdf-gyro``, ``tdf-gyro``, ``pendulous-accel``, ``fog`` or ``rlg``."""
        return self.meta["instrument"]["kind"]

    @property
    def mode(self) -> str:
        """``rebalance`` or ``servo`` (CONVENTIONS §4)."""
        return self.meta["mode"]

    @property
    def axis_names(self) -> list[str]:
        """Table axis names, outermost first."""
        return [a["name"] for a in self.meta["table"]["axes"]]

    @property
    def axes_enu(self) -> np.ndarray:
        """Table axis unit vectors in L at zero angles, outermost first, shape (k, 3)."""
        return np.array([a["axis_enu"] for a in self.meta["table"]["axes"]], dtype=float)

    @property
    def triad(self) -> np.ndarray:
        """Instrument axes in platform coordinates, rows (IA, OA, SA) / (X, Y, Z) / (IA, PA, OA)."""
        keys = TRIAD_KEYS[self.kind]
        return np.array([self.meta["instrument"][k] for k in keys], dtype=float)

    @property
    def latitude_deg(self) -> float:
        """Geodetic latitude of the site, deg."""
        return float(self.meta["site"]["latitude_deg"])

    @property
    def gravity_mps2(self) -> float:
        """Local gravity magnitude at the site, m/s²."""
        return float(self.meta["site"]["gravity_mps2"])

    @property
    def scale_factor(self) -> float:
        """Nominal scale factor: deg/h/mA for gyros, g/mA for accelerometers."""
        key = "scale_factor_g_per_mA" if self.kind == ACCEL else "scale_factor_deg_per_h_per_mA"
        return float(self.meta[key])

    @property
    def servo_axis_index(self) -> int | None:
        """Index of the servo axis among the table axes (servo records), else None."""
        s = self.meta.get("servo_axis")
        return None if s is None else self.axis_names.index(s)

    @property
    def encoder_axis_index(self) -> int:
        """Axis whose angle readout carries ``encoder_harmonic``: the servo axis, or else the last axis."""
        s = self.servo_axis_index
        return len(self.axis_names) - 1 if s is None else s

    # ---- column views --------------------------------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of samples."""
        return len(self.columns["time_s"])

    @property
    def time_s(self) -> np.ndarray:
        """Sample times, s, shape (n,)."""
        return self.columns["time_s"]

    @property
    def angles_deg(self) -> np.ndarray:
        """Table angles, shape (n, k), deg."""
        return np.stack([self.columns[f"angle_{a}_deg"] for a in self.axis_names], axis=1)

    @property
    def segment_id(self) -> np.ndarray:
        """Integer id of the continuous segment of each sample (CONVENTIONS §5)."""
        return continuous_segments(self.time_s, self.columns.get("segment"))

    @property
    def rates_derived(self) -> bool:
        """True when at least one table rate is derived from the angles (no ``rate_<axis>_dps`` column)."""
        return any(f"rate_{a}_dps" not in self.columns for a in self.axis_names)

    @property
    def rates_dps(self) -> np.ndarray:
        """Table rates, shape (n, k), deg/s: the rate columns where given, else derived inside segments."""
        seg = None  # the segment ids only when a rate has to be derived
        out = []
        for a in self.axis_names:
            col = self.columns.get(f"rate_{a}_dps")
            if col is None:
                seg = self.segment_id if seg is None else seg
                col = derive_rate(self.time_s, self.columns[f"angle_{a}_deg"], seg)
            out.append(col)
        return np.stack(out, axis=1)

    @property
    def current_mA(self) -> np.ndarray:
        """Torquer current; servo records without the column have 0 (commanded current)."""
        if self.kind == TDF:
            return np.stack([self.columns["current_x_mA"], self.columns["current_y_mA"]], axis=1)
        col = self.columns.get("current_mA")
        return np.zeros(self.n) if col is None else col

    @property
    def indicated(self) -> np.ndarray:
        """Indicated output S_nom·i: deg/h for gyros (TDF: shape (n, 2)), g for accelerometers."""
        return self.scale_factor * self.current_mA

    @property
    def temperature_C(self) -> np.ndarray | None:
        """Instrument temperature, °C, shape (n,); None when the record has no such column."""
        return self.columns.get("temperature_C")

    def to_pandas(self):
        """The CSV columns as a ``pandas.DataFrame`` (with ``segment_id`` added); metadata in ``.attrs``."""
        import pandas as pd

        df = pd.DataFrame(self.columns)
        df["segment_id"] = self.segment_id
        df.attrs.update(copy.deepcopy(self.meta))
        return df

    def with_columns(self, **cols) -> "Record":
        """A copy with some columns replaced or added."""
        new = dict(self.columns)
        new.update({k: np.asarray(v, dtype=float) for k, v in cols.items()})
        return Record(copy.deepcopy(self.meta), new, self.path)


def continuous_segments(time_s: np.ndarray, segment: np.ndarray | None = None) -> np.ndarray:
    """Label continuous runs: a new one starts where ``segment`` changes or the step exceeds 1.5 × median."""
    n = len(time_s)
    if n < 2:
        return np.zeros(n, dtype=np.int64)
    dt = np.diff(time_s)
    brk = dt > GAP_FACTOR * np.median(dt)
    if segment is not None:
        brk |= segment[1:] != segment[:-1]
    out = np.empty(n, dtype=np.int64)
    out[0] = 0
    np.cumsum(brk, out=out[1:])
    return out


JITTER_TOL = 0.05
"""Largest relative deviation of a step from the mean sample interval that :func:`uniform_interval` accepts as
logger jitter (5 %): a 204.8 Hz clock written with a few digits, or a logger's 9.9–10.05 ms steps."""


def uniform_interval(time_s, tol: float = JITTER_TOL) -> tuple[float, float]:
    """The mean sample interval of ``time_s`` (s) and its jitter, the largest |step − mean| / mean (dimensionless).

    Timestamps of real loggers jitter (rounding to a few digits, a clock read by software): the samples are taken
    uniformly, the stamps are not. Raises :class:`~gyrojax.errors.RecordError` when a step departs from the mean
    by more than ``tol`` (a gap or a changed rate, not jitter) or when there are fewer than two samples.
    """
    t = np.asarray(time_s, dtype=float)
    if t.size < 2:
        raise RecordError("a sample interval needs at least two samples")
    mean = float((t[-1] - t[0]) / (t.size - 1))
    if not mean > 0:
        raise RecordError("times must increase to define a sample interval")
    dev = np.diff(t)
    dev -= mean
    np.abs(dev, out=dev)  # |step − mean|, in place (one array of n − 1 for a long record)
    jitter = float(np.max(dev)) / mean
    if jitter > tol:
        i = int(np.argmax(dev))
        dt = np.diff(t)
        raise RecordError(
            f"step {i + 1} is {dt[i]:.6g} s against a mean interval of {mean:.6g} s ({100 * jitter:.3g} % off; "
            f"logger jitter up to {100 * tol:.3g} % is accepted): a gap or a change of sample rate"
        )
    return mean, jitter


def interval_key(dt_s: float, digits: int = 3) -> float:
    """A sample interval (s) rounded to ``digits`` significant digits: the key that tells records sampled at the
    same rate apart from others, whatever the last digits of their timestamps."""
    if not dt_s > 0 or not math.isfinite(dt_s):
        return 0.0
    return float(f"{dt_s:.{digits}g}")


def derive_rate(time_s: np.ndarray, angle_deg: np.ndarray, segment_id: np.ndarray) -> np.ndarray:
    """Angle rate (deg/s) by second-order differences, inside each continuous segment only."""
    rate = np.zeros_like(angle_deg, dtype=float)
    starts = np.flatnonzero(np.diff(segment_id, prepend=-1))
    ends = np.append(starts[1:], len(time_s))
    for s, e in zip(starts, ends):
        if e - s >= 2:
            rate[s:e] = np.gradient(angle_deg[s:e], time_s[s:e])
    return rate


# ---- loading and validation ----------------------------------------------------------------------------------


def record_paths(path: str | os.PathLike) -> tuple[Path, Path]:
    """(csv, json) paths of a record given either file (or the common stem)."""
    p = Path(path)
    if p.suffix.lower() in (".csv", ".json"):
        stem = p.with_suffix("")
    else:
        stem = p
    return stem.with_suffix(".csv"), stem.with_suffix(".json")


def _err(file, msg):
    return RecordError(f"{file}: {msg}")


def _unit_vector(file, key, v):
    if not isinstance(v, (list, tuple)) or len(v) != 3 or any(isinstance(x, bool) for x in v):
        raise _err(file, f"key {key!r} must be a list of 3 numbers (a unit vector), got {v!r}")
    try:
        arr = np.array([float(x) for x in v])
    except (TypeError, ValueError, OverflowError):
        raise _err(file, f"key {key!r} must hold 3 numbers, got {v!r}") from None
    if not np.all(np.isfinite(arr)):
        raise _err(file, f"key {key!r} has a non-finite component: {v!r}")
    norm = float(np.linalg.norm(arr))
    if abs(norm - 1.0) > AXIS_TOL:
        raise _err(file, f"key {key!r} is not a unit vector (norm {norm:.9g}; tolerance {AXIS_TOL})")
    return arr


def _require(file, d, key, where=""):
    if not isinstance(d, dict) or key not in d:
        raise _err(file, f"missing required key {where + key!r}")
    return d[key]


def _number(file, d, key, where=""):
    v = _require(file, d, key, where)
    if not is_finite_number(v):
        raise _err(file, f"key {where + key!r} must be a finite number, got {v!r}")
    return float(v)


def validate_meta(meta, file="record.json") -> dict:
    """Check a record's JSON against CONVENTIONS §5; returns it unchanged (unknown keys kept)."""
    if not isinstance(meta, dict):
        raise _err(file, "the top level must be a JSON object")
    fmt = _require(file, meta, "format")
    if fmt != FORMAT:
        raise _err(file, f"key 'format' is {fmt!r}; this reader knows {FORMAT!r}")
    name = _require(file, meta, "name")
    if not isinstance(name, str) or not name:
        raise _err(file, "key 'name' must be a non-empty string")
    if is_triad(meta):  # a hand-moved IMU: no table, segments instead (gyrojax.data.triad)
        return validate_triad_meta(meta, file)
    site = _require(file, meta, "site")
    lat = _number(file, site, "latitude_deg", "site.")
    if not -90.0 <= lat <= 90.0:
        raise _err(file, f"key 'site.latitude_deg' must lie in [-90, 90], got {lat}")
    g = _number(file, site, "gravity_mps2", "site.")
    if not 9.7 <= g <= 9.9:
        raise _err(file, f"key 'site.gravity_mps2' = {g} is not a gravity on the Earth's surface (9.7–9.9 m/s²)")
    table = _require(file, meta, "table")
    axes = _require(file, table, "axes", "table.")
    if not isinstance(axes, list) or not axes:
        raise _err(file, "key 'table.axes' must be a non-empty list of {name, axis_enu}")
    seen = set()
    for i, ax in enumerate(axes):
        where = f"table.axes[{i}]."
        nm = _require(file, ax, "name", where)
        if not isinstance(nm, str) or not nm or "," in nm:
            raise _err(file, f"key {where + 'name'!r} must be a non-empty string without commas")
        if nm in seen:
            raise _err(file, f"key {where + 'name'!r}: axis name {nm!r} is used twice")
        seen.add(nm)
        _unit_vector(file, where + "axis_enu", _require(file, ax, "axis_enu", where))
    inst = _require(file, meta, "instrument")
    kind = _require(file, inst, "kind", "instrument.")
    if kind not in INSTRUMENT_KINDS:
        raise _err(file, f"key 'instrument.kind' is {kind!r}; valid: {', '.join(INSTRUMENT_KINDS)}")
    keys = TRIAD_KEYS[kind]
    vecs = [_unit_vector(file, f"instrument.{k}", _require(file, inst, k, "instrument.")) for k in keys]
    for i in range(3):
        for j in range(i + 1, 3):
            d = float(vecs[i] @ vecs[j])
            if abs(d) > AXIS_TOL:
                raise _err(
                    file,
                    f"keys 'instrument.{keys[i]}' and 'instrument.{keys[j]}' are not orthogonal (dot {d:.3g})",
                )
    # right-handed: first × second = third (IA × OA = SA; X × Y = Z; IA × PA = OA)
    hand = float(np.cross(vecs[0], vecs[1]) @ vecs[2])
    if hand < 0:
        raise _err(
            file,
            f"key 'instrument.{keys[2]}': the triad is left-handed; "
            f"{keys[0]} × {keys[1]} must equal {keys[2]} (it equals −{keys[2]})",
        )
    mode = _require(file, meta, "mode")
    if mode not in ("rebalance", "servo"):
        raise _err(file, f"key 'mode' is {mode!r}; valid: 'rebalance', 'servo'")
    sf_key = "scale_factor_g_per_mA" if kind == ACCEL else "scale_factor_deg_per_h_per_mA"
    sf = _number(file, meta, sf_key)
    if sf == 0.0:
        raise _err(file, f"key {sf_key!r} must be non-zero")
    servo = meta.get("servo_axis")
    if mode == "servo":
        if servo is None:
            raise _err(file, "key 'servo_axis' must name a table axis when mode is 'servo'")
        if kind == TDF:
            raise _err(file, "key 'mode': servo mode is supported for sdf-gyro and pendulous-accel only")
    if servo is not None and (not isinstance(servo, str) or servo not in seen):
        raise _err(file, f"key 'servo_axis' is {servo!r}; table axes are {sorted(seen)}")
    return meta


NUMERIC_COLUMNS = ("time_s", "segment", "temperature_C", "current_mA", "current_x_mA", "current_y_mA")
TRIAD_COLUMN_PREFIXES = ("gyro_", "acc_")  # triad records (gyrojax.data.triad): gyro_<c>_dps|counts, acc_<c>_g


def must_be_numeric(column: str) -> bool:
    """Columns of CONVENTIONS §5 (these must hold finite numbers); any other column is extra, kept and ignored."""
    return (
        column in NUMERIC_COLUMNS
        or (column.startswith("angle_") and column.endswith("_deg"))
        or (column.startswith("rate_") and column.endswith("_dps"))
        or column.startswith(TRIAD_COLUMN_PREFIXES)
    )


def read_csv_bytes(csv_path: Path) -> bytes:
    """The bytes of a record's CSV file; :class:`~gyrojax.errors.RecordError` naming the file when it cannot be
    read."""
    try:
        with open(csv_path, "rb") as fh:
            raw = fh.read()
    except OSError as e:
        raise _err(csv_path, f"cannot read: {e.strerror} (a record is NAME.csv + NAME.json, both files)") from None
    if not raw.isascii():
        try:
            raw.decode("utf-8")
        except UnicodeDecodeError as e:
            row = raw[: e.start].count(b"\n") + 1
            raise _err(
                csv_path, f"row {row} is not UTF-8 (byte {e.start}: 0x{raw[e.start]:02x}); save the file as UTF-8"
            ) from None
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]  # a UTF-8 byte-order mark is fine
    if b"\x00" in raw[:65536]:
        row = raw[: raw.index(b"\x00")].count(b"\n") + 1
        raise _err(csv_path, f"row {row} holds a NUL byte: this is not a text file; records are UTF-8 CSV")
    if not raw[:4096].strip() and not raw.strip():
        raise _err(csv_path, "is empty; a header row and at least one sample are required")
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
        raise _err(csv_path, f"row 1 (header) is not a comma-separated line ({e}); a stray carriage return?") from None
    if not header:
        raise _err(csv_path, "row 1 (header) is empty; it must name the columns (time_s, angle_<axis>_deg, …)")
    if len(header) == 1:
        for sep in (";", "\t", "|"):
            if sep in header[0]:
                raise _err(
                    csv_path,
                    f"row 1 (header) is one column {header[0][:60]!r}: the file looks {sep!r}-separated; "
                    "records must be comma separated (CONVENTIONS §5)",
                )
    for j, h in enumerate(header):
        if not h:
            raise _err(csv_path, f"row 1 (header), column {j + 1} has no name; every column must be named")
        if header.count(h) > 1:
            k = header.index(h, j + 1)
            raise _err(
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
            raise _err(
                csv_path, f"row {reader.line_num} is not a valid CSV row ({e}); a stray carriage return or quote?"
            ) from None
        yield reader.line_num, row


def diagnose_csv(csv_path: Path, raw: bytes, header: list[str], strict: bool) -> None:
    """Stream the rows and raise at the first row of the wrong length or the first bad numeric cell.

    ``strict``: check every column (else only the columns of CONVENTIONS §5).
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
            raise _err(
                csv_path,
                f"row {i} has {len(row)} of {n} fields: column {header[len(row)]!r} is missing "
                "(is the file truncated?); every row needs one value per header column",
            )
        if len(row) > n:
            raise _err(
                csv_path,
                f"row {i} has {len(row)} fields but the header names {n} columns; "
                "every row needs one value per header column",
            )
        for j in check:
            v = row[j].strip()
            if v == "":
                raise _err(csv_path, f"row {i}, column {header[j]!r} is empty; a finite number is required")
            try:
                x = float(v)
            except ValueError:
                raise _err(
                    csv_path,
                    f"row {i}, column {header[j]!r} holds {v[:40]!r}, not a number; a finite number is required",
                ) from None
            if not math.isfinite(x):
                raise _err(csv_path, f"row {i}, column {header[j]!r} holds {v!r}; values must be finite numbers")


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


def _parse_csv(csv_path: Path) -> tuple[list[str], dict[str, np.ndarray]]:
    """Header and columns of a record CSV, naming the row and column of the first bad cell.

    Fast path: a plain ASCII file memory-mapped (:func:`_mapped_plain_csv`) and every cell parsed to float64
    (:func:`_float_table`). Otherwise, or on any failure, the bytes are read and checked (:func:`read_csv_bytes`)
    and the rows streamed again to name the first bad row and column; extra columns that are not numeric are kept
    as text.
    """
    import io

    import pandas as pd

    df = raw = None
    mm = _mapped_plain_csv(csv_path)
    if mm is not None:
        with mm:
            header = parse_csv_header(csv_path, mm[: mm.find(b"\n") + 1])
            df = _float_table(mm, header)
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
            raise _err(csv_path, f"is not a valid comma-separated table: {str(e).strip()}") from None
    if len(df) == 0:
        raise _err(csv_path, "has a header but no samples; at least one sample row is required")
    cols = {}
    for h in header:
        col = df[h].to_numpy()
        if col.dtype == np.float64 and must_be_numeric(h) and not np.all(np.isfinite(col)):
            diagnose_csv(csv_path, read_csv_bytes(csv_path) if raw is None else raw, header, strict=False)
            i = int(np.flatnonzero(~np.isfinite(col))[0])
            raise _err(csv_path, f"row {i + 2}, column {h!r} holds {float(col[i])}; values must be finite numbers")
        cols[h] = col if col.dtype == np.float64 else col.astype(str)
    return header, cols


def _column_hint(columns, want: str) -> str:
    """A hint when a required column seems present under another spelling (a unit in the name, other case)."""
    import re

    for c in columns:
        base = re.sub(r"\s*[\[(].*$", "", c).strip()
        if c != want and base == want:
            return (
                f"; column {c!r} looks like {want!r} with a unit: units are fixed by CONVENTIONS §5, "
                f"so name it exactly {want!r}"
            )
        if c != want and c.lower() == want.lower():
            return f"; column {c!r} differs only in case: name it exactly {want!r}"
    return ""


def validate_columns(meta: dict, columns: dict[str, np.ndarray], file="record.csv") -> None:
    """Check the CSV columns against the metadata (CONVENTIONS §5)."""
    if "time_s" not in columns:
        hint = _column_hint(columns, "time_s")
        raise _err(file, f"missing required column 'time_s'{hint}; columns are {list(columns)}")
    if is_triad(meta):
        _check_times(columns["time_s"], file)
        return validate_triad_columns(meta, columns, file)
    _check_times(columns["time_s"], file)
    names = [a["name"] for a in meta["table"]["axes"]]
    for a in names:
        if f"angle_{a}_deg" not in columns:
            hint = [c for c in columns if c.startswith("angle_")]
            raise _err(
                file,
                f"missing required column 'angle_{a}_deg' for table axis {a!r}"
                f"{_column_hint(columns, f'angle_{a}_deg')}; angle columns: {hint}",
            )
    kind = meta["instrument"]["kind"]
    if meta["mode"] == "rebalance":
        need = ("current_x_mA", "current_y_mA") if kind == TDF else ("current_mA",)
        for c in need:
            if c not in columns:
                raise _err(file, f"missing required column {c!r} (rebalance mode, {kind}){_column_hint(columns, c)}")
    if "segment" in columns:
        seg = columns["segment"]
        if np.any(seg != np.round(seg)):
            i = int(np.flatnonzero(seg != np.round(seg))[0])
            raise _err(file, f"row {i + 2}, column 'segment' holds {float(seg[i])}; segment labels are integers")


def _check_times(t, file) -> None:
    if len(t) > 1:
        bad = t[1:] <= t[:-1]  # a step that is not positive (same as diff <= 0 for finite times)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            what = "repeats" if t[i + 1] == t[i] else "decreases from"
            raise _err(
                file,
                f"row {i + 3}, column 'time_s': time {what} the previous row's {float(t[i])} (got {float(t[i + 1])}); "
                "times must be strictly increasing",
            )


def _no_duplicate_keys(json_path):
    def hook(pairs):
        seen = set()
        for k, _ in pairs:
            if k in seen:
                raise _err(json_path, f"key {k!r} appears twice in one object; each key must appear once")
            seen.add(k)
        return dict(pairs)

    return hook


def read_meta(json_path: Path) -> dict:
    """The record JSON as a dict (UTF-8, a BOM allowed; duplicate keys are errors), not yet validated."""
    try:
        raw = json_path.read_bytes()
    except OSError as e:
        raise _err(json_path, f"cannot read: {e.strerror} (a record is NAME.csv + NAME.json, both files)") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line = raw[: e.start].count(b"\n") + 1
        raise _err(json_path, f"is not UTF-8 (line {line}, byte {e.start}); save it as UTF-8") from None
    if not text.strip():
        raise _err(json_path, "is empty; a JSON object with the record's metadata (CONVENTIONS §5) is required")
    try:
        return json.loads(text, object_pairs_hook=_no_duplicate_keys(json_path))
    except json.JSONDecodeError as e:
        raise _err(json_path, f"is not valid JSON: {e.msg} at line {e.lineno}, column {e.colno}") from None


def load_record(path: str | os.PathLike) -> Record:
    """Load and validate one record from ``NAME.csv`` or ``NAME.json`` (either path works)."""
    csv_path, json_path = record_paths(path)
    for p in (json_path, csv_path):
        if not p.exists():
            raise RecordError(f"{p}: no such file (a record is NAME.csv + NAME.json side by side)")
    meta = read_meta(json_path)
    validate_meta(meta, json_path)
    _, columns = _parse_csv(csv_path)
    validate_columns(meta, columns, csv_path)
    return Record(meta, columns, str(csv_path))


def load_records(paths) -> list[Record]:
    """Load several records (a campaign). A directory loads every record in it, sorted by name."""
    out = []
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    for p in paths:
        p = Path(p)
        if p.is_dir():
            stems = sorted({q.with_suffix("") for q in p.glob("*.json")} & {q.with_suffix("") for q in p.glob("*.csv")})
            if not stems:
                raise RecordError(f"{p}: directory holds no record (a record is NAME.csv + NAME.json side by side)")
            out.extend(load_record(s.with_suffix(".json")) for s in stems)
        else:
            out.append(load_record(p))
    names = [r.name for r in out]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise RecordError(f"records named {sorted(dup)} appear twice in the campaign")
    return out


def _fmt(x) -> str:
    if isinstance(x, str):  # an extra text column, kept as read
        return x if not any(c in x for c in ',"\n\r') else '"' + x.replace('"', '""') + '"'
    return repr(float(x)) if x != 0 else "0"


CSV_CHUNK_ROWS = 100_000


def record_csv_chunks(record: Record, rows: int = CSV_CHUNK_ROWS):
    """The CSV text of a record in pieces of ``rows`` rows (full float64 precision), header first."""
    header = list(record.columns)
    cols = [record.columns[h] for h in header]
    yield ",".join(header) + "\n"
    for s in range(0, record.n, rows):
        part = zip(*(c[s : s + rows] for c in cols))
        yield "\n".join(",".join(_fmt(v) for v in row) for row in part) + "\n"


def _write_temp(path: Path, pieces) -> str:
    """Write text pieces to a temporary file beside ``path``; returns its name (the caller renames it)."""
    import tempfile

    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            for piece in pieces:
                fh.write(piece.encode("utf-8"))
    except BaseException:
        os.unlink(tmp)
        raise
    return tmp


def save_record(record: Record, directory: str | os.PathLike, force: bool = False) -> Path:
    """Write ``NAME.csv`` and ``NAME.json`` into ``directory`` atomically; returns the JSON path.

    Refuses to overwrite existing files unless ``force``; validates before writing anything; a failure while
    writing leaves no partial file behind.
    """
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    validate_meta(record.meta, f"{record.name}.json")
    validate_columns(record.meta, record.columns, f"{record.name}.csv")
    csv_path, json_path = d / f"{record.name}.csv", d / f"{record.name}.json"
    if not force:
        for p in (csv_path, json_path):
            if p.exists():
                raise RecordError(f"{p}: exists; pass force=True (or --force) to overwrite")
    # both files go to temporary names first (the CSV streamed in chunks, so memory stays one chunk), then are
    # renamed: a failure while writing leaves no partial file and never touches an existing record
    temps = []
    try:
        temps.append(_write_temp(csv_path, record_csv_chunks(record)))
        temps.append(_write_temp(json_path, [json.dumps(record.meta, indent=1) + "\n"]))
        os.replace(temps[0], csv_path)
        os.replace(temps[1], json_path)
    except BaseException:
        for t in temps:
            if os.path.exists(t):
                os.unlink(t)
        raise
    return json_path
