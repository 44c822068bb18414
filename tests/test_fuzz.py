"""Property-based fuzzing: random byte mutations of valid record CSV/JSON, plan and truth files, random JSON leaves,
and random command lines. The property: loading either succeeds or raises a gyrojax error (never a bare
ValueError, KeyError, IndexError …); the command line returns 0 or 2 (never 1, an internal error) and never
raises; nothing hangs (every example runs under an alarm)."""

from __future__ import annotations

import contextlib
import copy
import io
import json
import os
import shutil
import signal
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyrojax.cli import app as cli
from gyrojax.data import plans
from gyrojax.data.planfile import load_plan, plan_to_json
from gyrojax.data.records import load_record, save_record
from gyrojax.data.truth import load_truth
from gyrojax.errors import GyrojaxError
from gyrojax.simulation.simulator import simulate

NAME = "fixed"
# GYROJAX_FUZZ_EXAMPLES=2000 for a long, randomised hunt; the default run is short and reproducible
EXAMPLES = int(os.environ.get("GYROJAX_FUZZ_EXAMPLES", "0")) or None
FUZZ = settings(
    max_examples=EXAMPLES or 120, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=not EXAMPLES
)


@contextlib.contextmanager
def alarm(seconds: int = 60):
    """Fail instead of hanging."""

    def boom(*_):
        raise TimeoutError(f"no answer within {seconds} s")

    old = signal.signal(signal.SIGALRM, boom)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


@pytest.fixture(scope="module")
def valid(tmp_path_factory) -> Path:
    rec = simulate(plans.fixed_position(hours=0.01), {"coefficients": {"D_F": 0.1}, "noise": {"white": 0.01}})[0]
    d = tmp_path_factory.mktemp("fuzz-valid")
    save_record(rec, d)
    (d / "plan.json").write_text(plan_to_json(plans.fixed_position(hours=0.01)))
    truth = {
        "coefficients": {"D_F": 0.42, "D_I": 0.61, "E_SF": 150.0},
        "setup": {"table_tilt": [0.0, 90.0]},
        "noise": {"white": 0.0015, "gauss_markov": [0.004, 900.0]},
    }
    (d / "truth.json").write_text(json.dumps(truth))
    return d


# ---- byte mutations ----------------------------------------------------------------------------------------------

_SPECIAL = [
    b",",
    b"\n",
    b'"',
    b"\r",
    b"\x00",
    b"\xff",
    b"\xef\xbb\xbf",
    b"nan",
    b"inf",
    b"-",
    b".",
    b"e",
    b"{",
    b"}",
    b"[",
    b"]",
    b":",
    b" ",
    b"1e308",
    b"9" * 400,
    b"\\u0000",
    b"\xc3\xa9",
]


@st.composite
def mutations(draw, data: bytes) -> bytes:
    """Apply 1–4 random edits: flip, insert, delete, truncate, duplicate or swap lines, insert a special token."""
    out = bytearray(data)
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["flip", "insert", "delete", "truncate", "dupline", "swaplines", "special"]))
        n = len(out)
        i = draw(st.integers(0, max(n - 1, 0)))
        if op == "flip" and n:
            out[i] = draw(st.integers(0, 255))
        elif op == "insert":
            out[i:i] = draw(st.binary(min_size=1, max_size=8))
        elif op == "delete" and n:
            del out[i : i + draw(st.integers(1, 40))]
        elif op == "truncate":
            del out[i:]
        elif op in ("dupline", "swaplines"):
            lines = bytes(out).split(b"\n")
            a = draw(st.integers(0, len(lines) - 1))
            b = draw(st.integers(0, len(lines) - 1))
            if op == "dupline":
                lines.insert(b, lines[a])
            else:
                lines[a], lines[b] = lines[b], lines[a]
            out = bytearray(b"\n".join(lines))
        elif op == "special":
            out[i:i] = draw(st.sampled_from(_SPECIAL))
    return bytes(out)


def _fresh(valid: Path, tmp: Path) -> tuple[Path, Path]:
    for ext in (".csv", ".json"):
        shutil.copy(valid / f"{NAME}{ext}", tmp / f"{NAME}{ext}")
    return tmp / f"{NAME}.csv", tmp / f"{NAME}.json"


def _load_ok_or_gyrojax_error(fn, *args):
    with alarm(30):
        try:
            fn(*args)
        except GyrojaxError as e:
            assert str(e) and "\n" not in str(e).strip(), repr(e)


@pytest.mark.parametrize("which", ["csv", "json"])
def test_mutated_record_bytes(valid, which):
    original = (valid / f"{NAME}.{which}").read_bytes()

    @FUZZ
    @given(mutations(original))
    def check(data):
        with tempfile.TemporaryDirectory() as tmp:
            c, j = _fresh(valid, Path(tmp))
            (c if which == "csv" else j).write_bytes(data)
            _load_ok_or_gyrojax_error(load_record, j)

    check()


@pytest.mark.parametrize("which", ["plan", "truth"])
def test_mutated_plan_and_truth_bytes(valid, which):
    original = (valid / f"{which}.json").read_bytes()
    loader = load_plan if which == "plan" else load_truth

    @FUZZ
    @given(mutations(original))
    def check(data):
        with tempfile.TemporaryDirectory() as tmp:
            p = Path(tmp) / f"{which}.json"
            p.write_bytes(data)
            _load_ok_or_gyrojax_error(loader, p)

    check()


# ---- structured JSON mutations: any leaf becomes any JSON value --------------------------------------------------

JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-(10**30), 10**30) | st.floats(allow_nan=False) | st.text(max_size=12),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=6), children, max_size=3),
    max_leaves=8,
)


def _paths(obj, prefix=()):
    yield prefix
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _paths(v, prefix + (i,))


@st.composite
def leaf_edits(draw, doc):
    doc = copy.deepcopy(doc)
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p in _paths(doc) if p]
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent = doc
        for k in path[:-1]:
            parent = parent[k]
        if draw(st.booleans()):
            parent[path[-1]] = draw(JSON_VALUES)
        else:
            del parent[path[-1]]
    return doc


@pytest.mark.parametrize("which", ["record", "plan", "truth"])
def test_random_json_leaves(valid, which):
    src = {"record": valid / f"{NAME}.json", "plan": valid / "plan.json", "truth": valid / "truth.json"}[which]
    doc = json.loads(src.read_text())

    @FUZZ
    @given(leaf_edits(doc))
    def check(edited):
        with tempfile.TemporaryDirectory() as tmp:
            c, j = _fresh(valid, Path(tmp))
            target = {"record": j, "plan": Path(tmp) / "plan.json", "truth": Path(tmp) / "truth.json"}[which]
            target.write_text(json.dumps(edited))
            fn = {"record": load_record, "plan": load_plan, "truth": load_truth}[which]
            _load_ok_or_gyrojax_error(fn, target)

    check()


# ---- random command lines -----------------------------------------------------------------------------------------

COMMANDS = ["fit", "diagnose", "simulate", "plans"]
FLAGS = [
    "--terms",
    "--json",
    "--save",
    "--force",
    "--alpha",
    "--out",
    "--seed",
    "--truth",
    "-o",
    "--option",
    "--version",
    "--",
    "-",
    "--bogus",
    # design, mc and noise
    "--criterion",
    "--gm",
    "--positions",
    "--hours",
    "--arw",
    "--dt",
    "--starts",
    "--adam-steps",
    "--lbfgs-steps",
    "--table",
    "--draws",
    "--plot",
    "--gauss-markov",
]
VALUES = [
    "D_F",
    "D_F,D_I",
    "D_F,,D_F",
    "E_SF",
    "nope",
    "bias_temperature",
    "0.01",
    "2",
    "-1",
    "nan",
    "abc",
    "",
    "hours=0.002",
    "hours=-1",
    "hours=abc",
    "dt_s=0",
    "dt_s=nan",
    "hours=1e30",
    "junk",
    "fixed",
    "tumble=1",
    "\x00",
    "é",
    "{}",
    "[]",
    "D",
    "A:D_F=x",
    "c:D_F=1",
    "detect:NO_SUCH",
    "detect:D_OO=big",
    "0.1",
    "0.1,abc",
    "0.05,300",
    "two-axis",
    "inf",
    "0",
]


class _Reached(BaseException):
    """Raised in place of the long computation of ``design`` / ``mc``: the arguments passed validation."""


def _files(valid: Path, tmp: Path) -> list[str]:
    (tmp / "empty.json").write_bytes(b"")
    (tmp / "garbage.csv").write_bytes(b"\xff\xfe\x00garbage,,\n\n,")
    (tmp / "garbage.json").write_bytes(b'{"format": 3')
    return [
        str(valid / f"{NAME}.json"),
        str(valid / f"{NAME}.csv"),
        str(valid),
        str(tmp / "empty.json"),
        str(tmp / "garbage.csv"),
        str(tmp / "garbage.json"),
        str(tmp / "absent.json"),
        str(valid / "truth.json"),
        str(valid / "plan.json"),
        str(tmp / "out"),
    ]


def test_random_command_lines(valid, monkeypatch):
    """Random command lines exit 0 or 2 with one line; for ``design`` and ``mc`` the property is that bad input is
    refused before the computation starts (the computation itself is replaced by a marker)."""
    from gyrojax.montecarlo import runner
    from gyrojax.planning import optimal

    def reached(*a, **k):
        raise _Reached

    monkeypatch.setattr(optimal, "design", reached)
    monkeypatch.setattr(runner, "run_study", reached)
    with tempfile.TemporaryDirectory() as tmp:
        files = _files(valid, Path(tmp))
        # every sub-command (``noise``, ``design``, ``mc`` …), except the long ``demo``
        sub = next(a for a in cli.build_parser()._actions if a.dest == "command")
        commands = COMMANDS + [c for c in sub.choices if c not in COMMANDS and c != "demo"]
        token = st.sampled_from(FLAGS) | st.sampled_from(VALUES) | st.sampled_from(files)
        argv_st = st.tuples(st.sampled_from(commands), st.lists(token, max_size=6)).map(lambda t: [t[0], *t[1]])

        @settings(
            max_examples=EXAMPLES or 60,
            deadline=None,
            suppress_health_check=[HealthCheck.too_slow],
            derandomize=not EXAMPLES,
        )
        @given(argv_st)
        def check(argv):
            out, err = io.StringIO(), io.StringIO()
            with alarm(90), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                try:
                    rc = cli.main(argv)
                except SystemExit as e:  # only --help may leave through argparse
                    assert e.code in (0, None), (argv, err.getvalue())
                    return
                except _Reached:
                    return
            assert rc in (0, 2), (argv, rc, err.getvalue())
            if rc == 2:
                msg = err.getvalue()
                assert msg.startswith("gyrojax: error: ") and msg.count("\n") == 1, (argv, msg)

        check()
