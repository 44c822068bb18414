"""Records and logs too long to hold, read in chunks: a record's CSV column by column and chunk by chunk with the
checks of :mod:`gyrojax.data.records` (every cell a finite number, named by row and column; time increasing), the
static pieces of its samples fed to the octave Allan accumulator (:class:`gyrojax.noise.chunked.OctaveAllan`) —
so that ``gyrojax noise`` of a record of hours at a high rate holds a chunk and the accumulators, never the
samples — and a progress bar on a terminal.

Used for records of more than :data:`STREAM_SAMPLES` samples.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyrojax.data.timebase import GAP_FACTOR, JITTER_TOL
from gyrojax.errors import RecordError
from gyrojax.noise.chunked import OctaveAllan

STREAM_SAMPLES = 2**19
"""Records longer than this (samples) are analysed in chunks by ``gyrojax noise``: octave τ only, from the running
sums of :mod:`gyrojax.noise.chunked`, memory flat in the record's length."""
CHUNK_ROWS = 2**18
"""Rows read at a time."""


class Progress:
    """A progress bar on stderr, redrawn in place at most 10 times a second, shown only when stderr is a terminal
    (quiet in pipes, logs and tests)."""

    def __init__(self, what: str, total: float, unit: str = "samples", stream=None):
        self.stream = stream if stream is not None else sys.stderr
        self.on = bool(getattr(self.stream, "isatty", lambda: False)()) and total > 0
        self.what, self.total, self.unit = what, float(total), unit
        self.t0 = self.last = time.perf_counter()
        self.done = 0.0

    def add(self, k: float) -> None:
        """``k`` more units done."""
        self.done += k
        now = time.perf_counter()
        if self.on and now - self.last >= 0.1:
            self.last = now
            self._draw(now)

    def close(self) -> None:
        """The final state and a line end (only when shown)."""
        if self.on:
            self._draw(time.perf_counter())
            self.stream.write("\n")
            self.stream.flush()

    def _draw(self, now: float) -> None:
        frac = min(self.done / self.total, 1.0)
        bar = "#" * int(30 * frac)
        self.stream.write(
            f"\r{self.what} [{bar:<30s}] {100 * frac:5.1f} % of {self.total:.3g} {self.unit}, {now - self.t0:.0f} s"
        )
        self.stream.flush()


def count_rows(csv_path) -> int:
    """Data rows of a CSV file with a one-line header (lines after the first that are not blank), counted by
    reading the bytes in blocks (a 10⁸-row file in seconds, in constant memory)."""
    import bz2
    import gzip
    import lzma

    opener = {".gz": gzip.open, ".bz2": bz2.open, ".xz": lzma.open}.get(Path(csv_path).suffix.lower(), open)
    lines, last = 0, b"\n"
    with opener(csv_path, "rb") as fh:
        while block := fh.read(1 << 24):
            lines += block.count(b"\n")
            last = block[-1:]
    lines += last != b"\n"  # a last line without its line end
    return max(lines - 1, 0)


def csv_chunks(csv_path: Path, columns: list[str], rows: int | None = None):
    """(first row's file line, {column: float array in the record's units}) of a record CSV (times in s), ``rows``
    rows at a time (default
    :data:`CHUNK_ROWS`): only ``columns`` parsed; a cell that is not a finite number is a :class:`RecordError` naming
    its row and column."""
    import pandas as pd

    rows = rows or CHUNK_ROWS
    header = pd.read_csv(csv_path, nrows=0).columns.str.strip().tolist()
    missing = [c for c in columns if c not in header]
    if missing:
        raise RecordError(f"{csv_path}: missing columns {missing}")

    def reader(dtype):
        return pd.read_csv(csv_path, usecols=lambda c: c.strip() in columns, chunksize=rows, dtype=dtype)

    line = 2
    try:
        for df in reader(np.float64):  # pandas' C parser straight to floats (blanks around a number are no part of it)
            df.columns = df.columns.str.strip()
            out = {c: df[c].to_numpy() for c in columns}
            for c, col in out.items():
                if not np.all(np.isfinite(col)):
                    i = int(np.flatnonzero(~np.isfinite(col))[0])
                    raise RecordError(
                        f"{csv_path}: row {line + i}, column {c!r} holds {col[i]!r}; values must be finite"
                    )
            yield line, out
            line += len(df)
    except ValueError as e:
        if isinstance(e, RecordError):
            raise
        try:
            _name_bad_cell(csv_path, columns, reader(str))
        except (UnicodeDecodeError, pd.errors.ParserError) as e2:
            raise RecordError(f"{csv_path}: is not a readable table ({str(e2).strip()[:120]})") from None
        raise RecordError(f"{csv_path}: is not a table of numbers ({str(e).strip()[:120]})") from None


def _name_bad_cell(csv_path, columns, frames) -> None:
    """Raise the :class:`RecordError` of the first cell of ``columns`` that is not a number, by row and column."""
    import pandas as pd

    line = 2
    for df in frames:
        df.columns = df.columns.str.strip()
        for c in columns:
            col = pd.to_numeric(df[c].str.strip(), errors="coerce").to_numpy(dtype=float)
            if not np.all(np.isfinite(col)):
                i = int(np.flatnonzero(~np.isfinite(col))[0])
                raise RecordError(
                    f"{csv_path}: row {line + i}, column {c!r} holds {df[c].iloc[i]!r}; values must be finite"
                )
        line += len(df)


@dataclass
class Piece:
    """One continuous static piece of a streamed record: its accumulator, clock (``t_first``, ``t_last``, the
    smallest and largest step ``dt_min``, ``dt_max``: s) and length (samples)."""

    allan: OctaveAllan | None = None
    t_first: float = 0.0
    t_last: float = 0.0
    n: int = 0
    dt_min: float = np.inf
    dt_max: float = 0.0
    name: str = ""
    channels: list = field(default_factory=list)

    def feed(self, t: np.ndarray, y: np.ndarray, nominal_dt: float) -> None:
        """Add the next samples of the piece (times ``t`` s, rows of ``y``; ``nominal_dt`` s, the record's step)."""
        if self.n == 0:
            self.t_first = float(t[0])
            self.allan = OctaveAllan(nominal_dt, y.shape[1])
        else:
            d0 = float(t[0]) - self.t_last
            self.dt_min, self.dt_max = min(self.dt_min, d0), max(self.dt_max, d0)
        if len(t) > 1:
            d = np.diff(t)
            self.dt_min, self.dt_max = min(self.dt_min, float(d.min())), max(self.dt_max, float(d.max()))
        self.t_last = float(t[-1])
        self.n += len(t)
        self.allan.feed(y)

    def interval(self) -> float:
        """The mean sample interval, s; :class:`RecordError` when a step departs from it by more than logger
        jitter (:data:`gyrojax.data.timebase.JITTER_TOL`)."""
        mean = (self.t_last - self.t_first) / max(self.n - 1, 1)
        if self.n > 1 and max(self.dt_max - mean, mean - self.dt_min) > JITTER_TOL * mean:
            raise RecordError(
                f"{self.name}: steps from {self.dt_min:.6g} to {self.dt_max:.6g} s against a mean interval of "
                f"{mean:.6g} s: a gap or a change of sample rate; the Allan variance needs a constant interval"
            )
        return mean


def static_pieces(record_path: Path, meta: dict, progress: Progress | None = None) -> dict:
    """The static pieces of one record, streamed: {piece name: :class:`Piece`} with its octave Allan sums of the
    record's channels (an imu-triad record's gyro_x…z in deg/h and acc_x…z in m/s², each static segment's
    continuous runs; an SDF record's indicated rate in deg/h, its continuous pieces, the table checked still)."""
    from gyrojax import units
    from gyrojax.data.triad import CHANNELS, is_triad

    csv_path = Path(record_path)
    name = meta["name"]
    pieces: dict = {}
    if is_triad(meta):
        header = [h.strip() for h in csv_path.open().readline().split(",")]
        unit = "dps" if all(f"gyro_{c}_dps" in header for c in CHANNELS) else "counts"
        gyro = [f"gyro_{c}_{unit}" for c in CHANNELS]
        acc = [f"acc_{c}_g" for c in CHANNELS] if all(f"acc_{c}_g" in header for c in CHANNELS) else []
        static = {s["label"]: s.get("name", f"static-{s['label']}") for s in meta["segments"] if s["type"] == "static"}
        k = 3600.0 / (float(meta["instrument"]["gyro_counts_per_dps"]) if unit == "counts" else 1.0)
        cols = ["time_s", "segment", *gyro, *acc]
        scale = np.array([k] * 3 + [units.G0] * len(acc))
        channels = [f"gyro_{c}" for c in CHANNELS] + [f"acc_{c}" for c in CHANNELS][: len(acc)]
    else:
        axes = [a["name"] for a in meta["table"]["axes"]]
        cols = ["time_s", *[f"angle_{a}_deg" for a in axes], "current_mA"]
        scale = np.array([float(meta["scale_factor_deg_per_h_per_mA"])])
        channels = ["gyro"]
    state = {"t": None, "label": None, "run": 0, "angles": None, "dt": None}
    for line, chunk in csv_chunks(csv_path, cols):
        t = chunk["time_s"]
        prev = np.concatenate([[state["t"]], t]) if state["t"] is not None else t
        d = np.diff(prev)
        if np.any(d <= 0):
            i = int(np.flatnonzero(d <= 0)[0]) + (0 if state["t"] is None else -1)
            raise RecordError(f"{csv_path}: row {line + i + 1}, column 'time_s': time does not increase")
        if state["dt"] is None:
            state["dt"] = float(np.median(d)) if len(d) else 1.0
        if is_triad(meta):
            label = chunk["segment"].astype(np.int64)
            y = np.column_stack([chunk[c] for c in cols[2:]]) * scale
        else:
            ang = np.column_stack([chunk[f"angle_{a}_deg"] for a in axes])
            ref = ang[0] if state["angles"] is None else state["angles"]
            moving = np.any(ang != ref, axis=1)
            if moving.any():
                i = int(np.flatnonzero(moving)[0])
                raise RecordError(
                    f"{name}: the table moves at row {line + i} (angle {ang[i].tolist()} deg after {ref.tolist()}); "
                    "the noise analysis needs static records"
                )
            state["angles"] = ref
            label = np.zeros(len(t), dtype=np.int64)
            y = chunk["current_mA"][:, None] * scale
        # a piece ends where the label changes or the step exceeds GAP_FACTOR × the first chunk's median step
        gap = state["t"] is not None and t[0] - state["t"] > GAP_FACTOR * state["dt"]
        breaks = np.flatnonzero(np.diff(label) != 0) + 1
        steps = np.flatnonzero(np.diff(t) > GAP_FACTOR * state["dt"]) + 1
        cuts = np.unique(np.concatenate([[0], breaks, steps, [len(t)]]))
        for a, b in zip(cuts[:-1], cuts[1:]):
            lab = int(label[a])
            new_run = a > 0 or lab != state["label"] or gap
            if new_run:
                state["run"] += 1
            state["label"] = lab
            if is_triad(meta) and lab not in static:
                continue
            key = f"{name}: {static[lab]} (run {state['run']})" if is_triad(meta) else f"{name}: piece {state['run']}"
            piece = pieces.setdefault(key, Piece(name=key, channels=channels))
            piece.feed(t[a:b], y[a:b], state["dt"])
        state["t"] = float(t[-1])
        if progress is not None:
            progress.add(len(t))
    return pieces


def long_records(paths) -> list | None:
    """[(csv path, validated JSON, rows)] of the records ``paths`` (files or directories, as
    :func:`gyrojax.data.records.load_records` takes them) when one of them holds more than :data:`STREAM_SAMPLES`
    rows, else None (they are loaded whole)."""
    import os

    from gyrojax.data.records import read_meta, record_paths
    from gyrojax.data.schema import validate_meta

    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    found = []
    for p in map(Path, paths):
        if p.is_dir():
            stems = sorted({q.with_suffix("") for q in p.glob("*.json")} & {q.with_suffix("") for q in p.glob("*.csv")})
            found += [record_paths(s.with_suffix(".json")) for s in stems]
        else:
            found.append(record_paths(p))
    rows = [count_rows(c) if c.exists() and j.exists() else 0 for c, j in found]
    if not rows or max(rows) <= STREAM_SAMPLES:
        return None
    out = []
    for (c, j), n in zip(found, rows):
        meta = read_meta(j)
        validate_meta(meta, j)
        out.append((c, meta, n))
    return out
