"""Safe output: every file gyrojax writes goes to a temporary file in the same folder, then is renamed."""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` so that readers see the old file or the new one, never a partial one."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Text version of :func:`atomic_write_bytes` (UTF-8)."""
    atomic_write_bytes(path, text.encode("utf-8"))


def is_finite_number(v) -> bool:
    """A JSON number that is a finite float64 (not a bool, not an integer too large for a float)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return False
    try:
        return math.isfinite(float(v))
    except OverflowError:
        return False


def read_json_file(path, error: type, what: str):
    """Parse a JSON file, turning every way it can be unreadable into ``error`` with a one-line message naming the
    file: missing, a directory, unreadable, empty, not UTF-8, not JSON. ``what`` says what the file should hold."""
    p = Path(path)
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise error(f"{p}: no such file") from None
    except IsADirectoryError:
        raise error(f"{p}: is a directory; {what} is one JSON file") from None
    except OSError as e:
        raise error(f"{p}: cannot read: {e.strerror}") from None
    if not raw.strip():
        raise error(f"{p}: is empty; {what} is a JSON object") from None
    try:
        return json.loads(raw.decode("utf-8-sig"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise error(f"{p}: not valid UTF-8 JSON ({e}); {what} is a JSON object") from None
