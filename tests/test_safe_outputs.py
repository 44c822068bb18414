"""Safe outputs: no silent overwrite, atomic writes (a failure mid-write leaves no partial file and the old file
intact), and saved fit results that say which gyrojax and which inputs made them. Also the chunked big-record fit
(:mod:`gyrojax.bigfit`) against the in-memory fit."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gyrojax
from gyrojax.cli import app as cli
from gyrojax.data import csvfile, plans, record, records
from gyrojax.data.record import Record
from gyrojax.data.records import load_record, save_record
from gyrojax.errors import GyrojaxError, ModelError, RecordError
from gyrojax.inference.bigfit import fit_chunked
from gyrojax.inference.identifiability import IdentifiabilityError
from gyrojax.inference.identify import fit
from gyrojax.simulation.simulator import simulate

NAME = "ccw-up"  # the run of a one-run polar tumble


TUMBLE_TERMS = ["D_F", "D_I", "D_S", "D_IS"]


@pytest.fixture(scope="module")
def tumble_dir(tmp_path_factory):
    truth = {"coefficients": {"D_F": 0.5, "D_I": 0.3, "D_S": 0.1, "D_IS": 0.05}, "noise": {"white": 0.01}}
    plan = plans.tumble(revolutions=1, earth_rates=20, dt_s=5, flip=False, both_directions=False)
    (r,) = simulate(plan, truth, seed=3)
    d = tmp_path_factory.mktemp("tumble")
    save_record(r, d)
    return d / f"{r.name}.json"


@pytest.fixture(scope="module")
def rec(tumble_dir):
    return load_record(tumble_dir)


def _listing(d: Path) -> list[str]:
    return sorted(p.name for p in d.iterdir())


# ---- overwrite protection ----------------------------------------------------------------------------------------


def test_save_record_refuses_to_overwrite(rec, tmp_path):
    save_record(rec, tmp_path)
    before = {p: p.read_bytes() for p in tmp_path.iterdir()}
    changed = rec.with_columns(current_mA=rec.columns["current_mA"] + 1.0)
    with pytest.raises(RecordError, match="exists.*force"):
        save_record(changed, tmp_path)
    assert {p: p.read_bytes() for p in tmp_path.iterdir()} == before
    # only the JSON present (CSV lost): still refused, nothing written
    (tmp_path / f"{NAME}.csv").unlink()
    with pytest.raises(RecordError, match="exists"):
        save_record(changed, tmp_path)
    assert _listing(tmp_path) == [f"{NAME}.json"]
    save_record(changed, tmp_path, force=True)
    np.testing.assert_array_equal(
        load_record(tmp_path / f"{NAME}.csv").columns["current_mA"], changed.columns["current_mA"]
    )


def test_cli_simulate_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "out"
    args = ["simulate", "fixed", "-o", "hours=0.005", "--out", str(out)]
    assert cli.main(args) == 0
    capsys.readouterr()
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert cli.main(args + ["--seed", "3"]) == 2
    err = capsys.readouterr().err
    assert "exists" in err and "--force" in err and err.count("\n") == 1
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert cli.main(args + ["--force"]) == 0


# ---- atomic writes -----------------------------------------------------------------------------------------------


class Boom(RuntimeError):
    pass


def _failing_fmt(after: int):
    """A stand-in for the CSV cell formatter that fails after ``after`` cells: a crash in the middle of the file."""
    real = csvfile._fmt
    count = {"n": 0}

    def fmt(x):
        count["n"] += 1
        if count["n"] > after:
            raise Boom("disk full (simulated)")
        return real(x)

    return fmt


def test_failure_mid_csv_leaves_no_file(rec, tmp_path, monkeypatch):
    # 5-row chunks: the failure comes after three chunks already went to disk
    monkeypatch.setattr(records, "record_csv_chunks", lambda r, rows=5, _f=records.record_csv_chunks: _f(r, rows))
    monkeypatch.setattr(csvfile, "_fmt", _failing_fmt(3 * 5 * 5 + 2))
    with pytest.raises(Boom):
        save_record(rec, tmp_path)
    assert _listing(tmp_path) == []  # neither the CSV, nor the JSON, nor a temporary file


def test_failure_mid_write_keeps_the_old_record(rec, tmp_path, monkeypatch):
    save_record(rec, tmp_path)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    monkeypatch.setattr(csvfile, "_fmt", _failing_fmt(40))
    with pytest.raises(Boom):
        save_record(rec.with_columns(current_mA=rec.columns["current_mA"] * 2), tmp_path, force=True)
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_failure_writing_json_leaves_no_csv(rec, tmp_path, monkeypatch):
    real = json.dumps

    def dumps(obj, *a, **k):
        if isinstance(obj, dict) and obj.get("format") == record.FORMAT:
            raise Boom("crash while writing the JSON")
        return real(obj, *a, **k)

    monkeypatch.setattr(records.json, "dumps", dumps)
    with pytest.raises(Boom):
        save_record(rec, tmp_path)
    assert _listing(tmp_path) == []


def test_failure_at_rename_leaves_no_temporary(rec, tmp_path, monkeypatch):
    def replace(src, dst):
        raise OSError(28, "No space left on device", str(dst))

    monkeypatch.setattr(records.os, "replace", replace)
    with pytest.raises(OSError):
        save_record(rec, tmp_path)
    assert _listing(tmp_path) == []


def test_invalid_record_writes_nothing(rec, tmp_path):
    bad = rec.with_columns(time_s=rec.columns["time_s"][::-1].copy())
    with pytest.raises(RecordError, match="time_s"):
        save_record(bad, tmp_path)
    assert _listing(tmp_path) == []


# ---- fit --save: provenance ---------------------------------------------------------------------------------------


def test_fit_save_records_version_and_input_hashes(rec, tmp_path, capsys):
    save_record(rec, tmp_path / "r")
    out = tmp_path / "fit.json"
    args = ["fit", str(tmp_path / "r" / f"{NAME}.json"), "--terms", "D_F", "--save", str(out)]
    assert cli.main(args) == 0
    d = json.loads(out.read_text())
    assert d["gyrojax_version"] == gyrojax.__version__
    (inp,) = d["inputs"]
    assert inp["name"] == NAME and inp["path"].endswith(f"{NAME}.csv")
    assert len(inp["sha256"]) == 64 and int(inp["sha256"], 16) >= 0
    # refuses to overwrite; --force replaces
    capsys.readouterr()
    assert cli.main(args) == 2 and "exists" in capsys.readouterr().err
    # the hash identifies the data: one changed sample changes it; a byte-identical re-save does not
    cur = rec.columns["current_mA"].copy()
    cur[7] += 1e-12
    save_record(rec.with_columns(current_mA=cur), tmp_path / "r", force=True)
    assert cli.main(args + ["--force"]) == 0
    h2 = json.loads(out.read_text())["inputs"][0]["sha256"]
    assert h2 != inp["sha256"]
    save_record(rec, tmp_path / "r", force=True)
    assert cli.main(args + ["--force"]) == 0
    assert json.loads(out.read_text())["inputs"][0]["sha256"] == inp["sha256"]


# ---- the chunked fit ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("chunk_rows", [300])
def test_chunked_fit_equals_in_memory_fit(tumble_dir, chunk_rows):
    ref = fit([load_record(tumble_dir)], TUMBLE_TERMS, noise="white")
    got = fit_chunked(tumble_dir, TUMBLE_TERMS, chunk_rows=chunk_rows)
    assert got.n_samples == ref.n_samples > 800
    assert got.chunks == math.ceil(got.n_samples / chunk_rows)
    np.testing.assert_allclose(got.theta, ref.theta, rtol=1e-9, atol=0)
    np.testing.assert_allclose(got.std, ref.std, rtol=1e-9, atol=0)
    np.testing.assert_allclose(got.residual_rms, ref.residual_rms, rtol=1e-9)


def test_chunked_fit_names_the_file_row_of_a_bad_cell(tumble_dir, tmp_path):
    d = tmp_path / "bad"
    d.mkdir()
    lines = tumble_dir.with_suffix(".csv").read_text().splitlines()
    head = lines[0].split(",")
    cells = lines[499].split(",")  # row 500 of the file, in the sixth chunk of 97 rows
    cells[head.index("current_mA")] = "inf"
    lines[499] = ",".join(cells)
    (d / tumble_dir.with_suffix(".csv").name).write_text("\n".join(lines) + "\n")
    (d / tumble_dir.name).write_text(tumble_dir.read_text())
    with pytest.raises(RecordError, match=r"\.csv: row 500, column 'current_mA'"):
        fit_chunked(d / tumble_dir.name, TUMBLE_TERMS, chunk_rows=97)
    cells[head.index("current_mA")] = "oops"
    lines[499] = ",".join(cells)
    (d / tumble_dir.with_suffix(".csv").name).write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordError, match=r"row 500, column 'current_mA' holds 'oops'"):
        fit_chunked(d / tumble_dir.name, TUMBLE_TERMS, chunk_rows=97)
    # a time that goes back across a chunk edge (rows 98 and 99 are in different chunks)
    t98 = lines[97].split(",")[head.index("time_s")]
    lines = tumble_dir.with_suffix(".csv").read_text().splitlines()
    cells = lines[98].split(",")
    cells[head.index("time_s")] = t98
    lines[98] = ",".join(cells)
    (d / tumble_dir.with_suffix(".csv").name).write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordError, match=r"row 99, column 'time_s'.*increasing"):
        fit_chunked(d / tumble_dir.name, TUMBLE_TERMS, chunk_rows=97)


def test_chunked_fit_refuses_what_it_cannot_do(tumble_dir):
    with pytest.raises(ModelError, match="linear"):
        fit_chunked(tumble_dir, ["D_F", "table_tilt"])
    with pytest.raises(IdentifiabilityError, match="D_F.*D_II.*D_SS"):
        fit_chunked(tumble_dir, ["D_F", "D_II", "D_SS"])
    with pytest.raises(ModelError, match="temperature_C"):
        fit_chunked(tumble_dir, ["D_F", "bias_temperature"])
    with pytest.raises(GyrojaxError, match="no such file"):
        fit_chunked(tumble_dir.with_name("absent.json"), ["D_F"])


def test_chunked_fit_static_positions_without_rate_columns(tmp_path):
    """Rates derived from angles: zero where the table holds still inside a segment, so static multi-position records
    without rate columns stream too, and agree with the in-memory fit."""
    truth = {"coefficients": {"D_F": 0.5, "D_I": 0.3, "D_O": -0.2, "D_S": 0.1}, "noise": {"white": 0.01}}
    plan = plans.multiposition(positions=[(0, 0), (90, 0), (180, 0), (90, 90)], minutes=1.0)
    (r,) = simulate(plan, truth, seed=5)
    cols = {k: v for k, v in r.columns.items() if not k.startswith("rate_")}
    save_record(Record(r.meta, cols), tmp_path)
    path = tmp_path / f"{r.name}.json"
    terms = ["D_F", "D_I", "D_O", "D_S"]
    ref = fit([load_record(path)], terms, noise="white")
    got = fit_chunked(path, terms, chunk_rows=50)
    np.testing.assert_allclose(got.theta, ref.theta, rtol=1e-9)
    np.testing.assert_allclose(got.std, ref.std, rtol=1e-9)


def test_compilation_cache_location_follows_the_environment(monkeypatch, tmp_path):
    """The CLI's persistent compilation cache: GYROJAX_NO_CACHE turns it off, GYROJAX_CACHE_DIR places it, otherwise
    it lives under XDG_CACHE_HOME (or ~/.cache) in gyrojax/jax."""
    from gyrojax.runtime.cache import cache_dir

    for var in ("GYROJAX_NO_CACHE", "GYROJAX_CACHE_DIR", "XDG_CACHE_HOME"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    assert cache_dir() == str(tmp_path / ".cache" / "gyrojax" / "jax")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir() == str(tmp_path / "xdg" / "gyrojax" / "jax")
    monkeypatch.setenv("GYROJAX_CACHE_DIR", str(tmp_path / "here"))
    assert cache_dir() == str(tmp_path / "here")
    monkeypatch.setenv("GYROJAX_NO_CACHE", "0")
    assert cache_dir() == str(tmp_path / "here")
    monkeypatch.setenv("GYROJAX_NO_CACHE", "1")
    assert cache_dir() is None


_SETTINGS = "import jax; settings = lambda: {k: repr(v) for k, v in jax.config.values.items()}\n"
_SETTINGS_PROBE = {
    "jax-alone": _SETTINGS + "print(json.dumps({'after': settings()}))",
    "jax-first": _SETTINGS + "before = settings()\nimport gyrojax\n",
    "gyrojax-first": "import gyrojax\n" + _SETTINGS,
}
_KEPT_CALL = r"""
import jax.numpy as jnp
from gyrojax.runtime.kept import Kept
Kept("probe", jax.jit(lambda a: jnp.linalg.cholesky(a)))(np.eye(2))  # compiled, saved and called
print(json.dumps({"before": globals().get("before"), "after": settings(),
                  "env": sorted(set(os.environ.items()) ^ set(env.items()))}))
"""


def _probe(tmp_path, order):
    """JAX's settings (and the environment's change) in a fresh process: JAX alone with x64, or with gyrojax
    imported after or before it and a kept function called."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("GYROJAX_", "JAX_", "XDG_CACHE"))}
    env["GYROJAX_CACHE_DIR"] = str(tmp_path / "here")
    code = "import json, os, sys\nimport numpy as np\nenv = dict(os.environ)\n" + _SETTINGS_PROBE[order]
    if order == "jax-alone":
        env["JAX_ENABLE_X64"] = "1"
    else:
        code += _KEPT_CALL
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.splitlines()[-1])


def test_import_gyrojax_changes_no_jax_setting_but_x64(tmp_path):
    """``import gyrojax`` in a fresh process (a notebook's kernel), after or before JAX's, and a kept function
    compiled and called: every JAX setting is what JAX alone (with x64) has, the persistent compilation cache among
    them; the one variable set is JAX_ENABLE_X64 (when JAX is not imported yet). gyrojax's executables are kept in
    its own folder all the same."""
    alone = _probe(tmp_path, "jax-alone")["after"]
    assert alone["jax_compilation_cache_dir"] == "None" and alone["jax_enable_x64"] == "True"
    jax_first = _probe(tmp_path, "jax-first")
    assert {k for k in alone if jax_first["before"][k] != jax_first["after"][k]} == {"jax_enable_x64"}
    assert jax_first["after"] == alone and jax_first["env"] == []
    gyrojax_first = _probe(tmp_path, "gyrojax-first")
    assert gyrojax_first["after"] == alone and gyrojax_first["env"] == [["JAX_ENABLE_X64", "1"]]
    assert len(list((tmp_path / "here-kept").glob("probe-*.xla"))) == 1


_CLI_PROBE = (
    "import jax; from gyrojax.cli.app import main; main(['plans']); print(jax.config.jax_compilation_cache_dir)"
)


@pytest.mark.parametrize(
    "env, want",
    [
        ({"GYROJAX_CACHE_DIR": "{tmp}/here"}, "{tmp}/here"),
        ({"XDG_CACHE_HOME": "{tmp}/xdg"}, "{tmp}/xdg/gyrojax/jax"),
        ({"GYROJAX_NO_CACHE": "1", "GYROJAX_CACHE_DIR": "{tmp}/here"}, "None"),
    ],
)
def test_the_command_turns_the_compilation_cache_on_for_its_own_process(tmp_path, env, want):
    """The command's process is gyrojax's alone: it keeps every compiled function in JAX's persistent cache at
    gyrojax's cache folder, and GYROJAX_NO_CACHE=1 keeps it off."""
    base = {k: v for k, v in os.environ.items() if not k.startswith(("GYROJAX_", "JAX_COMPILATION", "XDG_CACHE"))}
    base.update({k: v.format(tmp=tmp_path) for k, v in env.items()})
    out = subprocess.run(
        [sys.executable, "-c", _CLI_PROBE], env=base, capture_output=True, text=True, check=True
    ).stdout.strip()
    assert out.splitlines()[-1] == want.format(tmp=tmp_path)
