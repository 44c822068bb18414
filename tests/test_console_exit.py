"""The ``gyrojax`` process ends without the interpreter's teardown (gyrojax.cli.app.console, issue 26), and loses
nothing by it: the same bytes on stdout and the same exit code as the ordinary exit, the exit handlers run, and a
thread still at work is waited for."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from gyrojax.data import plans
from gyrojax.data.records import save_record
from gyrojax.report.demo import TRUTH
from gyrojax.simulation.simulator import simulate

ROOT = Path(__file__).resolve().parent.parent
ORDINARY = "import sys; from gyrojax.cli.app import main; sys.argv[0] = 'gyrojax'; raise SystemExit(main())"


def _run(args, env_dir: Path, code: str | None = None):
    # the suite's compilation cache (tests/conftest.py) where there is one: what the processes compile is not the test
    env = {"GYROJAX_CACHE_DIR": os.environ.get("GYROJAX_CACHE_DIR", str(env_dir)), "PATH": "/usr/bin:/bin"}
    cmd = [sys.executable, "-m", "gyrojax", *args] if code is None else [sys.executable, "-c", code, *args]
    return subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, timeout=300)


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    out = tmp_path_factory.mktemp("campaign")
    for rec in simulate(plans.tumble(revolutions=1.0, dt_s=30.0), TRUTH, seed=3):
        save_record(rec, out)
    return sorted(str(p) for p in out.glob("*.csv"))


def test_the_console_writes_what_the_ordinary_exit_writes(records, tmp_path):
    args = ["diagnose", *records, "--terms", "D_F,D_I,D_S", "--json"]
    fast, slow = _run(args, tmp_path), _run(args, tmp_path, ORDINARY)
    assert fast.returncode == slow.returncode == 0, fast.stderr
    assert len(fast.stdout) > 1000 and fast.stdout == slow.stdout  # the whole JSON, byte for byte
    bad = _run(["fit", str(tmp_path / "none.csv")], tmp_path)
    assert bad.returncode == 2 and b"none.json: no such file" in bad.stderr


def _probe(tmp_path: Path, working_thread: bool):
    """``gyrojax --version`` by console() in a fresh interpreter with an exit handler, an object whose finalizer
    runs only in the interpreter's teardown (it writes through a descriptor and a function bound beforehand, which
    the teardown cannot have cleared) and, with ``working_thread``, a thread still writing: the marks that were
    written."""
    files = {k: tmp_path / k for k in ("handler", "teardown", "worker")}
    code = (
        "import atexit, os, sys, threading, time\n"
        f"atexit.register(lambda: open({str(files['handler'])!r}, 'w').write('ran'))\n"
        f"fd = os.open({str(files['teardown'])!r}, os.O_WRONLY | os.O_CREAT)\n"
        "class Late:\n"
        "    def __del__(self, _write=os.write, _fd=fd):\n"
        "        _write(_fd, b'ran')\n"
        "late = Late()\n"
        + (
            f"threading.Thread(target=lambda: (time.sleep(0.5), open({str(files['worker'])!r}, 'w').write('done')))"
            ".start()\n"
            if working_thread
            else ""
        )
        + "sys.argv = ['gyrojax', '--version']\nfrom gyrojax.cli.app import console\nconsole()\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and out.stdout.strip(), out.stderr
    return {k for k, f in files.items() if f.is_file() and f.read_bytes()}


def test_the_console_skips_only_the_teardown(tmp_path):
    assert _probe(tmp_path, working_thread=False) == {"handler"}  # exit handlers run; object teardown skipped


def test_the_console_waits_for_a_thread_at_work(tmp_path):
    assert _probe(tmp_path, working_thread=True) == {"handler", "teardown", "worker"}  # the ordinary exit
