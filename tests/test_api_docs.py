"""Docstring audit (issues #9, #15; the HTML reference is pdoc's, ``make docs``).

(a) every public function, class and public method of every gyrojax module has its own docstring;
(b) units: a public function or class that handles a physical quantity says its units.

The units check (c) is a heuristic, stated here so that it can be argued with:

- An object *handles a physical quantity* when one of its parameters is named after one (a ``_``-separated part of
  the name is in ``QUANTITY_WORDS``: rate, angle, dt, tau, freq, temperature, lat, …) without a unit suffix
  (``dt_s``, ``latitude_deg``, ``cal_temps_c`` carry their unit in the name), or when its docstring speaks of one
  (``QUANTITY_DOC``: rate, drift, angle, time, frequency, current, temperature, acceleration, latitude, …).
- Such an object passes when its docstring names a unit (``UNIT``: deg/h, deg/s, rad, s, h, Hz, mA, g, N·m, deg, ppm,
  arcsec, °C, m/s², or says "dimensionless", "unitless", "units of", "same units", "unit vector", or "report units",
  which conventions §1 defines: deg/h, deg/h/g, ppm, arcsec).
- Exception classes carry no quantity; ``ALLOWED`` lists the few remaining exceptions, one reason each.
- ``PENDING`` lists failures in modules another worker is editing; the lead empties it after merging. An entry that
  no longer fails is reported, so the list cannot go stale.

It is a heuristic: a word can trigger it needlessly (then say "dimensionless" or give the unit anyway, which costs
a few characters) and a docstring can name a unit without naming the right one; review still matters.
"""

from __future__ import annotations

import importlib
import inspect
import re

import pytest

from . import docaudit as apidoc

UNIT = re.compile(
    r"deg/|rad/|m/s|\bmA\b|\bHz\b|ppm|arcsec|°C|N·m|\bdeg\b|\brad\b|\bg0\b|dimensionless|unitless|units? of|"
    r"same units|in units|report units|unit vector|\b(?:seconds?|hours?|minutes?|degrees?|radians?)\b|"
    r"(?:(?<=[\s(\[/·0-9])|^)(?:s|h|g|m|min|K)(?=[\s)\],;.:/²³⁻^]|$)"
)
QUANTITY_WORDS = {
    "rate",
    "rates",
    "omega",
    "drift",
    "angle",
    "angles",
    "dt",
    "tau",
    "taus",
    "time",
    "times",
    "t",
    "freq",
    "freqs",
    "frequency",
    "current",
    "temperature",
    "temp",
    "temps",
    "accel",
    "lat",
    "latitude",
    "gravity",
    "period",
    "duration",
    "dwell",
    "arw",
    "velocity",
    "avar",
    "adev",
    "bandwidth",
    "psd",
}
UNIT_SUFFIXES = {
    "s",
    "h",
    "deg",
    "rad",
    "dps",
    "mA",
    "hz",
    "c",
    "C",
    "g",
    "mps2",
    "ppm",
    "arcsec",
    "min",
    "minutes",
    "seconds",
    "hours",
    "dph",
}
QUANTITY_DOC = re.compile(
    r"\b(?:rates?|drift|angles?|times?|frequenc(?:y|ies)|current|temperatures?|accelerations?|latitude|gravity|"
    r"duration|dwell|velocity|period|bandwidth)\b",
    re.IGNORECASE,
)

# name -> why it needs no unit although the heuristic thinks it does. Keep this short and honest.
ALLOWED: dict[str, str] = {}

# name -> what is missing, in modules another worker is editing (identify, whiten, diagnose, model, loops).
# The lead empties this after merging that work.
PENDING: dict[str, str] = {}


def _public_objects():
    """(dotted name, object, is_method) of every audited object."""
    out = []
    for mod_name in apidoc.module_names():
        module = importlib.import_module(mod_name)
        for name, obj in apidoc.public_members(module):
            if apidoc.kind(obj) == "constant":
                continue
            out.append((f"{mod_name}.{name}", obj, False))
            if inspect.isclass(obj):
                out += [(f"{mod_name}.{name}.{m}", a, True) for m, a in apidoc.public_methods(obj)]
    return out


OBJECTS = _public_objects()


def _parameters(obj) -> list[str]:
    try:
        return list(inspect.signature(obj).parameters)
    except (TypeError, ValueError):
        return []


def _quantity_parameter(name: str) -> bool:
    parts = name.split("_")
    return any(p in QUANTITY_WORDS for p in parts) and parts[-1] not in UNIT_SUFFIXES


def units_problem(obj) -> str | None:
    """What the units heuristic finds wrong with ``obj``'s docstring, or None."""
    if inspect.isclass(obj) and issubclass(obj, BaseException):
        return None
    doc = apidoc.own_doc(obj)
    if UNIT.search(doc):
        return None
    params = [p for p in _parameters(obj) if _quantity_parameter(p)]
    words = sorted({w.lower() for w in QUANTITY_DOC.findall(doc)})
    if not params and not words:
        return None
    return f"no unit named, but parameters {params} / docstring words {words} carry quantities"


def docstring_problems() -> dict[str, str]:
    return {name: "no docstring" for name, obj, _ in OBJECTS if not apidoc.own_doc(obj)}


def unit_problems() -> dict[str, str]:
    out = {}
    for name, obj, is_method in OBJECTS:
        if is_method or name in ALLOWED:
            continue
        problem = units_problem(obj)
        if problem:
            out[name] = problem
    return out


def _report(problems: dict[str, str]) -> str:
    return "\n".join(f"  {k}: {v}" for k, v in sorted(problems.items()))


def test_audit_sees_the_package():
    names = {n for n, _, _ in OBJECTS}
    # a few anchors: functions, classes, methods and a jitted function must all be found
    for expected in (
        "gyrojax.units.white_sigma_deg_per_h",
        "gyrojax.data.record.Record",
        "gyrojax.data.record.Record.n",
        "gyrojax.physics.model.predict_jit",
        "gyrojax.dynamics.discretize.zoh",
    ):
        assert expected in names
    # the package's re-exports (gyrojax.Record, gyrojax.simulate, ...) are left to the defining modules
    assert not [n for n in names if n.count(".") == 1]


def test_every_public_object_has_a_docstring():
    problems = {k: v for k, v in docstring_problems().items() if k not in PENDING}
    assert not problems, "public objects without a docstring:\n" + _report(problems)


def test_units_are_stated():
    problems = {k: v for k, v in unit_problems().items() if k not in PENDING}
    assert not problems, "docstrings that handle physical quantities without naming a unit:\n" + _report(problems)


def test_allow_and_pending_lists_are_current():
    failing = set(docstring_problems()) | set(unit_problems())
    stale = sorted(set(PENDING) - failing)
    assert not stale, f"PENDING entries that pass now (remove them): {stale}"
    unknown = sorted(set(ALLOWED) - {n for n, _, _ in OBJECTS})
    assert not unknown, f"ALLOWED entries that name no public object: {unknown}"


@pytest.mark.parametrize(
    "doc, ok",
    [
        ("Rate of the table, deg/h.", True),
        ("Sample interval (s).", True),
        ("Duration in s, ", True),
        ("Angle of the table.", False),  # a quantity without a unit
        ("Hu's tumble angle.", False),  # the s of Hu's is not seconds
        ("Scale-factor error, dimensionless.", True),
        ("Holm adjusted p-values.", True),  # no quantity at all
    ],
)
def test_units_heuristic_on_examples(doc, ok):
    def f(x):
        pass

    f.__doc__ = doc
    assert (units_problem(f) is None) == ok


def test_units_heuristic_reads_parameter_names():
    def f(rate, dt_s):
        """Something."""

    def g(rate_dps, dt_s):
        """Something."""

    assert units_problem(f) is not None  # ``rate`` has no unit in its name or the docstring
    assert units_problem(g) is None
