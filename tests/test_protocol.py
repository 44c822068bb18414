"""The one result protocol (gyrojax.protocol): strict JSON, one format tag and integer version, save/load a pair."""

import json
import math

import numpy as np
import pytest

from gyrojax import protocol
from gyrojax.errors import FormatError


def _reject_constants(name):
    raise ValueError(f"non-standard JSON constant {name}")


def test_strict_json_has_no_nan_tokens_and_round_trips_numbers(tmp_path):
    payload = {"x": np.float64("nan"), "y": [1.5, np.inf, -np.inf], "n": np.int64(3), "a": np.eye(2), "ok": True}
    p = protocol.save(tmp_path / "obj.json", payload, "gyrojax-thing", 2)
    text = p.read_text()
    doc = json.loads(text, parse_constant=_reject_constants)  # a strict reader (no NaN/Infinity tokens) reads it
    assert list(doc)[:2] == ["format", "format_version"]
    assert doc == {
        "format": "gyrojax-thing",
        "format_version": 2,
        "x": None,
        "y": [1.5, None, None],
        "n": 3,
        "a": [[1.0, 0.0], [0.0, 1.0]],
        "ok": True,
    }
    back = protocol.load(p, "gyrojax-thing", 2)
    assert back == doc
    y = protocol.floats(back["y"])
    assert y[0] == 1.5 and math.isnan(y[1]) and math.isnan(y[2])


def test_existing_file_is_kept_unless_forced(tmp_path):
    p = tmp_path / "obj.json"
    protocol.save(p, {"v": 1}, "gyrojax-thing", 1)
    with pytest.raises(FormatError, match="exists"):
        protocol.save(p, {"v": 2}, "gyrojax-thing", 1)
    assert protocol.load(p, "gyrojax-thing", 1)["v"] == 1
    protocol.save(p, {"v": 2}, "gyrojax-thing", 1, force=True)
    assert protocol.load(p, "gyrojax-thing", 1)["v"] == 2


def test_a_payload_that_is_not_json_loses_nothing(tmp_path):
    p = tmp_path / "obj.json"
    protocol.save(p, {"v": 1}, "gyrojax-thing", 1)
    with pytest.raises(TypeError, match="not JSON data: object"):
        protocol.save(p, {"v": object()}, "gyrojax-thing", 1, force=True)
    assert protocol.load(p, "gyrojax-thing", 1)["v"] == 1
    assert [f.name for f in tmp_path.iterdir()] == ["obj.json"]  # no temporary file left behind


@pytest.mark.parametrize(
    "doc, message",
    [
        ([1, 2], "not a gyrojax-thing file"),
        ({"format_version": 1}, "key 'format' is missing"),
        ({"format": "gyrojax-other", "format_version": 1}, "key 'format' is 'gyrojax-other', not 'gyrojax-thing'"),
        ({"format": "gyrojax-thing"}, "key 'format_version' is missing"),
        ({"format": "gyrojax-thing", "format_version": 3}, "reads gyrojax-thing 1 to 2"),
        ({"format": "gyrojax-thing", "format_version": 0}, "key 'format_version' is 0"),
        ({"format": "gyrojax-thing", "format_version": True}, "key 'format_version' is True"),
        ({"format": "gyrojax-thing", "format_version": "1"}, "key 'format_version' is '1'"),
    ],
)
def test_wrong_tags_are_refused_naming_the_file_and_key(tmp_path, doc, message):
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(FormatError, match=message) as e:
        protocol.load(p, "gyrojax-thing", 2)
    assert str(p) in str(e.value)


def test_unreadable_files_are_refused(tmp_path):
    for name, content in [("empty.json", ""), ("garbage.json", "{not json"), ("latin1.json", b"\xff\xfe{")]:
        p = tmp_path / name
        p.write_bytes(content.encode() if isinstance(content, str) else content)
        with pytest.raises(FormatError, match=name):
            protocol.load(p, "gyrojax-thing", 1)
    with pytest.raises(FormatError, match="no such file"):
        protocol.load(tmp_path / "missing.json", "gyrojax-thing", 1)


def test_legacy_tags_that_carried_their_version():
    doc = {"format": "gyrojax-thing-1", "v": 1}
    out = protocol.check(doc, "gyrojax-thing", 2, "old.json", legacy={"gyrojax-thing-1": ("gyrojax-thing", 1)})
    assert (out["format"], out["format_version"], out["v"]) == ("gyrojax-thing", 1, 1)
    with pytest.raises(FormatError, match="old.json"):
        protocol.check(doc, "gyrojax-thing", 2, "old.json")


def test_tags_are_checked_when_writing():
    with pytest.raises(ValueError, match="start with 'gyrojax-'"):
        protocol.dumps({}, "thing", 1)
    with pytest.raises(ValueError, match="integers >= 1"):
        protocol.dumps({}, "gyrojax-thing", 0)
    with pytest.raises(TypeError, match="keys are strings"):
        protocol.dumps({"a": {1: 2}}, "gyrojax-thing", 1)
