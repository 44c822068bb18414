"""Lazy imports (issue 26): the commands that need no arithmetic start without JAX, and the flat API still loads
on first use with float64 on. Each case runs in a fresh interpreter, as the command does."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SESSION = ROOT / "tests" / "data" / "imucal" / "annotated_session.csv"

PROBE = r"""
import contextlib, io, json, sys
from gyrojax.cli.app import main
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    try:
        rc = main(sys.argv[1:])
    except SystemExit as e:  # --help
        rc = e.code
print(json.dumps({"rc": rc, "jax": "jax" in sys.modules}))
"""


def _run(code: str, *args: str) -> str:
    env = {"GYROJAX_NO_CACHE": "1", "PATH": "/usr/bin:/bin"}
    out = subprocess.run(
        [sys.executable, "-c", code, *args], cwd=ROOT, env=env, capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0, out.stderr
    return out.stdout.strip().splitlines()[-1]


@pytest.mark.parametrize(
    "argv",
    [
        ["--help"],
        ["--version"],
        ["plans"],
        ["import", "imucal", str(SESSION), "--gyro-scale", "16.4", "--out", "OUT"],
    ],
    ids=["help", "version", "plans", "import"],
)
def test_commands_without_arithmetic_do_not_import_jax(argv, tmp_path):
    argv = [str(tmp_path / "o") if a == "OUT" else a for a in argv]
    got = json.loads(_run(PROBE, *argv))
    assert got == {"rc": 0, "jax": False}
    if argv[0] == "import":  # the command did its work, not an early error
        assert (tmp_path / "o" / "annotated_session.json").is_file()


def test_the_command_that_computes_imports_jax_with_float64(tmp_path):
    # the probe's own check: a command that fits does load JAX (the test above can fail), in float64
    code = PROBE.replace('"jax" in sys.modules', '__import__("jax").numpy.ones(1).dtype.name')
    got = json.loads(_run(code, "simulate", "tumble", "-o", "revolutions=1", "-o", "dt_s=30", "--out", str(tmp_path)))
    assert got == {"rc": 0, "jax": "float64"}


@pytest.mark.parametrize("jax_first", [False, True], ids=["gyrojax-first", "jax-first"])
def test_flat_api_loads_lazily_in_float64(jax_first):
    code = (
        ("import jax\n" if jax_first else "")
        + "import sys\nimport gyrojax as gj\nbefore = 'jax' in sys.modules\n"
        + "import jax.numpy as jnp\nprint(before, callable(gj.fit), callable(gj.diagnose), jnp.ones(1).dtype)"
    )
    assert _run(code) == f"{jax_first} True True float64"


def test_a_triad_fit_process_loads_neither_scipy_stats_nor_scipy_signal(tmp_path):
    # issue 26: `gyrojax fit` of a hand session stays near the import floor: scipy.stats (0.2-0.4 s; scipy.signal
    # loads it too) is not on its path (χ² tails by scipy.special, the same bits); the command did fit (rc 0)
    from gyrojax.data.records import save_record
    from gyrojax.montecarlo.triad import mems_truth
    from gyrojax.simulation.triad import simulate_multiposition

    save_record(simulate_multiposition(mems_truth(), poses=12, static_s=2.0, move_s=1.0, seed=1), tmp_path)
    (csv,) = tmp_path.glob("*.csv")
    code = PROBE.replace(
        '"jax": "jax" in sys.modules', '"stats": "scipy.stats" in sys.modules, "signal": "scipy.signal" in sys.modules'
    )
    assert json.loads(_run(code, "fit", str(csv), "--json")) == {"rc": 0, "stats": False, "signal": False}


def test_a_triad_diagnose_process_loads_neither_pandas_nor_scipy_stats(tmp_path):
    # a diagnosis of a hand session as a process: its CSV read by numpy, its tails and quantiles by scipy.special
    # (gyrojax.tails, the same bits as scipy.stats); the command did diagnose (rc 0, or 1: inadequate)
    from gyrojax.data.records import save_record
    from gyrojax.montecarlo.triad import mems_truth
    from gyrojax.simulation.triad import simulate_multiposition

    save_record(simulate_multiposition(mems_truth(), poses=12, static_s=2.0, move_s=1.0, seed=1), tmp_path)
    (meta,) = tmp_path.glob("*.json")
    code = PROBE.replace(
        '"jax": "jax" in sys.modules', '"stats": "scipy.stats" in sys.modules, "pandas": "pandas" in sys.modules'
    )
    got = json.loads(_run(code, "diagnose", str(meta), "--json"))
    assert got["rc"] in (0, 1) and not got["stats"] and not got["pandas"]
