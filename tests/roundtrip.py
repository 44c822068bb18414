"""Whole-object comparison for save/load round trips: every field of two results, recursively, NaN equal to NaN."""

import dataclasses
import math

import numpy as np


def assert_same(a, b, where: str = "result", skip=()) -> None:
    """Raise AssertionError naming the first field (as a path) where ``a`` and ``b`` differ. Dataclasses compare
    field by field (``skip``: top-level field names left out), arrays and numbers exactly (NaN == NaN, types of
    float/int/numpy scalars not told apart), dicts by their keys and values, lists/tuples item by item."""
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), f"{where}: {type(a).__name__} vs {type(b).__name__}"
        for f in dataclasses.fields(a):
            if f.name not in skip:
                assert_same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
        return
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        assert x.shape == y.shape, f"{where}: shape {x.shape} vs {y.shape}"
        assert np.array_equal(x, y, equal_nan=True), f"{where}: {x} vs {y}"
        return
    if isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b), f"{where}: keys {sorted(a)} vs {sorted(b)}"
        for k in a:
            assert_same(a[k], b[k], f"{where}[{k!r}]")
        return
    if isinstance(a, (list, tuple)):
        assert isinstance(b, (list, tuple)) and len(a) == len(b), f"{where}: {a!r} vs {b!r}"
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{where}[{i}]")
        return
    if isinstance(a, float) or isinstance(b, float) or isinstance(a, np.floating):
        assert isinstance(b, (int, float, np.number)) and not isinstance(b, bool), f"{where}: {a!r} vs {b!r}"
        assert (math.isnan(a) and math.isnan(b)) or a == b, f"{where}: {a!r} vs {b!r}"
        return
    assert a == b, f"{where}: {a!r} vs {b!r}"


def strict_json(text: str):
    """Parse ``text`` refusing the NaN/Infinity tokens that strict JSON does not have."""
    import json

    def refuse(token):
        raise ValueError(f"not strict JSON: bare {token}")

    return json.loads(text, parse_constant=refuse)
