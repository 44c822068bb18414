"""gyrojax's compiled functions kept across processes (gyrojax.runtime.kept): a saved trace is reloaded instead of
traced again (in this process and in fresh ones, as a notebook's kernel), gives the closed-form answer, is keyed by
shape, and a damaged or foreign file is replaced with a warning, never called."""

import os
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gyrojax.runtime import kept

TRACES = []


def _energy(x, scale, extra=None):
    TRACES.append(x.shape)  # runs while tracing only
    y = jnp.sum(scale * x**2) + (0.0 if extra is None else jnp.sum(extra))
    return y, 2.0 * scale * x


def _fresh():
    return kept.Kept("energy", jax.jit(_energy))


@pytest.fixture
def where(tmp_path, monkeypatch):
    pytest.importorskip("flatbuffers")
    monkeypatch.setattr(kept, "folder", lambda: tmp_path / "k")
    TRACES.clear()
    return tmp_path / "k"


def test_a_saved_trace_is_reloaded_without_tracing(where):
    x = np.arange(5.0)
    y, g = _fresh()(x, 3.0)
    assert len(TRACES) == 1 and len(list(where.glob("energy-*.bin"))) == 1
    TRACES.clear()
    y2, g2 = _fresh()(x + 1.0, 0.5)  # a new instance: as in a fresh process
    assert TRACES == []
    assert float(y) == pytest.approx(3.0 * 30.0, rel=1e-15) and float(y2) == pytest.approx(0.5 * 55.0, rel=1e-15)
    np.testing.assert_allclose(np.asarray(g2), (x + 1.0), rtol=1e-15)


def test_the_key_follows_shape_and_tree(where):
    f = _fresh()
    f(np.ones(3), 1.0)
    f(np.ones(4), 1.0)
    f(np.ones(4), 1.0, np.ones(2))
    assert len(list(where.glob("energy-*.bin"))) == 3 and len(TRACES) == 3
    assert float(f(np.ones(4), 2.0, np.ones(2))[0]) == 10.0


def test_a_damaged_file_is_traced_again_with_a_warning(where):
    _fresh()(np.ones(3), 1.0)
    (path,) = where.glob("energy-*.bin")
    path.write_bytes(b"not an exported module")
    with pytest.warns(UserWarning, match="kept trace unreadable"):
        y, _ = _fresh()(np.full(3, 2.0), 1.0)
    assert float(y) == 12.0
    TRACES.clear()
    assert float(_fresh()(np.full(3, 2.0), 1.0)[0]) == 12.0 and TRACES == []  # replaced by a good one


def test_a_file_of_other_inputs_under_the_key_is_compiled_again(where):
    _fresh()(np.ones(3), 1.0)
    _fresh()(np.ones(4), 1.0)
    three, four = (p for p in where.glob("energy-*.bin"))  # which is which does not matter: swap their contents
    a, b = three.read_bytes(), four.read_bytes()
    three.write_bytes(b), four.write_bytes(a)
    with pytest.warns(UserWarning, match="are not the call's"):
        assert float(_fresh()(np.full(3, 2.0), 1.0)[0]) == 12.0


def test_inside_a_transformation_the_jitted_function_runs(where):
    grad = jax.grad(lambda x: _fresh()(x, 2.0)[0])(jnp.arange(3.0))
    np.testing.assert_allclose(np.asarray(grad), 4.0 * np.arange(3.0), rtol=1e-15)
    assert not where.exists()


def test_nothing_is_kept_with_the_cache_off(monkeypatch, tmp_path):
    monkeypatch.setenv("GYROJAX_CACHE_DIR", str(tmp_path / "c"))
    assert kept.SERIALIZABLE is False or kept.folder() == tmp_path / ("c" + kept.SUFFIX)
    monkeypatch.setenv("GYROJAX_NO_CACHE", "1")
    assert kept.folder() is None
    assert float(_fresh()(np.ones(2), 1.0)[0]) == 2.0
    assert not (tmp_path / ("c" + kept.SUFFIX)).exists()


def test_kept_arrays_are_computed_once_and_read_back_exactly(where):
    calls = []
    x = np.random.default_rng(1).normal(size=(4, 3))

    def compute():
        calls.append(1)
        return [np.array(["a b (c/d)", "e"]), x, np.arange(3)]

    first = kept.kept_arrays("rows", ("sdf", ("D_F",)), compute)
    again = kept.kept_arrays("rows", ("sdf", ("D_F",)), compute)
    other = kept.kept_arrays("rows", ("sdf", ("D_F", "D_I")), compute)
    assert len(calls) == 2 and len(list(where.glob("rows-*.npz"))) == 2
    for got in (first, again, other):
        assert got[0].tolist() == ["a b (c/d)", "e"] and np.array_equal(got[1], x) and got[2].tolist() == [0, 1, 2]
    for path in where.glob("rows-*.npz"):
        path.write_bytes(b"damaged")
    with pytest.warns(UserWarning, match="kept arrays unreadable"):
        assert np.array_equal(kept.kept_arrays("rows", ("sdf", ("D_F",)), compute)[1], x)
    assert len(calls) == 3


def test_files_of_other_library_sources_are_pruned(where, monkeypatch):
    """The first use of the folder deletes the kept files of other library sources but the most recent
    KEEP_OTHER_SOURCES, and files named without the digest (an earlier layout); this source's files stay."""
    where.mkdir(parents=True)
    mine = kept.source_digest()[: kept.DIGEST_CHARS]
    others = [f"{i:x}" * kept.DIGEST_CHARS for i in range(10, 14)]  # four other sources, oldest first
    key = "0" * 32
    for age, d in enumerate(reversed(others)):
        for name in ("energy", "rows"):
            p = where / f"{name}-{d}-{key}.bin"
            p.write_bytes(b"x")
            os.utime(p, (1e9 - 1e5 * age, 1e9 - 1e5 * age))  # others[-1] written last
    (where / f"energy-{mine}-{key}.bin").write_bytes(b"mine")
    (where / f"energy-{key}.bin").write_bytes(b"old layout")
    (where / "notes.txt").write_text("not ours")
    monkeypatch.setattr(kept, "_PRUNED", set())
    _fresh()(np.ones(3), 1.0)  # first use in this "process"
    left = sorted(p.name for p in where.iterdir())
    kept_digests = {n.split("-")[1] for n in left if n.count("-") == 2}
    assert kept_digests == {mine, *others[-kept.KEEP_OTHER_SOURCES :]}
    assert f"energy-{key}.bin" not in left and "notes.txt" in left
    assert (where / f"energy-{mine}-{key}.bin").read_bytes() == b"mine"
    assert len([n for n in left if n.startswith(f"energy-{mine}-")]) == 2  # the new trace beside the planted one
    assert kept.prune(where) == []  # nothing more to delete


def test_a_folder_that_cannot_be_written_is_said_once(tmp_path, monkeypatch):
    """A cache folder below a file (or read-only): the functions run all the same, and one warning names the folder
    and the way out, however many traces and arrays could not be kept."""
    (tmp_path / "file").write_text("not a folder")
    monkeypatch.setattr(kept, "folder", lambda: tmp_path / "file" / "k")
    monkeypatch.setattr(kept, "_UNWRITABLE", set())
    with pytest.warns(UserWarning, match="GYROJAX_NO_CACHE=1") as said:
        assert float(_fresh()(np.ones(2), 1.0)[0]) == 2.0
        assert float(_fresh()(np.ones(3), 1.0)[0]) == 3.0  # another shape: another trace not saved
        assert kept.kept_arrays("rows", ("x",), lambda: [np.arange(2)])[0].tolist() == [0, 1]
    assert len([w for w in said if "not saved" in str(w.message)]) == 1


NOTEBOOK = r"""
import sys, warnings
import jax.numpy as jnp, numpy as np
import gyrojax, jax
from gyrojax.runtime import kept

def energy(x, scale):
    print("traced", x.shape)
    return jnp.sum(scale * x**2), 2.0 * scale * x

f = kept.Kept("energy", jax.jit(energy))
with warnings.catch_warnings(record=True) as said:
    warnings.simplefilter("always")
    y, g = f(np.arange(float(sys.argv[1])), 3.0)
print("value", float(y), float(np.sum(g)))
print("warned", [str(w.message) for w in said])
"""


def _notebook(tmp_path, n):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("GYROJAX_", "JAX_COMPILATION"))}
    env["GYROJAX_CACHE_DIR"] = str(tmp_path / "c")
    out = subprocess.run([sys.executable, "-c", NOTEBOOK, str(n)], env=env, capture_output=True, text=True, check=True)
    return out.stdout


def test_a_fresh_process_loads_the_trace_without_tracing(tmp_path):
    pytest.importorskip("flatbuffers")
    """A notebook's process: gyrojax's traces kept beside the cache its import chose; a second process loads the
    trace (no trace, the closed-form value), another shape traces its own, and a damaged file is said,
    traced again and replaced."""
    first = _notebook(tmp_path, 5)
    assert "traced (5,)" in first and "value 90.0 60.0" in first
    (path,) = (tmp_path / ("c" + kept.SUFFIX)).glob("energy-*.bin")
    again = _notebook(tmp_path, 5)
    assert "traced" not in again and "value 90.0 60.0" in again and "warned []" in again
    assert "traced (4,)" in _notebook(tmp_path, 4)
    path.write_bytes(b"damaged")
    said = _notebook(tmp_path, 5)
    assert "kept trace unreadable" in said and "value 90.0 60.0" in said
    assert "traced" not in _notebook(tmp_path, 5)
