"""Record files: ``NAME.csv`` + ``NAME.json`` (conventions §5).

A record is one test run. ``load_record`` validates everything at the boundary and raises
:class:`~gyrojax.errors.RecordError` naming the file and the key, or the row and the column; ``save_record``
writes both files atomically and never over a good file without ``force``. The pieces: the :class:`Record` type
(:mod:`gyrojax.data.record`), its time base (:mod:`gyrojax.data.timebase`), the schema
(:mod:`gyrojax.data.schema`) and the CSV reading and writing (:mod:`gyrojax.data.csvfile`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from gyrojax.data.csvfile import parse_csv, record_csv_chunks
from gyrojax.data.record import Record
from gyrojax.data.schema import err, validate_columns, validate_meta
from gyrojax.errors import RecordError


def record_paths(path: str | os.PathLike) -> tuple[Path, Path]:
    """(csv, json) paths of a record given either file (or the common stem)."""
    p = Path(path)
    if p.suffix.lower() in (".csv", ".json"):
        stem = p.with_suffix("")
    else:
        stem = p
    return stem.with_suffix(".csv"), stem.with_suffix(".json")


def _no_duplicate_keys(json_path):
    def hook(pairs):
        seen = set()
        for k, _ in pairs:
            if k in seen:
                raise err(json_path, f"key {k!r} appears twice in one object; each key must appear once")
            seen.add(k)
        return dict(pairs)

    return hook


def read_meta(json_path: Path) -> dict:
    """The record JSON as a dict (UTF-8, a BOM allowed; duplicate keys are errors), not yet validated."""
    try:
        raw = json_path.read_bytes()
    except OSError as e:
        raise err(json_path, f"cannot read: {e.strerror} (a record is NAME.csv + NAME.json, both files)") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line = raw[: e.start].count(b"\n") + 1
        raise err(json_path, f"is not UTF-8 (line {line}, byte {e.start}); save it as UTF-8") from None
    if not text.strip():
        raise err(json_path, "is empty; a JSON object with the record's metadata (conventions §5) is required")
    try:
        return json.loads(text, object_pairs_hook=_no_duplicate_keys(json_path))
    except json.JSONDecodeError as e:
        raise err(json_path, f"is not valid JSON: {e.msg} at line {e.lineno}, column {e.colno}") from None


def load_record(path: str | os.PathLike) -> Record:
    """Load and validate one record from ``NAME.csv`` or ``NAME.json`` (either path works)."""
    csv_path, json_path = record_paths(path)
    for p in (json_path, csv_path):
        if not p.exists():
            raise RecordError(f"{p}: no such file (a record is NAME.csv + NAME.json side by side)")
    meta = read_meta(json_path)
    validate_meta(meta, json_path)
    _, columns = parse_csv(csv_path)
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
