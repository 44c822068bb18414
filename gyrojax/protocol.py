"""Files gyrojax writes and reads: atomic output, strict JSON, and the one versioned result protocol.

Every object gyrojax saves (fit, triad fit, noise model, design, study, study result, plan, truth) is one JSON
object whose first two keys are ``"format"`` (a tag such as ``"gyrojax-fit"``) and ``"format_version"`` (an
integer), written by :func:`save` and read back by :func:`load`, as a pair. The JSON is strict: non-finite
numbers are written as ``null`` (never the bare ``NaN``/``Infinity`` tokens that other JSON readers refuse), numpy
scalars and arrays as numbers and lists. A reader accepts versions 1 to the one it writes and refuses anything
else with a :class:`~gyrojax.errors.FormatError` naming the file and the key.

This module sits at the bottom of the package: it imports nothing of gyrojax but :mod:`gyrojax.errors`.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from gyrojax.errors import FormatError

FORMAT_KEY = "format"
VERSION_KEY = "format_version"


# -- atomic output ---------------------------------------------------------------------------------------------------
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


# -- reading ---------------------------------------------------------------------------------------------------------
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


# -- strict JSON -----------------------------------------------------------------------------------------------------
def strict(obj):
    """``obj`` with every value JSON can hold strictly: non-finite floats become ``None``, numpy scalars and arrays
    plain numbers and (nested) lists, tuples lists; dict keys must be strings. Raises ``TypeError`` naming the type
    of anything else."""
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, (int, np.integer)) and not isinstance(obj, np.bool_):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (float, np.floating)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, np.ndarray):
        return strict(obj.tolist())
    if isinstance(obj, Mapping):
        out = {}
        for k, v in obj.items():
            if not isinstance(k, str):
                raise TypeError(f"JSON object keys are strings; got {type(k).__name__} {k!r}")
            out[k] = strict(v)
        return out
    if isinstance(obj, (list, tuple)):
        return [strict(v) for v in obj]
    if hasattr(obj, "__array__"):  # a JAX array
        return strict(np.asarray(obj))
    raise TypeError(f"not JSON data: {type(obj).__name__}")


def dumps(payload: Mapping, fmt: str, version: int, indent: int | None = 1) -> str:
    """The file text of ``payload`` tagged with ``fmt`` and ``version`` (those two keys first), strict JSON."""
    _check_tag(fmt, version)
    body = {k: v for k, v in payload.items() if k not in (FORMAT_KEY, VERSION_KEY)}
    doc = {FORMAT_KEY: fmt, VERSION_KEY: int(version), **strict(body)}
    return json.dumps(doc, indent=indent, allow_nan=False, ensure_ascii=False) + "\n"


def save(path, payload: Mapping, fmt: str, version: int, force: bool = False) -> Path:
    """Write ``payload`` tagged ``fmt``/``version`` to ``path`` atomically. An existing file is an error unless
    ``force`` (the old file is never touched when the text cannot be made). Returns the path."""
    p = Path(path)
    if p.exists() and not force:
        raise FormatError(f"{p}: exists; pass force=True (or --force) to overwrite")
    text = dumps(payload, fmt, version)  # before touching the file: a payload that is not JSON loses nothing
    atomic_write_text(p, text)
    return p


def check(doc, fmt: str, version: int, where: str, legacy: Mapping[str, tuple[str, int]] | None = None) -> dict:
    """``doc`` (a parsed file) after checking it is a JSON object tagged ``fmt`` at a version 1..``version``.
    ``legacy`` maps an old format string (one that carried its version, such as ``"gyrojax-fit-1"``) to the tag and
    version it stands for. Returns the dict with ``format``/``format_version`` normalised."""
    if not isinstance(doc, dict):
        raise FormatError(f"{where}: not a {fmt} file (a JSON object with key 'format' is expected)")
    tag, ver = doc.get(FORMAT_KEY), doc.get(VERSION_KEY)
    if legacy and ver is None and tag in legacy:
        tag, ver = legacy[tag]
    if tag != fmt:
        raise FormatError(f"{where}: key 'format' is {_plain(tag)}, not {fmt!r}")
    if not isinstance(ver, int) or isinstance(ver, bool) or not 1 <= ver <= version:
        raise FormatError(f"{where}: key 'format_version' is {_plain(ver)}; this gyrojax reads {fmt} 1 to {version}")
    return {**doc, FORMAT_KEY: tag, VERSION_KEY: ver}


def load(path, fmt: str, version: int, legacy: Mapping[str, tuple[str, int]] | None = None) -> dict:
    """Read a file written by :func:`save` and :func:`check` it; :class:`~gyrojax.errors.FormatError` names the
    file and the key otherwise."""
    doc = read_json_file(path, FormatError, f"a {fmt} file")
    return check(doc, fmt, version, str(path), legacy)


def check_as(doc, fmt: str, version: int, where: str, error: type, legacy=None) -> dict:
    """:func:`check` for a loader with an error type of its own (``PlanError``, ``StudyError`` …): the same message
    (plus the legacy tags it also reads, if any), raised as ``error``."""
    try:
        return check(doc, fmt, version, where, legacy)
    except FormatError as e:
        old = f" (also read: the older {', '.join(repr(k) for k in legacy)})" if legacy else ""
        raise error(f"{e}{old}") from None


def require(doc: Mapping, keys, where: str) -> None:
    """Raise :class:`~gyrojax.errors.FormatError` naming the first of ``keys`` missing from ``doc``."""
    for key in keys:
        if key not in doc:
            raise FormatError(f"{where}: key {key!r} is missing")


def floats(values) -> np.ndarray:
    """A saved list of numbers (``null`` for non-finite) back as a float64 array (``nan`` for ``null``)."""
    return np.array(_nan_for_none(values), dtype=float)


def _nan_for_none(v):
    if v is None:
        return math.nan
    if isinstance(v, list):
        return [_nan_for_none(x) for x in v]
    return v


def _check_tag(fmt: str, version: int) -> None:
    if not isinstance(fmt, str) or not fmt.startswith("gyrojax-"):
        raise ValueError(f"format tags start with 'gyrojax-'; got {fmt!r}")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise ValueError(f"format versions are integers >= 1; got {version!r}")


def _plain(v) -> str:
    return "missing" if v is None else repr(v)
