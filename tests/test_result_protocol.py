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
    assert "p.json" in str(info.value)


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
    # the CONVENTIONS §8 example, as another tool writes it: no format key
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
