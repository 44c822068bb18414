"""``gyrojax design --separate A,B --from RECORDS`` (issue 27): on a polar tumble, whose mounting keeps a_I² + a_S²
constant so that D_SS is an exact alias of D_II (with D_F), the designed follow-up test is predicted to separate
them within 2 h; the prediction is checked against the independent score-test noncentrality of tests/power.py,
and the joint fit of the simulated test with the original records resolves the alias. A base tilt about North
and an azimuth error are refused (no test on any table separates them), bad input exits 2 with one line."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import stats

from gyrojax.cli.app import main
from gyrojax.data import plans
from gyrojax.data.planfile import load_plan
from gyrojax.data.records import load_records, save_record
from gyrojax.inference.identify import fit
from gyrojax.inference.separation import case_turns
from gyrojax.simulation.simulator import plan_records, simulate
from tests import power

BASE = ["D_F", "D_I", "D_O", "D_S"]
ARW = 0.01
TRUTH = {"D_F": 0.5, "D_I": 0.2, "D_O": -0.1, "D_S": 0.05, "D_SS": 0.15}


@pytest.fixture(scope="module")
def tumble_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("tumble")
    for r in simulate(
        plans.tumble(revolutions=1.0, dt_s=60.0), {"coefficients": TRUTH, "noise": {"white": ARW}}, seed=5
    ):
        save_record(r, d)
    return d


@pytest.fixture(scope="module")
def designed(tumble_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("design") / "separate.json"
    args = ["design", "--separate", "D_II,D_SS", "--from", str(tumble_dir), "--hours", "2", "--out", str(out)]
    return out, args + ["--positions", "8", "--starts", "1", "--adam-steps", "200", "--json"]


def _one_line_error(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err and "\n" not in err and "Traceback" not in err
    return err


def test_case_turns_are_the_24_rotations_of_a_cube():
    p = case_turns()
    assert p.shape == (24, 3, 3)
    assert np.allclose(p[0], np.eye(3))
    for m in p:
        assert np.allclose(m @ m.T, np.eye(3)) and np.isclose(np.linalg.det(m), 1.0)
        assert set(np.abs(m).ravel()) == {0.0, 1.0}
    assert len({tuple(m.ravel()) for m in p}) == 24


def test_tumble_alias_is_separated_by_the_designed_test(tumble_dir, designed, capsys):
    recs = load_records(tumble_dir)
    # the campaign cannot see D_SS beside D_II: exact alias (independent regressors of tests/power.py)
    assert power.noncentrality(recs, BASE + ["D_II"], "D_SS", TRUTH, ARW) < 1e-6

    out, argv = designed
    assert main(argv) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["hours_needed"] is not None and rep["hours_needed"] <= 2.0
    assert rep["power"]["D_II"] >= 0.9 and rep["power"]["D_SS"] >= 0.9
    assert abs(rep["dwell_hours"] - 2.0) < 0.01

    # the predicted noncentrality of D_SS beside D_II, against the independent one of the joint campaign
    plan = load_plan(out)
    geometry = plan_records(plan)
    size = {"D_SS": rep["size"]["D_SS"][0]}
    lam = power.noncentrality(recs + geometry, BASE + ["D_II"], "D_SS", size, ARW)
    assert lam == pytest.approx(rep["noncentrality"]["D_SS"], rel=0.15)

    # simulate the plan with the campaign's truth and fit it jointly with the original records
    new = simulate(plan, {"coefficients": TRUTH, "noise": {"white": ARW}}, seed=6)
    lam_true = power.noncentrality(recs + new, BASE + ["D_II"], "D_SS", TRUTH, ARW)
    assert stats.norm.sf(3.0 - np.sqrt(power.MARGIN * lam_true)) >= 0.999  # D_SS is ≥ 3σ from zero with power 0.999
    res = fit(recs + new, BASE + ["D_II", "D_SS"])
    v, s = res.values, res.stds
    assert abs(v["D_SS"] - TRUTH["D_SS"]) < 4 * s["D_SS"]
    assert abs(v["D_SS"]) >= 3 * s["D_SS"]
    assert abs(v["D_II"]) < 4 * s["D_II"]


def test_tilt_and_azimuth_are_refused_with_the_reason(tumble_dir, tmp_path, capsys):
    argv = ["design", "--separate", "table_tilt,table_azimuth", "--from", str(tumble_dir), "--out"]
    err = _one_line_error(capsys, argv + [str(tmp_path / "p.json")])
    assert "collinear" in err and "delta_N" in err and "delta_U" in err and "levelling" in err
    assert not (tmp_path / "p.json").exists()


@pytest.mark.parametrize(
    "pair, says",
    [
        ("D_II,D_XX", "unknown effect 'D_XX'"),
        ("D_II,DX_F", "not an effect of the records' instrument kind sdf-gyro"),
        ("D_II", "two effect names"),
        ("D_II,D_II", "twice"),
    ],
)
def test_bad_effects_exit_2(tumble_dir, tmp_path, capsys, pair, says):
    err = _one_line_error(
        capsys, ["design", "--separate", pair, "--from", str(tumble_dir), "--out", str(tmp_path / "p")]
    )
    assert says in err


def test_no_records_exit_2(tmp_path, capsys):
    assert "--from" in _one_line_error(capsys, ["design", "--separate", "D_II,D_SS", "--out", str(tmp_path / "p")])
    (tmp_path / "empty").mkdir()
    argv = ["design", "--separate", "D_II,D_SS", "--from", str(tmp_path / "empty"), "--out", str(tmp_path / "p")]
    assert "no record" in _one_line_error(capsys, argv)
    assert "--separate" in _one_line_error(capsys, ["design", "--from", str(tmp_path), "--out", str(tmp_path / "p")])


def test_options_separate_does_not_use_are_refused(tumble_dir, tmp_path, capsys):
    argv = ["design", "--separate", "D_II,D_SS", "--from", str(tumble_dir), "--out", str(tmp_path / "p")]
    assert "--arw" in _one_line_error(capsys, argv + ["--arw", "0.02"])
    assert "--criterion" in _one_line_error(capsys, argv + ["--criterion", "A"])


def test_diagnose_names_the_designed_test(tumble_dir):
    from gyrojax.inference.diagnose import diagnose

    d = diagnose(load_records(tumble_dir), BASE, model_free=False)
    c = next(c for c in d.candidates if c.name == "D_SS")
    assert "D_II" in c.aliases
    entry = c.separated_by[0]
    assert entry.startswith("design --separate D_SS,D_II:")
    p = float(entry.split("power ")[1].split()[0])
    assert 0.5 <= p <= 1.0
    # the built-in plans are still named beside it
    assert any(not s.startswith("design --separate") for s in c.separated_by)
