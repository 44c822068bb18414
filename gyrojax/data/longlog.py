"""Logs too long to hold — hours of an IMU at rest at a high rate, 10⁷–10⁸ samples — imported in chunks: the log read
:data:`~gyrojax.data.stream.CHUNK_ROWS` rows at a time (a progress bar on a terminal), each chunk checked (every
cell a finite number, the time increasing), said (ranges, the clock) and written at once into the record's CSV
(:func:`format_rows`, numpy-vectorised text), while the variance of each short block of samples is kept (a few
numbers per 0.2 s). From those the rests are found after the pass, as :mod:`gyrojax.data.segments` finds them on
a log held whole (each block's variance against the median block's, the threshold a multiple of that noise from
the χ² law of a block), and the record's ``segment`` column — written last in each row, two characters wide — is
patched in place where the log moves. The record is the rest log :mod:`gyrojax.data.restlog` describes; memory is
one chunk and the block statistics, flat in the log's length.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gyrojax import units
from gyrojax.data.door import check_rest_gyro
from gyrojax.data.logs import TIME_UNITS, file_stem, log_clock, table_layout
from gyrojax.data.segments import WINDOW_S, default_threshold, window_samples
from gyrojax.data.stream import CHUNK_ROWS, Progress
from gyrojax.data.timebase import true_runs
from gyrojax.data.triad import CHANNELS
from gyrojax.errors import RecordError
from gyrojax.physics.gravity import site_gravity

_POW10 = 10 ** np.arange(19, dtype=np.int64)


def format_column(x: np.ndarray, decimals: int) -> np.ndarray:
    """The numbers ``x`` as right-aligned text of ``decimals`` decimals, one row of ASCII bytes per number, all of
    one width (n, w): the sign beside the first digit, blanks before it (a float parser skips them). Integers of a
    narrow range (counts) are looked up in a table of their texts; others are cut into digits all at once."""
    v = np.rint(np.asarray(x, dtype=np.float64) * 10.0**decimals).astype(np.int64)
    lo, hi = (int(v.min()), int(v.max())) if len(v) else (0, 0)
    if hi - lo <= 1 << 17 and len(v) > 4 * (hi - lo + 1):
        table = _texts(np.arange(lo, hi + 1, dtype=np.int64), decimals)
        return table[v - lo]
    return _texts(v, decimals)


_PAIRS = np.array([[48 + i // 10, 48 + i % 10] for i in range(100)], dtype=np.uint8)
"""The two ASCII digits of 0 … 99."""


def _texts(v: np.ndarray, decimals: int) -> np.ndarray:
    """(n, w) ASCII of the integers ``v`` written with ``decimals`` decimals (:func:`format_column`): two digits at
    a time from a table, in 32-bit arithmetic when the numbers allow."""
    neg = v < 0
    a = np.abs(v)
    ndig = np.maximum(np.searchsorted(_POW10, a, side="right"), decimals + 1)
    k = int(ndig.max())
    pairs = (k + 1) // 2
    a = a.astype(np.int32) if k <= 9 else a
    hundred = np.asarray(100, dtype=a.dtype)
    text = np.empty((len(v), 2 * pairs), dtype=np.uint8)
    q = a
    for j in range(pairs):  # the pair of 10^(2j), 10^(2j+1), written right to left
        q, r = np.divmod(q, hundred)
        text[:, 2 * (pairs - j) - 2 : 2 * (pairs - j)] = _PAIRS[r]
    text = text[:, 2 * pairs - k :]
    lead = np.arange(k)[None, :] < (k - ndig)[:, None]
    text[lead] = 32
    if neg.any():  # the sign just before the first digit
        text = np.concatenate([np.full((len(v), 1), 32, np.uint8), text], axis=1)
        text[np.flatnonzero(neg), k - ndig[neg]] = ord("-")
    if decimals > 0:
        w = text.shape[1]
        text = np.concatenate([text[:, : w - decimals], np.full((len(v), 1), 46, np.uint8), text[:, w - decimals :]], 1)
    return np.ascontiguousarray(text)


def format_rows(columns: list, decimals: list, segment: int = 0) -> tuple[bytes, int, int]:
    """CSV rows of ``columns`` (each (n,) floats, written with its ``decimals``) and a last ``segment`` column two
    characters wide; returns (bytes, row length, position of the segment field in a row)."""
    parts = []
    for x, d in zip(columns, decimals):
        parts += [format_column(x, d), np.full((len(x), 1), ord(","), np.uint8)]
    seg = np.frombuffer(f"{segment:2d}\n".encode(), np.uint8)
    parts.append(np.broadcast_to(seg, (len(columns[0]), 3)))
    rows = np.concatenate(parts, axis=1)
    return rows.tobytes(), rows.shape[1], rows.shape[1] - 3


def decimals_for(x: np.ndarray, most: int = 9) -> int:
    """The fewest decimals (≤ ``most``) that write the numbers ``x`` back (to 1e-12 of each: 0.001·k computed in
    binary is 3 decimals; 0 for counts)."""
    for d in range(most + 1):
        if np.allclose(np.round(x, d), x, rtol=1e-12, atol=0.0):
            return d
    return most


QUANTUM_OF_NOISE = 1e-3
"""A channel's decimals write it to this fraction of its sample-to-sample noise (or exactly, when fewer
decimals do): the rounding adds (10⁻³)²/12 ≈ 10⁻⁷ of the noise variance, far below any Allan variance's
sampling error."""


def noise_decimals(x: np.ndarray) -> int:
    """Decimals for a channel (:data:`QUANTUM_OF_NOISE`): exact if at most that many are needed, at most 9."""
    sigma = float(np.std(np.diff(x)) / np.sqrt(2.0)) if len(x) > 2 else 0.0
    cap = int(np.clip(np.ceil(-np.log10(QUANTUM_OF_NOISE * sigma)), 0, 9)) if sigma > 0 else 9
    return min(decimals_for(x), cap)


class _Blocks:
    """Mean and variance per channel of consecutive blocks of ``size`` samples, over chunks (a partial block waits
    for the next chunk)."""

    def __init__(self, size: int, channels: int):
        self.size = size
        self.rest = np.zeros((0, channels))
        self.means: list = []
        self.vars: list = []

    def add(self, x: np.ndarray) -> None:
        x = np.concatenate([self.rest, x]) if len(self.rest) else x
        k = len(x) // self.size
        b = x[: k * self.size].reshape(k, self.size, x.shape[1])
        self.means.append(b.mean(axis=1))
        self.vars.append(b.var(axis=1, ddof=1))
        self.rest = x[k * self.size :].copy()

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        return np.concatenate(self.means), np.concatenate(self.vars)


def still_blocks(var: np.ndarray, size: int, sensors: dict, floor: np.ndarray) -> tuple[np.ndarray, dict]:
    """Which blocks rest: per sensor (name → its columns of ``var``), the block variances in units of the median
    block's (the rest noise of a log that rests most of the time; at least ``floor``, the LSB²/12), averaged over
    the sensor's channels, at most the threshold of :func:`gyrojax.data.segments.default_threshold` for a block's
    ``size`` − 1 degrees of freedom (the probability that a block of rest noise exceeds it is 10⁻⁶). Returns the
    mask and the thresholds."""
    still = np.ones(len(var), dtype=bool)
    thr = {}
    for name, cols in sensors.items():
        noise = np.maximum(np.median(var[:, cols], axis=0), np.maximum(floor[cols], 1e-300))
        ratio = (var[:, cols] / noise).mean(axis=1)
        thr[name] = default_threshold(size - 1.0)
        still &= ratio <= thr[name]
    return still, thr


def import_long_csv(
    path,
    mapping: dict,
    out_dir,
    *,
    gyro_unit: str = "dps",
    gyro_counts_per_dps: float | None = None,
    acc_unit: str = "g",
    acc_counts_per_g: float | None = None,
    rate_hz: float | None = None,
    time_unit: str | None = None,
    delimiter: str | None = None,
    latitude_deg: float | None = None,
    gravity_mps2: float | None = None,
    min_rest_s: float = 0.5,
    name: str | None = None,
    instrument_id: str | None = None,
    force: bool = False,
    rows_hint: int = 0,
) -> Path:
    """Import a rest log too long to hold (module doc) into ``out_dir``; returns the record's JSON path. Options
    as :func:`gyrojax.data.importers.import_csv` (``time_unit`` s, ms, us or ns); a sample counter (``sample``) is
    not taken here."""
    gravity_mps2 = site_gravity(latitude_deg) if gravity_mps2 is None else float(gravity_mps2)
    from gyrojax.data.importers import gyro_record_columns
    from gyrojax.data.records import record_paths
    from gyrojax.data.restlog import REST_LOG_COVERAGE, SAME_ORIENTATION_DEG, rest_accelerometer
    from gyrojax.data.triad import triad_meta, validate_triad_meta
    from gyrojax.protocol import atomic_write_text

    where = str(path)
    if "sample" in mapping:
        raise RecordError(f"{where}: a log this long is read in chunks, with a time column or a rate, not a counter")
    time_col = mapping.get("time", mapping.get("time_s"))
    acc_keys = [f"acc_{c}" for c in CHANNELS if f"acc_{c}" in mapping]
    gyro_names = [mapping[f"gyro_{c}"] for c in CHANNELS]
    acc_names = [mapping[k] for k in acc_keys]
    notes: list[str] = []
    sep, skip, preamble, decimal = table_layout(path, delimiter, notes)
    name = name or file_stem(path)
    out_dir = Path(out_dir)
    csv_path, json_path = record_paths(out_dir / name)
    if not force:
        for p in (csv_path, json_path):
            if p.exists():
                raise RecordError(f"{p}: exists; pass --force to overwrite")
    out_dir.mkdir(parents=True, exist_ok=True)
    import pandas as pd

    wanted = ([time_col] if time_col else []) + gyro_names + acc_names
    try:
        header = pd.read_csv(path, sep=sep, skiprows=skip, nrows=0, skipinitialspace=True).columns
    except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as e:
        raise RecordError(f"{where}: not a readable table ({str(e).strip()[:120]})") from None
    header = [str(h).strip() for h in header]
    miss = [c for c in wanted if c not in header]
    if miss:
        raise RecordError(f"{where}: columns {miss} (from the mapping) are not in the file; it has {header}")
    scale_t = TIME_UNITS[time_unit or "s"]
    progress = Progress("import", rows_hint)
    fd, tmp = tempfile.mkstemp(prefix=f".{csv_path.name}.", suffix=".tmp", dir=out_dir)
    try:
        with os.fdopen(fd, "wb") as fh:
            cols_out = ["time_s", *[f"gyro_{c}_{'counts' if gyro_unit == 'counts' else 'dps'}" for c in CHANNELS]]
            cols_out += [f"acc_{c}_g" for c in CHANNELS][: len(acc_names)]
            fh.write((",".join([*cols_out, "segment"]) + "\n").encode())
            log = _Log(
                path,
                sep,
                skip,
                decimal,
                wanted,
                time_col,
                scale_t,
                rate_hz,
                preamble,
                gyro_names,
                acc_names,
                gyro_unit,
                gyro_counts_per_dps,
                acc_unit,
                acc_counts_per_g,
                where,
            )
            state = _pass(pd, log, fh, progress)
        progress.close()
        n = state["n"]
        kw = dict(rate_hz=rate_hz, preamble=preamble)
        if time_col:
            kw.update(
                span=(state["t_first"], state["t_last"]),
                time_source=f"the time column {time_col!r} ({time_unit or 's'})",
            )
        _, clock = log_clock(n, where, **kw)
        rate = clock["rate_hz"]
        means, var = state["blocks"].arrays()
        size = state["blocks"].size
        sensors = {"gyro": [0, 1, 2]} | ({"acc": [3, 4, 5]} if acc_names else {})
        still, thr = still_blocks(var, size, sensors, state["floor"])
        rests = []
        for s, e in true_runs(still):
            s2, e2 = s + (s > 0), e - (e < len(still))  # a block beside a move is no rest
            if (e2 - s2) * size >= min_rest_s * rate and e2 > s2:
                rests.append((s2, e2))
        if not rests:
            raise RecordError(f"{where}: no rest found in {n} samples; a log this long is imported as a rest log")
        iv = [(s * size, e * size if e < len(still) else n) for s, e in rests]  # the last rest keeps the tail
        covered = sum(e - s for s, e in iv) / n
        moving = f"its rests cover {covered:.1%} of it (a rest log: at least {REST_LOG_COVERAGE:.0%})"
        if covered < REST_LOG_COVERAGE or len(rests) >= 9:
            raise RecordError(
                f"{where}: a log of {n} samples is read in chunks as a rest log, and this one moves: "
                f"{moving}; {len(rests)} rests"
            )
        gyro_dps = means[:, :3] / (gyro_counts_per_dps or 1.0) if gyro_unit == "counts" else means[:, :3]
        door = {"clock": clock, "ranges": state["ranges"], "range_units": state["range_units"]}
        door["rest_gyro"] = check_rest_gyro(gyro_dps, rests, where, gyro_unit)
        if acc_names:
            u = np.array([means[s:e, 3:].mean(axis=0) for s, e in rests])
            u /= np.linalg.norm(u, axis=1, keepdims=True)
            if np.any(u @ u[0] < np.cos(np.radians(SAME_ORIENTATION_DEG))):
                raise RecordError(
                    f"{where}: a log of {n} samples is read in chunks as a rest log, and its rests "
                    "point in different directions: a hand session this long?"
                )
            g_units = gravity_mps2 / units.G0
            rest_means_g = np.array([[means[s:e, 3:].mean(axis=0)] for s, e in rests]).reshape(len(rests), 3)
            _, rest_g, acc_notes = rest_accelerometer(
                rest_means_g, [(k, k + 1) for k in range(len(rests))], "g", g_units, None, where
            )
            notes += acc_notes
            door["rest_gravity"] = rest_g
        _patch_segments(tmp, state["chunks"], iv, n)
        segs = [{"label": i, "type": "static", "name": f"rest-{i}"} for i in range(len(iv))]
        report = {
            "source": where,
            "kind": "rest log",
            **door,
            "rests_found": len(iv),
            "rests": [[round(s / rate, 4), round(e / rate, 4)] for s, e in iv],
            "dropped": [],
            "joined": [],
            "window_s": size / rate,
            "static_threshold": thr,
            "min_rest_s": float(min_rest_s),
            "read_in_chunks": {"rows": n, "chunk_rows": CHUNK_ROWS, "block_samples": size},
            "written": state["written"],
            "notes": notes + state["notes"],
        }
        _, counts_per_dps = gyro_record_columns(np.zeros((1, 3)), gyro_unit, gyro_counts_per_dps, where)
        meta = triad_meta(
            name,
            segs,
            latitude_deg=latitude_deg,
            gravity_mps2=gravity_mps2,
            counts_per_dps=counts_per_dps,
            instrument_id=instrument_id,
            extra={"import": report},
            notes=f"imported from {where}: a rest log: {len(iv)} rest(s) covering {covered:.1%} of "
            f"{clock['duration_s']:.6g} s ({rate:.6g} Hz), read in chunks",
        )
        validate_triad_meta(meta, json_path)
        os.replace(tmp, csv_path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    import json

    atomic_write_text(json_path, json.dumps(meta, indent=1) + "\n")
    return json_path


@dataclass(frozen=True)
class _Log:
    """What :func:`_pass` reads: the file, its layout and columns, its clock and its units."""

    path: object
    sep: str
    skip: int
    decimal: str
    wanted: list
    time_col: str | None
    scale_t: float
    rate_hz: float | None
    preamble: list
    gyro_names: list
    acc_names: list
    gyro_unit: str
    gyro_scale: float | None
    acc_unit: str
    acc_scale: float | None
    where: str


def _pass(pd, log: _Log, fh, progress) -> dict:
    """The one pass over the log: read, check, say, write, keep the block statistics."""
    from gyrojax.data.importers import gyro_record_columns
    from gyrojax.data.logs import numeric_columns, preamble_rate
    from gyrojax.data.segments import quantum

    def chunks(dtype):
        return pd.read_csv(
            log.path,
            sep=log.sep,
            skiprows=log.skip,
            skipinitialspace=True,
            decimal=log.decimal,
            usecols=lambda c: c.strip() in log.wanted,
            chunksize=CHUNK_ROWS,
            dtype=dtype,
        )

    def frames():
        try:
            yield from chunks(np.float64)  # pandas' C parser straight to floats
        except (ValueError, pd.errors.ParserError) as e:  # a cell that is not a number: named by the checked reading
            first = log.skip + 2
            try:
                for df in chunks(str):
                    df.columns = [str(c).strip() for c in df.columns]
                    df.attrs["first_line"] = first
                    numeric_columns(df, [c for c in log.wanted if c in df.columns], log.where)
                    first += len(df)
            except (UnicodeDecodeError, pd.errors.ParserError) as e2:
                raise RecordError(
                    f"{log.where}: after row {first}, not a readable table ({str(e2).strip()[:120]})"
                ) from None
            raise RecordError(f"{log.where}: not a readable table of numbers ({str(e).strip()[:120]})") from None

    st = {"n": 0, "chunks": [], "ranges": {}, "range_units": {}, "notes": [], "written": {}}
    offset = fh.tell()
    t_last = None
    line = log.skip + 2
    step = None
    for df in frames():
        df.columns = [str(c).strip() for c in df.columns]
        df.attrs["first_line"] = line
        gyr = numeric_columns(df, log.gyro_names, log.where)
        acc = numeric_columns(df, log.acc_names, log.where) if log.acc_names else None
        if log.time_col:
            t = numeric_columns(df, [log.time_col], log.where)[:, 0] * log.scale_t
            prev = t if t_last is None else np.concatenate([[t_last], t])
            bad = np.flatnonzero(np.diff(prev) <= 0)
            if bad.size:
                i = int(bad[0]) + (1 if t_last is None else 0)
                raise RecordError(f"{log.where}: row {line + i}, column {log.time_col!r}: time does not increase")
            if t_last is None:
                st["t_first"] = float(t[0])
            t_last = float(t[-1])
            st["t_last"] = t_last
        else:
            rate = log.rate_hz or (preamble_rate(log.preamble) or (None,))[0]
            if not rate:
                raise RecordError(
                    f"{log.where}: the samples need a rate: give --rate-hz or map a time column (time=COL)"
                )
            t = (st["n"] + np.arange(len(df))) / float(rate)
            st["t_first"], st["t_last"] = 0.0, float(t[-1])
        gcols, _ = gyro_record_columns(gyr, log.gyro_unit, log.gyro_scale, log.where)
        g = np.column_stack(list(gcols.values()))
        a = None
        if acc is not None:
            if log.acc_unit == "counts" and log.acc_scale is None:
                raise RecordError(
                    f"{log.where}: a rest log's accelerometer in counts needs its nominal scale: --acc-scale"
                )
            a = acc * ({"g": 1.0, "m/s^2": 1.0 / units.G0}.get(log.acc_unit) or 1.0 / float(log.acc_scale))
        if step is None:  # the block size and the formats, from the first chunk
            d = np.diff(t)
            step = float(np.median(d)) if len(d) else 1.0 / (log.rate_hz or 1.0)
            size = window_samples(WINDOW_S, 1.0 / step)
            x = g if a is None else np.column_stack([g, a])
            st["blocks"] = _Blocks(size, x.shape[1])
            st["floor"] = quantum(x) ** 2 / 12.0
            t0 = float(t[0])
            t_dec = min(decimals_for(t - t0), int(np.clip(np.ceil(-np.log10(step * 1e-4)), 3, 9)))
            decs = [t_dec] + [noise_decimals(x[:, j]) for j in range(x.shape[1])]
            st["written"] = {"decimals": dict(zip(["time_s", *_out_names(x.shape[1])], decs))}
            if any(d < decimals_for(x[:, j]) for j, d in enumerate(decs[1:])):
                st["notes"].append(
                    "channels written to 1/1000 of their sample-to-sample noise (decimals "
                    + ", ".join(f"{k} {v}" for k, v in list(st["written"]["decimals"].items())[1:])
                    + "): the rounding adds 1e-7 of the noise variance"
                )
        x = g if a is None else np.column_stack([g, a])
        for j, nm in enumerate(_out_names(x.shape[1], raw=True)):
            raw = gyr[:, j] if j < 3 else acc[:, j - 3]
            lo, hi, sm = st["ranges"].get(nm, [np.inf, -np.inf, 0.0])
            st["ranges"][nm] = [min(lo, float(raw.min())), max(hi, float(raw.max())), sm + float(raw.sum())]
            st["range_units"][nm] = log.gyro_unit if j < 3 else log.acc_unit
        st["blocks"].add(x)
        data, row_len, seg_pos = format_rows([t - t0, *x.T], decs)
        st["chunks"].append((st["n"], offset, row_len, seg_pos))
        fh.write(data)
        offset += len(data)
        st["n"] += len(df)
        line += len(df)
        progress.add(len(df))
    if st["n"] < 2:
        raise RecordError(f"{log.where}: fewer than 2 samples")
    for v in st["ranges"].values():
        v[2] /= st["n"]
    return st


def _out_names(k: int, raw: bool = False) -> list[str]:
    """The first ``k`` channel names (gyro x–z, accelerometer x–z): as said (``raw``) or as written."""
    if raw:
        return ([f"gyro_{c}" for c in CHANNELS] + [f"acc_{c}" for c in CHANNELS])[:k]
    return ([f"gyro_{c}" for c in CHANNELS] + [f"acc_{c}_g" for c in CHANNELS])[:k]


def _patch_segments(csv_tmp: str, chunks: list, rests: list, n: int) -> None:
    """Write −1 into the segment field of every row outside the ``rests`` (and each rest k ≥ 1 its label), in the
    record CSV written by :func:`_pass` (rows of one length within each chunk)."""
    import mmap

    label = np.full(n, -1, dtype=np.int64)
    for k, (s, e) in enumerate(rests):
        label[s:e] = k
    with open(csv_tmp, "r+b") as fh, mmap.mmap(fh.fileno(), 0) as mm:
        bounds = [c[0] for c in chunks[1:]] + [n]
        for (first, offset, row_len, seg_pos), end in zip(chunks, bounds):
            lab = label[first:end]
            if np.all(lab == 0):
                continue
            view = np.frombuffer(mm, dtype=np.uint8, count=(end - first) * row_len, offset=offset)
            rows = view.reshape(end - first, row_len)
            text = np.array([list(f"{k:2d}".encode()) for k in range(-1, 10)], dtype=np.uint8)
            rows[:, seg_pos : seg_pos + 2] = text[lab + 1]
            del rows, view
