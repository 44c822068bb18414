"""Traced functions kept across processes (gyrojax.noise.kept, issue 26): a saved trace is reloaded instead of
traced again, gives the closed-form answer, is keyed by shape, and a damaged file is replaced with a warning."""

import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gyrojax.noise import kept

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
    assert jax.export.deserialize(bytearray(path.read_bytes())) is not None  # replaced


def test_inside_a_transformation_the_jitted_function_runs(where):
    grad = jax.grad(lambda x: _fresh()(x, 2.0)[0])(jnp.arange(3.0))
    np.testing.assert_allclose(np.asarray(grad), 4.0 * np.arange(3.0), rtol=1e-15)
    assert not where.exists()


def test_nothing_is_kept_without_flatbuffers(monkeypatch):
    assert jax.config.jax_compilation_cache_dir  # tests/conftest.py turns the cache on
    assert kept.SERIALIZABLE is False or kept.folder() is not None
    monkeypatch.setattr(kept, "SERIALIZABLE", False)
    assert kept.folder() is None
    assert float(_fresh()(np.ones(2), 1.0)[0]) == 2.0


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
    """A cache folder below a file (or read-only): the traces run all the same, and one warning names the folder
    and the way out, however many traces and arrays could not be kept."""
    pytest.importorskip("flatbuffers")
    (tmp_path / "file").write_text("not a folder")
    monkeypatch.setattr(kept, "folder", lambda: tmp_path / "file" / "k")
    monkeypatch.setattr(kept, "_UNWRITABLE", set())
    with pytest.warns(UserWarning, match="GYROJAX_NO_CACHE=1") as said:
        assert float(_fresh()(np.ones(2), 1.0)[0]) == 2.0
        assert float(_fresh()(np.ones(3), 1.0)[0]) == 3.0  # another shape: another trace not saved
        assert kept.kept_arrays("rows", ("x",), lambda: [np.arange(2)])[0].tolist() == [0, 1]
    assert len([w for w in said if "not saved" in str(w.message)]) == 1
