"""Execute each tutorial notebook (jupytext percent-format ``notebooks/*.py``) headless and check its final figure.

Each notebook ends by saving ``<nn>_final.png``; the test runs it in a temporary working directory with a kernel
spec pointing at this interpreter (written into a temporary prefix, so it works from a fresh ``pip install``).
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gyrojax.runtime.cache import persistent_cache_settings

jupytext = pytest.importorskip("jupytext")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.py"))
STUDIES = {"13_campaign_loop"}
"""Notebooks that run a whole campaign (minutes of compilation on a fresh machine): studies (``make studies``); the
loop they show is tested in ``test_adaptive``."""


@pytest.fixture(scope="module")
def kernel_env(tmp_path_factory):
    """A ``python3`` kernel spec for this interpreter in a temporary prefix; env with JUPYTER_PATH, Agg, PYTHONPATH."""
    prefix = tmp_path_factory.mktemp("kernel")
    subprocess.run(
        [sys.executable, "-m", "ipykernel", "install", "--prefix", str(prefix), "--name", "python3"],
        check=True,
        capture_output=True,
    )
    # a kernel is a process of the suite's alone: JAX's persistent cache of the session (tests/conftest.py) serves
    # it as it serves the command lines the tests run, for every function however small (gyrojax.runtime.cache)
    cache = {name.upper(): str(v) for name, v in (persistent_cache_settings() or {}).items()}
    saved = {k: os.environ.get(k) for k in ("JUPYTER_PATH", "MPLBACKEND", "PYTHONPATH", *cache)}
    os.environ.update(cache)
    os.environ["JUPYTER_PATH"] = os.pathsep.join(
        filter(None, [str(prefix / "share" / "jupyter"), saved["JUPYTER_PATH"]])
    )
    os.environ["MPLBACKEND"] = "Agg"
    os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), saved["PYTHONPATH"]]))
    yield
    for k, v in saved.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


def test_notebooks_exist():
    assert len(NOTEBOOKS) >= 4


@pytest.mark.parametrize(
    "path", [pytest.param(p, id=p.stem, marks=[pytest.mark.slow] if p.stem in STUDIES else []) for p in NOTEBOOKS]
)
def test_notebook_runs_and_writes_final_figure(path, tmp_path, kernel_env):
    nb = jupytext.reads(path.read_text(encoding="utf-8"), fmt="py:percent")
    client = nbclient.NotebookClient(
        nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    )
    t0 = time.time()
    client.execute()
    print(f"{path.name}: {time.time() - t0:.1f} s")
    png = tmp_path / f"{path.stem[:2]}_final.png"
    assert png.exists() and png.stat().st_size > 1000, f"{path.name} did not write {png.name}"
    # the last code cell displays the figure
    last = [c for c in nb.cells if c.cell_type == "code"][-1]
    assert any("image/png" in o.get("data", {}) for o in last.get("outputs", [])), f"{path.name}: figure not shown"
