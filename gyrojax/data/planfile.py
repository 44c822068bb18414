"""Plan files: a :class:`~gyrojax.data.plans.Plan` as JSON and back, in the result protocol of
:mod:`gyrojax.protocol` (format tag ``"gyrojax-plan"``, integer ``format_version``; files written before the
protocol, tagged ``"gyrojax-plan-1"``, are read as version 1). Units are those of the field names (deg, s, deg/s,
Hz); errors name the file and the key (``runs[0].segments[2].dt_s``).
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

from gyrojax import protocol
from gyrojax.data.plans import DEFAULT_LATITUDE, Plan, Run, Segment, validate_plan
from gyrojax.errors import PlanError
from gyrojax.protocol import is_finite_number, read_json_file

PLAN_FORMAT = "gyrojax-plan"
PLAN_VERSION = 1
PLAN_LEGACY = {"gyrojax-plan-1": (PLAN_FORMAT, 1)}
"""Format strings of plan files written before the result protocol, and the version they stand for."""


def plan_to_json(plan: Plan) -> str:
    """The plan file text: strict JSON, ``format``/``format_version`` first, then the plan's fields."""
    return protocol.dumps(asdict(plan), PLAN_FORMAT, PLAN_VERSION)


def save_plan(plan: Plan, path, force: bool = False) -> Path:
    """Write ``plan`` to ``path`` atomically (an existing file only with ``force``); :func:`load_plan` reads it back
    equal. Returns the path."""
    return protocol.save(path, asdict(plan), PLAN_FORMAT, PLAN_VERSION, force=force)


def _need(where, d, key, path):
    if not isinstance(d, dict):
        raise PlanError(f"{where}: key {path.rstrip('.')!r} must be an object")
    if key not in d:
        raise PlanError(f"{where}: missing required key {path + key!r}")
    return d[key]


def _list(where, v, path):
    if not isinstance(v, list):
        raise PlanError(f"{where}: key {path!r} must be a list, got {type(v).__name__}")
    return v


def _number(where, v, path, default=None):
    if v is None and default is not None:
        return default
    if not is_finite_number(v):
        raise PlanError(f"{where}: key {path!r} must be a finite number, got {v!r}")
    return float(v)


def _numbers(where, v, path):
    if v is None:
        return None
    if not isinstance(v, list) or not all(is_finite_number(x) for x in v):
        raise PlanError(f"{where}: key {path!r} must be a list of finite numbers (one per table axis), got {v!r}")
    return tuple(float(x) for x in v)


def plan_from_dict(d: dict, where: str = "plan") -> Plan:
    """A plan from its JSON dict, validated (errors name the key, e.g. ``runs[0].segments[2].dt_s``)."""
    if not isinstance(d, dict):
        raise PlanError(f"{where}: the top level must be an object")
    protocol.check_as(d, PLAN_FORMAT, PLAN_VERSION, where, PlanError, PLAN_LEGACY)
    runs = []
    for i, r in enumerate(_list(where, _need(where, d, "runs", ""), "runs")):
        at = f"runs[{i}]."
        axes = []
        for a, ax in enumerate(_list(where, _need(where, r, "axes", at), at + "axes")):
            if not (isinstance(ax, list) and len(ax) == 2 and isinstance(ax[0], str) and isinstance(ax[1], list)):
                raise PlanError(f"{where}: key '{at}axes[{a}]' must be [name, [e, n, u]], got {ax!r}")
            axes.append((ax[0], _numbers(where, ax[1], f"{at}axes[{a}][1]")))
        segs = []
        for j, s in enumerate(_list(where, _need(where, r, "segments", at), at + "segments")):
            sat = f"{at}segments[{j}]."
            label = s.get("label") if isinstance(s, dict) else None
            if label is not None and (not is_finite_number(label) or label != int(label)):
                raise PlanError(f"{where}: key '{sat}label' must be an integer or null, got {label!r}")
            segs.append(
                Segment(
                    _numbers(where, _need(where, s, "start_deg", sat), sat + "start_deg"),
                    _number(where, _need(where, s, "duration_s", sat), sat + "duration_s"),
                    _number(where, s.get("dt_s"), sat + "dt_s", 1.0),
                    _numbers(where, s.get("rate_dps"), sat + "rate_dps"),
                    _numbers(where, s.get("amplitude_deg"), sat + "amplitude_deg"),
                    _number(where, s.get("frequency_hz"), sat + "frequency_hz", 0.0),
                    None if label is None else int(label),
                )
            )
        inst = _need(where, r, "instrument", at)
        if not isinstance(inst, dict):
            raise PlanError(f"{where}: key '{at}instrument' must be an object (conventions §5), got {inst!r}")
        name = _need(where, r, "name", at)
        if not isinstance(name, str) or not name:
            raise PlanError(f"{where}: key '{at}name' must be a non-empty string, got {name!r}")
        temp = r.get("temperature_C")
        numbers = isinstance(temp, list) and all(is_finite_number(x) for x in temp)
        if temp is not None and not (is_finite_number(temp) or numbers):
            raise PlanError(f"{where}: key '{at}temperature_C' must be null, a number or a list of numbers")
        runs.append(
            Run(
                name,
                tuple(axes),
                dict(inst),
                tuple(segs),
                r.get("mode", "rebalance"),
                r.get("servo_axis"),
                _number(where, r.get("scale_factor"), at + "scale_factor", 17.171),
                _number(where, r.get("gap_s"), at + "gap_s", 30.0),
                tuple(temp) if isinstance(temp, list) else temp,
            )
        )
    name = _need(where, d, "name", "")
    if not isinstance(name, str):
        raise PlanError(f"{where}: key 'name' must be a string, got {name!r}")
    lat = d.get("latitude_deg", DEFAULT_LATITUDE)
    if not is_finite_number(lat):
        raise PlanError(f"{where}: key 'latitude_deg' must be a finite number in [-90, 90], got {lat!r}")
    plan = Plan(
        name,
        tuple(runs),
        float(lat),
        d.get("gravity_mps2"),
        str(d.get("description", "")),
        str(d.get("reference", "")),
        _number(where, d.get("gap_between_runs_s"), "gap_between_runs_s", 60.0),
    )
    return validate_plan(plan, where)


def load_plan(path) -> Plan:
    """Load and validate a plan from a JSON file (errors name the file and the key)."""
    return plan_from_dict(read_json_file(path, PlanError, "a plan"), str(path))
