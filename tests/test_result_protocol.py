"""The result protocol for plans, truths, studies, study results and designs: every file is strict JSON tagged
with one format and an integer version (those two keys first), ``save``/``load`` are a pair that gives back the
whole object, files written before the protocol (or, for truths, by other tools) still load, and a file of another
format or a later version is refused with an error naming the key."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from gyrojax.data import plans
from gyrojax.data.planfile import load_plan, plan_to_json, save_plan
from gyrojax.data.truth import Truth, load_truth, save_truth, truth_from_dict
from gyrojax.errors import FormatError, PlanError, TruthError
from gyrojax.montecarlo.results import RESULT_FILE, StudyResult, load_result, save_result
from gyrojax.montecarlo.study import Study, StudyError, load_study, save_study, study_from_dict
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics.model import Model
from gyrojax.planning.criteria import Criterion
from gyrojax.planning.designfile import load_design, save_design
from gyrojax.planning.fisher import Table
from gyrojax.planning.optimal import DesignResult


def _strict(path):
    """The file parsed by a JSON reader that refuses NaN/Infinity tokens, as other languages' readers do."""

    def refuse(token):
        raise ValueError(f"{path}: non-standard JSON token {token}")

    return json.loads(path.read_text(encoding="utf-8"), parse_constant=refuse)


def _tag(path):
    doc = _strict(path)
    return list(doc)[:2], doc["format"], doc["format_version"]


def assert_same(a, b, where="object"):
    """Equal field by field: dataclasses recursively, arrays exactly (NaN equal to NaN), the rest by ``==``."""
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            assert_same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, np.ndarray) or isinstance(b, np.ndarray) or hasattr(a, "__array__"):
        a, b = np.asarray(a), np.asarray(b)
        assert a.shape == b.shape and a.dtype.kind == b.dtype.kind, where
        np.testing.assert_array_equal(a, b, err_msg=where)
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


# ---- plans ----------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "plan",
    [
        plans.tumble(revolutions=0.05, dt_s=20.0),
        plans.servo("polar", hours=0.01),
        plans.multiposition(8, minutes=1.0),
        plans.tdf_tumble(),
        plans.accel_tumble(positions=4, dwell_s=10.0),
    ],
    ids=lambda p: p.name,
)
def test_plan_round_trip(plan, tmp_path):
    p = save_plan(plan, tmp_path / "plan.json")
    assert _tag(p) == (["format", "format_version"], "gyrojax-plan", 1)
    assert load_plan(p) == plan
    with pytest.raises(FormatError, match="exists"):
        save_plan(plan, p)
    assert load_plan(save_plan(plan, p, force=True)) == plan


def test_plan_files_before_the_protocol_read_as_version_1(tmp_path):
    plan = plans.eight_position(minutes=1.0)
    old = dataclasses.asdict(plan)
    old["format"] = "gyrojax-plan-1"  # how plan files were tagged before
    (tmp_path / "old.json").write_text(json.dumps(old, indent=1))
    assert load_plan(tmp_path / "old.json") == plan


@pytest.mark.parametrize(
    "edit,key", [({"format_version": 2}, "format_version"), ({"format": "gyrojax-truth"}, "'format'")]
)
def test_plan_of_another_format_or_a_later_version_is_refused(edit, key, tmp_path):
    doc = {**json.loads(plan_to_json(plans.fixed_position(hours=0.01))), **edit}
    (tmp_path / "p.json").write_text(json.dumps(doc))
    with pytest.raises(PlanError, match=key) as info:
        load_plan(tmp_path / "p.json")
    assert "p.json" in str(info.value) and "'gyrojax-plan-1'" in str(info.value)  # the legacy tag it also reads


# ---- truths ---------------------------------------------------------------------------------------------------------


def test_truth_round_trip(tmp_path):
    truth = truth_from_dict(
        {
            "coefficients": {"D_F": 0.42, "D_I": -0.61, "E_SF": 150.0},
            "setup": {"table_tilt": [3.0, -2.0], "table_azimuth": 5.0, "encoder_harmonic": [1, 0, 0, 2]},
            "noise": {"white": 0.0015, "gauss_markov": [0.004, 900.0]},
        }
    )
    p = save_truth(truth, tmp_path / "truth.json")
    assert _tag(p) == (["format", "format_version"], "gyrojax-truth", 1)
    assert load_truth(p) == truth
    assert load_truth(save_truth(Truth(), tmp_path / "empty.json")) == Truth()


def test_truth_files_without_a_tag_load(tmp_path):
    # the conventions §8 example, as another tool writes it: no format key
    doc = {
        "coefficients": {"D_F": 0.42, "D_I": 0.61, "D_IS": 0.052, "E_SF": 150.0, "M_O": 120.0, "D_T": 0.01},
        "setup": {"table_tilt": [0.0, 90.0], "table_azimuth": 0.0, "encoder_harmonic": [0, 0, 0, 0]},
        "noise": {"white": 0.0015, "gauss_markov": [0.004, 900.0], "random_walk": 0.0, "quantization": 0.0},
    }
    (tmp_path / "t.json").write_text(json.dumps(doc))
    t = load_truth(tmp_path / "t.json")
    assert t.coefficients == doc["coefficients"] and t.setup["table_tilt"] == (0.0, 90.0)
    assert load_truth(save_truth(t, tmp_path / "again.json")) == t


def test_truth_of_a_later_version_is_refused(tmp_path):
    (tmp_path / "t.json").write_text(json.dumps({"format": "gyrojax-truth", "format_version": 2, "coefficients": {}}))
    with pytest.raises(TruthError, match="format_version"):
        load_truth(tmp_path / "t.json")


# ---- studies and their results --------------------------------------------------------------------------------------

STUDY = {
    "plan": "multiposition",
    "plan_options": {"n": 8, "minutes": 1, "dt_s": 5},
    "terms": ["D_F", "D_I", "D_O"],
    "priors": {"D_F": {"normal": [0, 1]}, "D_I": {"uniform": [-1, 1]}, "D_O": 0.3},
    "setup": {"table_tilt": {"normal": [0, 20]}},
    "noise": {"white": 0.01, "gauss_markov": [0.1, 30.0]},
    "draws": 90,
    "seed": 5,
    "chunk": 16,
    "solver": "qr",
}


def test_study_round_trip(tmp_path):
    study = study_from_dict(STUDY)
    p = save_study(study, tmp_path / "study.json")
    assert _tag(p) == (["format", "format_version"], "gyrojax-mc-study", 1)
    assert load_study(p) == study
    assert study_from_dict(json.loads(study.to_json())) == study


@pytest.mark.parametrize("tag", [{}, {"format": "gyrojax-mc-study-1"}], ids=["untagged", "before-the-protocol"])
def test_study_files_without_the_new_tag_load(tag, tmp_path):
    (tmp_path / "s.json").write_text(json.dumps({**tag, **STUDY}))
    assert load_study(tmp_path / "s.json") == study_from_dict(STUDY)


def test_study_of_a_later_version_is_refused(tmp_path):
    (tmp_path / "s.json").write_text(json.dumps({"format": "gyrojax-mc-study", "format_version": 9, **STUDY}))
    with pytest.raises(StudyError, match="format_version"):
        load_study(tmp_path / "s.json")


def _result(study: Study, n: int = 7) -> StudyResult:
    """A result with arrays of every kind a run produces (no run needed: the files are what is tested)."""
    rng = np.random.default_rng(3)
    fit = ("D_F", "D_I", "D_O")
    truth = fit + ("table_tilt_x", "table_tilt_y")
    std = rng.uniform(0.1, 1.0, (n, 3))
    std[2, 1] = np.nan  # a draw whose σ̂ is not finite must survive the files
    return StudyResult(
        study,
        truth,
        fit,
        np.arange(100, 100 + n),
        rng.normal(size=(n, len(truth))),
        rng.normal(size=(n, 3)),
        std,
        rng.uniform(size=n),
        compile_s=1.25,
        run_s=0.5,
    )


def test_study_result_round_trip(tmp_path):
    res = _result(replace_draws(study_from_dict(STUDY), 1000))  # the study asked for more draws than were run
    files = save_result(res, tmp_path / "res")
    assert _tag(tmp_path / "res" / RESULT_FILE) == (["format", "format_version"], "gyrojax-mc-result", 1)
    assert _tag(tmp_path / "res" / "study.json")[1:] == ("gyrojax-mc-study", 1)
    assert load_study(files["study"]).draws == 7  # study.json re-runs the result as written
    assert_same(load_result(tmp_path / "res"), res, "result")
    with pytest.raises(StudyError, match="exists"):
        save_result(res, tmp_path / "res")


def replace_draws(study: Study, draws: int) -> Study:
    return dataclasses.replace(study, draws=draws)


def test_result_directories_before_the_protocol_load(tmp_path):
    res = _result(study_from_dict(STUDY))
    save_result(res, tmp_path / "res")
    (tmp_path / "res" / RESULT_FILE).unlink()  # a directory as gyrojax mc wrote it before result.json
    old = load_result(tmp_path / "res")
    assert_same(old, dataclasses.replace(res, study=replace_draws(res.study, 7), compile_s=0.0, run_s=0.0), "result")


def test_result_of_a_later_version_is_refused(tmp_path):
    save_result(_result(study_from_dict(STUDY)), tmp_path / "res")
    p = tmp_path / "res" / RESULT_FILE
    p.write_text(json.dumps({**json.loads(p.read_text()), "format_version": 2}))
    with pytest.raises(StudyError, match="format_version"):
        load_result(tmp_path / "res")


# ---- designs --------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("table", ["two-axis", "fixture"])
@pytest.mark.parametrize("criterion", ["D", "A:D_F=2,D_I=1", "detect:D_OO=0.03"])
def test_design_round_trip(table, criterion, tmp_path):
    model = Model.of(["D_F", "D_I", "D_O", "D_S", "D_II", "D_SS"])
    tab = Table.two_axis() if table == "two-axis" else Table.fixture()
    rng = np.random.default_rng(1)
    a = rng.normal(size=(6, 6))
    n = 5
    res = DesignResult(
        rng.uniform(0, 360, (n, len(tab.axis_names))),
        rng.uniform(100, 900, n),
        -12.5,
        Criterion.parse(criterion, model),
        model,
        tab,
        NoiseSpec(white=0.01, gauss_markov=((0.05, 300.0),)),
        2.0,
        np.array([3.0, 2.0, np.nan, 1.0]),
        1e-7,
        rng.normal(size=3),
        a @ a.T,
        {"compile_s": 2.0, "run_s": 0.25},
    )
    p = save_design(res, tmp_path / "design.json")
    assert _tag(p) == (["format", "format_version"], "gyrojax-design", 1)
    back = load_design(p)
    assert_same(back, res, "design")
    assert back.plan() == res.plan()


def test_design_of_another_format_is_refused(tmp_path):
    save_plan(plans.fixed_position(hours=0.01), tmp_path / "plan.json")
    with pytest.raises(FormatError, match="'format'"):
        load_design(tmp_path / "plan.json")
