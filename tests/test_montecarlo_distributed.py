"""A Monte Carlo study split over processes equals the single-process run: as one ``jax.distributed`` job of two
local processes (gloo collectives over localhost), and as independent index ranges merged afterwards."""

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gyrojax.cli import app as cli
from gyrojax.montecarlo import hosts, results, runner
from gyrojax.montecarlo import study as mc
from gyrojax.runtime import kept

ROOT = Path(__file__).resolve().parents[1]
STUDY = {
    "plan": "multiposition",
    "plan_options": {"n": 8, "minutes": 1, "dt_s": 5},
    "terms": ["D_F", "D_I", "D_O"],
    "priors": {"D_F": {"normal": [0, 1]}, "D_I": {"uniform": [-1, 1]}, "D_O": 0.3, "D_S": {"normal": [0, 0.2]}},
    "noise": {"white": 0.01, "gauss_markov": [0.1, 30.0]},
    "draws": 37,
    "seed": 5,
    "chunk": 8,  # one compiled shape for every run here (37 draws: the last chunk padded; 18 + 19 on two processes)
}
COLUMNS = ("truth", "estimate", "std", "rms")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _assert_same(a: results.StudyResult, b: results.StudyResult) -> None:
    np.testing.assert_array_equal(a.draw, b.draw)
    assert a.truth_names == b.truth_names and a.fit_names == b.fit_names
    for k in COLUMNS:
        np.testing.assert_allclose(getattr(a, k), getattr(b, k), rtol=1e-12, atol=1e-12)


def test_share_splits_every_draw_once():
    for n in (0, 1, 5, 37, 1000):
        for nproc in (1, 2, 3, 7):
            blocks = [hosts.share(n, nproc, k) for k in range(nproc)]
            idx = np.concatenate([np.arange(lo, hi) for lo, hi in blocks])
            np.testing.assert_array_equal(idx, np.arange(n))
            sizes = [hi - lo for lo, hi in blocks]
            assert max(sizes) - min(sizes) <= 1


def _two_processes(sp: Path, out: Path, cache: Path) -> list[str]:
    """``gyrojax mc`` of the study ``sp`` as two processes of one jax.distributed job (coordinator on a free
    localhost port) with gyrojax's cache in ``cache``: the stdout of each."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), JAX_PLATFORMS="cpu", GYROJAX_CACHE_DIR=str(cache), GYROJAX_DEBUG="")
    for k in ("JAX_COORDINATOR_ADDRESS", "GYROJAX_NO_CACHE"):
        env.pop(k, None)
    port = _free_port()
    procs = []
    try:
        for k in (0, 1):
            cmd = [sys.executable, "-m", "gyrojax", "mc", str(sp), "--out", str(out), "--json", "--force"]
            cmd += ["--coordinator", f"127.0.0.1:{port}", "--num-processes", "2", "--process-id", str(k)]
            procs.append(subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
        outs = [p.communicate(timeout=120) for p in procs]
    finally:
        for p in procs:  # never leave a process behind, whatever happened
            if p.poll() is None:
                p.kill()
                p.wait()
    for p, (_so, se) in zip(procs, outs):
        assert p.returncode == 0, se[-2000:]
    return [so for so, _ in outs]


def test_two_process_distributed_mc_equals_one_process(tmp_path):
    """Two processes of one jax.distributed job write what one process does, with gyrojax's cache empty and again
    with the executables the first job kept (each process keeps its own: one compiled for another process' device
    would wait for it for ever)."""
    sp = tmp_path / "study.json"
    sp.write_text(json.dumps(STUDY))
    one = runner.run_study(mc.study_from_dict(STUDY))
    assert np.abs(one.estimate).max() > 0.1  # the comparison has teeth
    results.save_result(one, tmp_path / "one")
    for run in ("cold", "kept"):
        out = tmp_path / run
        stdout = _two_processes(sp, out, tmp_path / "cache")
        rep0 = json.loads(stdout[0].strip().splitlines()[-1])
        assert rep0["draws"] == 37 and stdout[1].strip() == ""  # process 0 alone reports and writes
        _assert_same(results.load_result(out), one)
        # the files process 0 wrote are the single-process files
        assert (out / "summary.csv").read_text() == (tmp_path / "one" / "summary.csv").read_text()
        assert json.loads((out / "study.json").read_text()) == json.loads((tmp_path / "one" / "study.json").read_text())
    assert len(list((tmp_path / ("cache" + kept.SUFFIX)).glob("*.xla"))) >= 2  # kept, by each process


def test_index_ranges_merge_to_the_whole_run(tmp_path, capsys):
    """The no-coordination split: mc --start/--draws per host, then mc-merge; overlaps and other studies refused."""
    sp = tmp_path / "study.json"
    sp.write_text(json.dumps(STUDY))
    assert cli.main(["mc", str(sp), "--out", str(tmp_path / "b"), "--start", "20", "--draws", "17"]) == 0
    assert cli.main(["mc", str(sp), "--out", str(tmp_path / "a"), "--draws", "20"]) == 0
    assert cli.main(["mc", str(sp), "--out", str(tmp_path / "all")]) == 0
    capsys.readouterr()
    assert cli.main(["mc-merge", str(tmp_path / "b"), str(tmp_path / "a"), "--out", str(tmp_path / "m"), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["draws"] == 37
    merged, whole = results.load_result(tmp_path / "m"), results.load_result(tmp_path / "all")
    _assert_same(merged, whole)
    assert (tmp_path / "m" / "summary.csv").read_text() == (tmp_path / "all" / "summary.csv").read_text()
    assert merged.study == whole.study

    assert cli.main(["mc-merge", str(tmp_path / "a"), str(tmp_path / "all"), "--out", str(tmp_path / "x")]) == 2
    assert "draw 0 is in" in capsys.readouterr().err
    sp.write_text(json.dumps({**STUDY, "seed": 6}))
    assert cli.main(["mc", str(sp), "--out", str(tmp_path / "c"), "--start", "37", "--draws", "3"]) == 0
    assert cli.main(["mc-merge", str(tmp_path / "all"), str(tmp_path / "c"), "--out", str(tmp_path / "x")]) == 2
    assert "'seed' differs" in capsys.readouterr().err
    assert cli.main(["mc-merge", str(tmp_path / "a"), str(tmp_path / "nothing"), "--out", str(tmp_path / "x")]) == 2
    assert cli.main(["mc-merge", str(tmp_path / "a"), "--out", str(tmp_path / "m")]) == 2  # exists: --force
    assert "--force" in capsys.readouterr().err


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--coordinator", "localhost"], "HOST:PORT"),
        (["--num-processes", "0", "--process-id", "0", "--coordinator", "127.0.0.1:1"], "--num-processes"),
        (["--num-processes", "2", "--process-id", "2", "--coordinator", "127.0.0.1:1"], "--process-id"),
        (["--start", "-1"], "--start"),
    ],
)
def test_bad_distributed_options_exit_2(tmp_path, capsys, argv, needle):
    sp = tmp_path / "study.json"
    sp.write_text(json.dumps(STUDY))
    assert cli.main(["mc", str(sp), "--out", str(tmp_path / "o"), *argv]) == 2
    err = capsys.readouterr().err
    assert needle in err and len(err.strip().splitlines()) == 1
