"""gyrojax's compiled functions kept across processes (gyrojax.runtime.kept): a saved executable is loaded instead of
traced and compiled again (in this process and in fresh ones, as a notebook's kernel), gives the closed-form answer,
is keyed by shape, host CPU and XLA flags, and a damaged or foreign file is compiled again with a warning, never
called."""

import json
import os
import pickle
import re
import subprocess
import sys
import warnings
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gyrojax.runtime import kept, lapack
from gyrojax.runtime.threads import in_background

TRACES = []


def _energy(x, scale, extra=None):
    TRACES.append(x.shape)  # runs while tracing only
    y = jnp.sum(scale * x**2) + (0.0 if extra is None else jnp.sum(extra))
    return y, 2.0 * scale * x


def _fresh():
    return kept.Kept("energy", jax.jit(_energy))


@pytest.fixture
def where(tmp_path, monkeypatch):
    monkeypatch.setattr(kept, "folder", lambda: tmp_path / "k")
    TRACES.clear()
    return tmp_path / "k"


def test_a_saved_executable_is_loaded_without_tracing(where):
    x = np.arange(5.0)
    y, g = _fresh()(x, 3.0)
    assert len(TRACES) == 1 and len(list(where.glob("energy-*.xla"))) == 1
    TRACES.clear()
    y2, g2 = _fresh()(x + 1.0, 0.5)  # a new instance: as in a fresh process
    assert TRACES == []
    assert float(y) == pytest.approx(3.0 * 30.0, rel=1e-15) and float(y2) == pytest.approx(0.5 * 55.0, rel=1e-15)
    np.testing.assert_allclose(np.asarray(g2), (x + 1.0), rtol=1e-15)


def test_an_executable_prepared_from_shapes_on_another_thread_serves_the_call(where):
    """``prepare`` with shapes alone (:class:`jax.ShapeDtypeStruct`, as the triad design loads its second stage while
    the first runs) on a worker thread (:func:`gyrojax.runtime.threads.in_background`) traces, compiles and keeps the
    executable once and returns the shapes of its outputs; the call at those shapes then neither traces nor writes a
    file, to the same bits as jit."""
    f, x = _fresh(), np.arange(9.0)  # a shape no other test traces
    shape = jax.ShapeDtypeStruct(x.shape, x.dtype)
    out = in_background(f.prepare, shape, jax.ShapeDtypeStruct((), np.float64)).result()
    assert [(o.shape, o.dtype) for o in out] == [((), np.float64), (x.shape, np.float64)]  # _energy's outputs
    assert len(TRACES) == 1 and len(files := list(where.glob("energy-*.xla"))) == 1
    written = files[0].stat().st_mtime_ns
    TRACES.clear()
    y, g = f(x, 1.5)
    assert TRACES == [] and files[0].stat().st_mtime_ns == written
    y0, g0 = jax.jit(_energy)(x, 1.5)
    assert float(y) == float(y0) and np.array_equal(np.asarray(g), np.asarray(g0))


def test_released_executables_are_read_again_from_their_files(where):
    """:func:`gyrojax.runtime.kept.release` drops the executables held in this process (a long process' memory map
    fills with their machine code); the next call reads its file again, without tracing, to the same bits."""
    f, x = _fresh(), np.arange(7.0)  # a shape no other test traces (JAX keeps traces of _energy by shape)
    y, g = f(x, 2.0)
    assert kept.release() >= 1 and kept.release() == 0
    TRACES.clear()
    y2, g2 = f(x, 2.0)
    assert TRACES == [] and float(y2) == float(y) == 2.0 * 91.0
    np.testing.assert_array_equal(np.asarray(g2), np.asarray(g))
    assert kept.release() >= 1


def test_near_the_memory_map_limit_a_new_shape_drops_the_kept_executables_and_says_so(where, monkeypatch):
    """Past 3/4 of vm.max_map_count XLA's next compile may die of the limit: a kept function's new shape first drops
    the executables every kept function holds, with a warning that names the count and the limit; below it, nothing.
    The count is this process' /proc/self/maps, one line an entry, where Linux has it."""
    f, x = _fresh(), np.arange(5.0)
    f(x, 1.0)
    real = kept.map_entries()
    if real is not None:
        assert 0 < real[0] < real[1]
    monkeypatch.setattr(kept, "map_entries", lambda: (60_000, 65_530))
    with pytest.warns(RuntimeWarning, match="60000 of the 65530 memory-map entries"):
        y, _ = f(np.arange(6.0), 1.0)
    assert float(y) == 55.0 and kept.release() == 1  # only the new shape's executable is held again
    monkeypatch.setattr(kept, "map_entries", lambda: (40_000, 65_530))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        f(np.arange(7.0), 1.0)
    assert kept.release() == 1


def test_the_key_follows_shape_and_tree(where):
    f = _fresh()
    f(np.ones(3), 1.0)
    f(np.ones(4), 1.0)
    f(np.ones(4), 1.0, np.ones(2))
    assert len(list(where.glob("energy-*.xla"))) == 3 and len(TRACES) == 3
    assert float(f(np.ones(4), 2.0, np.ones(2))[0]) == 10.0


def test_a_damaged_file_is_compiled_again_with_a_warning(where):
    _fresh()(np.ones(3), 1.0)
    (path,) = where.glob("energy-*.xla")
    for damage in (b"not an executable", path.read_bytes()[:-100]):
        path.write_bytes(damage)
        with pytest.warns(UserWarning, match="kept executable not loaded"):
            y, _ = _fresh()(np.full(3, 2.0), 1.0)
        assert float(y) == 12.0
        TRACES.clear()
        assert float(_fresh()(np.full(3, 2.0), 1.0)[0]) == 12.0 and TRACES == []  # replaced by a good one


def test_a_file_of_another_key_is_compiled_again(where):
    """Files swapped between keys (two shapes) are refused by the key they hold, before anything is loaded."""
    _fresh()(np.ones(3), 1.0)
    _fresh()(np.ones(4), 1.0)
    three, four = (p for p in where.glob("energy-*.xla"))
    a, b = three.read_bytes(), four.read_bytes()
    three.write_bytes(b), four.write_bytes(a)
    with pytest.warns(UserWarning, match="another key"):
        assert float(_fresh()(np.full(3, 2.0), 1.0)[0]) == 12.0


def test_an_executable_of_other_inputs_under_the_key_is_never_called(where):
    """A file holding this call's key but an executable of other shapes (written by hand: the key is checked
    first) is refused by its inputs."""
    spec = [jax.ShapeDtypeStruct((3,), np.float64), jax.ShapeDtypeStruct((), np.float64)]
    _fresh()(np.ones(3), 1.0)
    (path,) = where.glob("energy-*.xla")
    other = jax.jit(lambda x, s: _energy(x, s)).lower(np.ones(4), 1.0).compile()
    key = kept._key("energy", jax.tree_util.tree_structure((0, 0)), spec)
    path.write_bytes(kept._written(other, key))
    with pytest.warns(UserWarning, match="are not the call's"):
        assert float(_fresh()(np.full(3, 2.0), 1.0)[0]) == 12.0


def test_another_cpu_or_xla_flags_never_load_this_executable(where, monkeypatch):
    """The host CPU and the XLA flags are in the key: another machine (or ISA held back by XLA_FLAGS) gets its own
    file, and a file of this machine copied under the other's name is refused by the key it holds."""
    _fresh()(np.ones(3), 1.0)
    (mine,) = where.glob("energy-*.xla")
    for change in ("cpu", "flags"):
        with monkeypatch.context() as m:
            if change == "cpu":
                m.setattr(kept, "host_cpu", lambda: "an older cpu")
            else:
                m.setenv("XLA_FLAGS", "--xla_cpu_max_isa=AVX")
            assert float(_fresh()(np.ones(3), 1.0)[0]) == 3.0  # compiled and kept under a key of its own
            (theirs,) = set(where.glob("energy-*.xla")) - {mine}
            theirs.write_bytes(mine.read_bytes())
            with pytest.warns(UserWarning, match="another key"):
                assert float(_fresh()(np.ones(3), 1.0)[0]) == 3.0
            theirs.unlink()


CPUINFO = """processor\t: 0
vendor_id\t: GenuineIntel
cpu family\t: 6
model\t\t: 85
model name\t: Intel(R) Xeon(R) CPU
flags\t\t: fpu sse2 avx avx2 avx512f
bogomips\t: 4000.00
cpu MHz\t\t: 2100.000

processor\t: 1
cpu MHz\t\t: 1200.000
"""


def test_the_cpu_fingerprint_follows_the_instruction_set_not_the_clock():
    """Another flag set (AVX-512 missing) or model is another fingerprint; the clock, the BogoMIPS and the other
    processors' lines are not part of it."""
    same = CPUINFO.replace("2100.000", "3400.000").replace("4000.00", "6800.00").replace("1200.000", "800.000")
    assert kept.cpu_fingerprint(same) == kept.cpu_fingerprint(CPUINFO)
    assert kept.cpu_fingerprint(CPUINFO.replace(" avx512f", "")) != kept.cpu_fingerprint(CPUINFO)
    assert kept.cpu_fingerprint(CPUINFO.replace("model\t\t: 85", "model\t\t: 63")) != kept.cpu_fingerprint(CPUINFO)
    if Path("/proc/cpuinfo").is_file():
        assert re.search(r"^(flags|Features|isa)\s*:", Path("/proc/cpuinfo").read_text(), re.MULTILINE)


def test_inside_a_transformation_the_jitted_function_runs(where):
    grad = jax.grad(lambda x: _fresh()(x, 2.0)[0])(jnp.arange(3.0))
    np.testing.assert_allclose(np.asarray(grad), 4.0 * np.arange(3.0), rtol=1e-15)
    assert not where.exists()


def test_nothing_is_kept_with_the_cache_off(monkeypatch, tmp_path):
    monkeypatch.setenv("GYROJAX_CACHE_DIR", str(tmp_path / "c"))
    assert kept.folder() == tmp_path / ("c" + kept.SUFFIX)
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
from gyrojax.runtime import kept, lapack
from gyrojax.runtime.cache import use_persistent_cache

if sys.argv[2] == "command":  # the command's process: JAX's persistent cache on as well
    use_persistent_cache()

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


def _env(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("GYROJAX_", "JAX_COMPILATION", "XLA_FLAGS"))}
    env["GYROJAX_CACHE_DIR"] = str(tmp_path / "c")
    return env


def _notebook(tmp_path, n, process="notebook"):
    args = [sys.executable, "-c", NOTEBOOK, str(n), process]
    return subprocess.run(args, env=_env(tmp_path), capture_output=True, text=True, check=True).stdout


def test_a_fresh_process_loads_the_executable_without_tracing(tmp_path):
    """A notebook's process: gyrojax's executables kept in its folder; a second process loads the executable (no
    trace, the closed-form value), another shape compiles its own, and a damaged file is said, compiled again and
    replaced."""
    first = _notebook(tmp_path, 5)
    assert "traced (5,)" in first and "value 90.0 60.0" in first
    (path,) = (tmp_path / ("c" + kept.SUFFIX)).glob("energy-*.xla")
    again = _notebook(tmp_path, 5)
    assert "traced" not in again and "value 90.0 60.0" in again and "warned []" in again
    assert "traced (4,)" in _notebook(tmp_path, 4)
    path.write_bytes(b"damaged")
    said = _notebook(tmp_path, 5)
    assert "kept executable not loaded" in said and "value 90.0 60.0" in said
    assert "traced" not in _notebook(tmp_path, 5)


def test_an_executable_from_the_persistent_cache_is_compiled_afresh_before_it_is_kept(tmp_path):
    """In the command's process JAX's persistent cache may hand back an executable (its kept file gone), which
    serialises without its machine code: it is compiled afresh, and the kept one runs in the next process."""
    assert "value 90.0 60.0" in _notebook(tmp_path, 5, "command")
    (path,) = (tmp_path / ("c" + kept.SUFFIX)).glob("energy-*.xla")
    path.unlink()
    assert "value 90.0 60.0" in _notebook(tmp_path, 5, "command")  # traced; JAX's cache answers the compile
    assert path.is_file()
    for process in ("command", "notebook"):
        out = _notebook(tmp_path, 5, process)
        assert "traced" not in out and "value 90.0 60.0" in out and "warned []" in out


LINALG = r"""
import hashlib, json, sys
import numpy as np
import gyrojax, jax, jax.numpy as jnp
from jax.lax import linalg
from gyrojax.runtime import kept, lapack

OPS = {
    "cholesky": lambda a: linalg.cholesky(a @ a.T + 4.0 * jnp.eye(4)),
    "lu": lambda a: linalg.lu(a)[0],
    "triangular_solve": lambda a: linalg.triangular_solve(jnp.tril(a) + 4.0 * jnp.eye(4), a, left_side=True),
    "qr": lambda a: linalg.qr(a, full_matrices=False),
    "qr_pivoted": lambda a: linalg.qr(a, pivoting=True, full_matrices=False)[:2],
    "ormqr": lambda a: linalg.ormqr(a, jnp.full(4, 0.5), a),
    "eigh": lambda a: linalg.eigh(a + a.T),
    "svd": lambda a: jnp.linalg.svd(a),
    "svd_qr": lambda a: linalg.svd(a, algorithm=linalg.SvdAlgorithm.QR),
    "eig": lambda a: linalg.eig(a, compute_left_eigenvectors=False),
    "schur": lambda a: linalg.schur(a),
    "hessenberg": lambda a: linalg.hessenberg(a),
    "tridiagonal": lambda a: linalg.tridiagonal(a + a.T),
}
a = np.cos(np.arange(16.0)).reshape(4, 4) + np.diag([3.0, -2.0, 1.5, 5.0])
bits = {}
for name, op in OPS.items():
    out = kept.Kept(f"linalg_{name}", jax.jit(op))(a)
    bits[name] = hashlib.sha256(b"".join(np.asarray(x).tobytes() for x in jax.tree_util.tree_leaves(out))).hexdigest()
print(json.dumps(bits))
"""


def test_every_lapack_kernel_a_kept_executable_may_call_is_ready_in_a_fresh_process(tmp_path):
    """A function on each LAPACK routine JAX's CPU backend calls, compiled and kept by one process and loaded by a
    fresh one that has lowered no linear algebra of its own (without :func:`gyrojax.runtime.lapack.prepare` it
    crashes): the same bits, and together they call every float64 kernel the preparation knows."""
    run = [sys.executable, "-c", LINALG]
    first = subprocess.run(run, env=_env(tmp_path), capture_output=True, text=True, check=True).stdout
    files = sorted((tmp_path / ("c" + kept.SUFFIX)).glob("linalg_*.xla"))
    assert len(files) == 13
    again = subprocess.run(run, env=_env(tmp_path), capture_output=True, text=True, check=True)
    assert again.returncode == 0 and json.loads(again.stdout) == json.loads(first)
    assert sorted((tmp_path / ("c" + kept.SUFFIX)).glob("linalg_*.xla")) == files
    called = set()
    for f in files:
        called |= set(pickle.loads(f.read_bytes()[len(kept.MAGIC) :])["kernels"])
    assert called == {name for name, (_, dtype) in lapack.PRIMERS.items() if dtype == "float64"}


def test_each_primer_lowers_to_the_kernel_it_prepares():
    """The operation :func:`gyrojax.runtime.lapack.prepare` lowers for a kernel names that kernel (jaxlib resolves
    the routines while lowering it), for every routine and dtype."""
    for name, (op, dtype) in lapack.PRIMERS.items():
        text = jax.jit(op).lower(jax.ShapeDtypeStruct((2, 2), dtype)).as_text()
        assert name in text, name
    assert lapack.preparable({"lapack_dpotrf_ffi"}) and not lapack.preparable({"lapack_dpotrf_ffi", "my_kernel"})


DIAGNOSIS = r"""
import json
import gyrojax as gj
from gyrojax.planning.triad_protocol import ferraris_steps
from gyrojax.simulation.triad_session import simulate_session

truth = {"coefficients": {"D_F": 0.5, "D_I": 0.1, "D_S": 0.2, "D_SS": 0.05}, "noise": {"white": 0.001}}
tumble = gj.simulate(gj.plans.tumble(revolutions=1, dt_s=10), truth, seed=3)
c0, steps = ferraris_steps(60.0)
session = simulate_session(steps, {"D_F[x]": 20.0, "E_SF[y]": 300.0}, start_attitude=c0, rate_hz=50.0, seed=1)
out = {"tumble": gj.diagnose(tumble, ("D_F", "D_I", "D_S")).to_json(), "triad": gj.diagnose([session]).to_json()}
print(json.dumps(out, sort_keys=True))
"""
KEPT_BY_A_DIAGNOSIS = {
    "value_and_grad",
    "likelihood_terms",
    "whiten_scan",
    "inputs_without_setup",
    "predict_sdfgyro",
    "predict_jacobian_sdfgyro",
    "static_rows_sdfgyro",
    "triad_segment_rows_sdfgyro",
    "triad_linear_matrices_sdfgyro",
}


def test_a_fresh_process_diagnoses_with_the_kept_executables_to_the_same_bits(tmp_path):
    """The library's kept functions (the noise fit's likelihood, the model's prediction (the simulator's) and Jacobian,
    the static rows, the adequacy inputs, the triad's passes) compiled and kept by a first simulation and diagnosis of a
    tumble and a triad session, then loaded, none compiled again, by a fresh process, whose diagnoses print the same
    JSON to the last digit."""
    run = [sys.executable, "-c", DIAGNOSIS]
    first = subprocess.run(run, env=_env(tmp_path), capture_output=True, text=True, check=True).stdout
    folder = tmp_path / ("c" + kept.SUFFIX)
    written = {p: p.stat().st_mtime_ns for p in folder.glob("*.xla")}
    stems = {p.name.split("-")[0].rsplit("_", 1)[0] if "sdfgyro" in p.name else p.name.split("-")[0] for p in written}
    assert stems == KEPT_BY_A_DIAGNOSIS
    again = subprocess.run(run, env=_env(tmp_path), capture_output=True, text=True, check=True).stdout
    assert again == first
    assert {p: p.stat().st_mtime_ns for p in folder.glob("*.xla")} == written  # loaded, none compiled again
