"""The campaign loop (:mod:`gyrojax.adaptive`) on every turntable instrument and table it designs for, end to end
through the command line (``gyrojax campaign --simulate``, then ``gyrojax next`` on the records it wrote).

Each laboratory holds one effect its first test cannot see, and the loop must find it, bring every σ to target and
state values the truth file (written here, not by the loop) lies within:

* ``tdf``: a TDF gyro first tested in Hu's eight positions (Hu 3-1 to 3-11). In every one of them gravity lies
  along one case axis, so each product a_X·a_Y, a_X·a_Z, a_Y·a_Z is 0 and DX_XZ is invisible; the tests are designed
  on the two-axis table.
* ``accel``: a pendulous accelerometer first tested on the dividing head with its output axis along the head axis
  (Hu 3-41, 3-43): a_O = 0, so K_IO (Hu's k_5) is invisible; the tests are designed on the dividing head with the case
  turned on its faces.
* ``servo``: an SDF gyro whose first test is a polar servo run (Hu 3-86): IA along the servo axis keeps
  a_I = g·sin φ, so D_F and D_I read as one; the static tests, on the two-axis table, are fitted jointly with the
  servo record.
* ``one-axis``: the SDF gyro of ``test_adaptive`` (a polar tumble, OA along the axis: a_O constant, D_O invisible),
  its tests designed on the tumble's own one-axis table with the case turned (two mountings a test) instead of the
  two-axis table.

Where the physics of the table forbids the goal, the loop must refuse and name the table that would reach it: a
vertical axis (the eight-position fixture) never tilts gravity off the case axes; a servo axis along the IA never
changes a_I unless the case is turned.
"""

from __future__ import annotations

import contextlib
import io
import json
import math

import pytest

from gyrojax.adaptive.classical import joined, sequence
from gyrojax.adaptive.goal import Goal
from gyrojax.adaptive.lab import Lab
from gyrojax.adaptive.step import next_test
from gyrojax.cli.app import main
from gyrojax.data import plans
from gyrojax.data.planfile import load_plan
from gyrojax.data.records import load_records
from gyrojax.simulation.simulator import simulate

SDF = {"coefficients": {"D_F": 0.4, "D_I": 0.6, "D_S": -0.3, "D_O": 0.2}, "noise": {"white": 0.005}}
TWO_AXIS = ["--table", "two-axis", "--no-turn", "--mountings", "1"]
KINDS = {
    "tdf": {
        "kind": "tdf-gyro",
        "truth": {
            "coefficients": {
                "DX_F": 0.5, "DY_F": -0.3, "DX_X": 0.4, "DX_Y": 0.1, "DY_X": -0.2, "DY_Y": 0.3, "DX_XZ": 0.15,
            },
            "noise": {"white": 0.005},
        },
        "first": ["eight-position", "-o", "kind=tdf-gyro", "-o", "dt_s=30"],
        "terms": "DX_F,DY_F,DX_X,DX_Y,DY_X,DY_Y",
        "target": 0.01,
        "seed": 2,
        "lab": TWO_AXIS,
        "classical": ["eight-position", "tumble"],
    },
    "accel": {
        "kind": "pendulous-accel",
        # noise in the accelerometer's output unit, g·√h (conventions §9.6): 60·N/√10 ≈ 6 μg a sample
        "truth": {"coefficients": {"K_0": 1e-3, "K_1": 1.0002, "K_2": 5e-5, "K_IO": 4e-5}, "noise": {"white": 3e-7}},
        "first": ["accel-tumble", "-o", "dt_s=10"],
        "terms": "K_0,K_1,K_2",
        "target": 2e-6,
        "seed": 1,
        "lab": ["--mountings", "1"],
        "classical": ["dividing-head tumble, OA along the head", "dividing-head tumble, PA along the head"],
    },
    "servo": {
        "kind": "sdf-gyro",
        "truth": SDF,
        "first": ["servo", "-o", "hours=2", "-o", "dt_s=30"],
        "terms": "D_F,D_I,D_S",
        "target": 0.02,
        "seed": 3,
        "lab": TWO_AXIS,
        "classical": ["multi-position", "tumble", "servo"],
    },
    "one-axis": {
        "kind": "sdf-gyro",
        "truth": SDF,
        "first": ["tumble", "-o", "revolutions=2", "-o", "earth_rates=20", "-o", "dt_s=60", "-o", "flip=false"]
        + ["-o", "both_directions=false"],
        "terms": "D_F,D_I,D_S",
        "target": 0.02,
        "seed": 4,
        "lab": ["--mountings", "2"],
        "classical": ["multi-position", "tumble", "servo"],
    },
}  # fmt: skip
SEARCH = ["--positions", "8", "--starts", "1", "--steps", "120"]


def _run(argv) -> dict:
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(argv) == 0
    return json.loads(buf.getvalue())


@pytest.fixture(scope="module", params=sorted(KINDS))
def campaign(request, tmp_path_factory):
    """One campaign of the kind on the command line: (case, JSON, directory it wrote)."""
    case = KINDS[request.param]
    d = tmp_path_factory.mktemp(request.param)
    (d / "truth.json").write_text(json.dumps(case["truth"]), encoding="utf-8")
    argv = ["campaign", "--simulate", str(d / "truth.json"), "--first", *case["first"], "--terms", case["terms"]]
    argv += ["--target-sigma", str(case["target"]), "--seed", str(case["seed"]), "--json", "--out", str(d / "run")]
    return case, _run(argv + case["lab"] + SEARCH), d / "run"


@pytest.mark.slow
def test_the_loop_finds_the_hidden_effect_and_states_honest_sigma(campaign):
    case, j, out = campaign
    truth = case["truth"]["coefficients"]
    assert j["goal_met"] and j["verdict"] == "adequate"
    assert set(j["terms"]) == set(truth)  # the hidden effect found, nothing false added
    assert len(j["steps"]) >= 2  # the first test alone cannot see the hidden effect
    for name, c in j["coefficients"].items():
        assert c["std"] <= case["target"] * (1 + 1e-9)
        assert abs(c["value"] - truth[name]) <= 3 * c["std"]
    if case["first"][0] == "servo":  # the servo record is fitted jointly with the static tests
        modes = {r.name: r.meta["mode"] for r in load_records(out / "records")}
        assert modes.pop("servo-polar") == "servo" and set(modes.values()) == {"rebalance"}
        # the servo run alone cannot tell D_F from D_I (a_I = g·sin φ throughout): no fit of it, only the joint one
        assert j["steps"][0]["coefficients"] == {} and {"D_F", "D_I"} <= set(j["steps"][1]["coefficients"])


@pytest.mark.slow
def test_the_classical_sequence_is_simulated_from_the_same_truth_to_the_same_sigma(campaign):
    """Hu's sequence of the kind, scaled until its own fit of records simulated from the truth meets every σ target
    of the loop's final model: its hours are that scaled sequence's duration, and it identifies every coefficient
    (the accelerometer's needs both dividing-head states: with the output axis along the head a_O = 0, and K_IO is
    seen only with the pendulous axis along it, Hu 3-42)."""
    case, j, _ = campaign
    cl = j["classical"]
    assert cl["hours"] > 0 and cl["scale"] > 0 and not cl["reason"]
    assert [p["test"] for p in cl["path"]] == case["classical"]
    duration = float(joined(sequence(case["kind"], cl["scale"])).duration_s) / 3600.0
    assert cl["hours"] == pytest.approx(duration, rel=1e-12)
    assert set(cl["sigma"]) == set(j["coefficients"])
    assert all(v <= case["target"] * (1 + 1e-9) for v in cl["sigma"].values())
    assert j["classical_table_hours"] == cl["hours"]
    assert j["hours_ratio"] == pytest.approx(j["table_hours"] / cl["hours"])


@pytest.mark.slow
def test_next_on_the_campaign_records_designs_a_test_then_stops(campaign, tmp_path):
    """``gyrojax next`` on the first test's records designs a test that runs in the simulator; on every record of
    the campaign, with its model and looks, the goal is met and nothing is written."""
    case, j, out = campaign
    first = load_plan(j["steps"][0]["plan"])
    records = load_records(out / "records")
    firsts = [str(out / "records" / f"{r.name}.json") for r in first.runs]
    argv = ["next", *firsts, "--terms", case["terms"], "--target-sigma", str(case["target"]), "--json"]
    nt = _run(argv + ["--out", str(tmp_path / "next.json")] + case["lab"] + SEARCH)
    assert nt["status"] == "test" and nt["plan_file"]
    start = max(float(r.time_s[-1]) for r in records[: len(firsts)])
    assert simulate(load_plan(tmp_path / "next.json"), case["truth"], seed=2, start_s=start + 30.0)
    argv = ["next", str(out / "records"), "--terms", ",".join(j["terms"]), "--target-sigma", str(case["target"])]
    argv += ["--looks", str(j["looks"]), "--json", "--out", str(tmp_path / "none.json")]
    assert _run(argv + case["lab"] + SEARCH)["goal_met"]
    assert not (tmp_path / "none.json").exists()


def test_the_eight_position_fixture_cannot_see_the_cross_terms_and_says_which_table_does():
    """The eight-position test's fixture turns about Up: every position keeps gravity along one case axis, so
    a_X·a_Y = a_X·a_Z = a_Y·a_Z = 0 whatever the angle or the case turn — refused, naming the two-axis table."""
    records = simulate(plans.eight_position(10.0, dt_s=30.0, kind="tdf-gyro"), KINDS["tdf"]["truth"], seed=1)
    lab = Lab.from_records(records, positions=8, mountings_per_test=1)
    nt = next_test(records, KINDS["tdf"]["terms"].split(","), Goal(sigma=0.01), lab, starts=1, steps=20)
    assert nt.status == "unreachable" and nt.plan is None
    for term in ("DX_XY", "DX_XZ", "DX_YZ", "DY_XY", "DY_XZ", "DY_YZ"):
        assert f"no orientation of this table separates {term}" in nt.reason
    assert "a two-axis table" in nt.reason


def test_a_servo_axis_along_the_ia_needs_the_case_turned():
    """On the polar servo table with one mounting a_I = g·sin φ at every angle: D_F and D_I stay one combination,
    D_I·sin φ·(g_local/g0) + D_F, and the refusal says turning the case on this table separates them."""
    records = simulate(plans.servo("polar", hours=2.0, dt_s=30.0), SDF, seed=1)
    lab = Lab.from_records(records, turn_case=False, positions=8, mountings_per_test=1)
    nt = next_test(records, ["D_F", "D_I", "D_S"], Goal(sigma=0.02), lab, starts=1, steps=20)
    assert nt.status == "unreachable"
    assert "the case turned on its faces on this table" in nt.reason
    text = nt.reason.split("separates D_F: ")[1].split(" is invisible")[0]
    parts = dict(reversed(t.strip().split("·")) for t in text.split(" + "))
    site = records[0].meta["site"]
    s = math.sin(math.radians(site["latitude_deg"])) * site["gravity_mps2"] / 9.80665
    assert abs(float(parts["D_F"]) / float(parts["D_I"])) == pytest.approx(s, abs=2e-3)
