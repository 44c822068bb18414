"""The ``gyrojax`` command line.

Exit codes: 0 success; 2 usage or input error (one line on stderr, no traceback); 1 internal error.
Every sub-command that writes files refuses to overwrite without ``--force`` and writes atomically.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .errors import GyrojaxError


class UsageError(GyrojaxError):
    """Bad command-line arguments."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse would print usage and exit 2; keep it to one line
        raise UsageError(f"{self.prog}: {message}")


def _parse_value(v: str):
    try:
        return json.loads(v)
    except json.JSONDecodeError:
        return v


def _options(pairs) -> dict:
    out = {}
    for p in pairs or []:
        if "=" not in p:
            raise UsageError(f"plan option {p!r} must look like NAME=VALUE")
        k, v = p.split("=", 1)
        out[k.replace("-", "_")] = _parse_value(v)
    return out


def _terms(s: str | None) -> list[str]:
    if s is None:
        return []
    return [t.strip() for t in s.split(",") if t.strip()]


# ---- sub-commands ----------------------------------------------------------------------------------------------


def cmd_plans(args) -> int:
    """``gyrojax plans``: print the built-in plans, one line each; exit code."""
    from .plans import BUILDERS

    for name, (_, doc) in BUILDERS.items():
        print(f"{name:18s} {doc}")
    return 0


def _plan_from_arg(arg: str, options: dict):
    from . import plans

    if arg in plans.BUILDERS:
        return plans.build(arg, **options)
    p = Path(arg)
    if p.suffix == ".json" or p.exists():
        if options:
            raise UsageError("--option applies to built-in plans only, not to a plan file")
        return plans.load_plan(p)
    raise UsageError(f"{arg!r} is neither a built-in plan ({', '.join(plans.BUILDERS)}) nor a plan file")


def cmd_simulate(args) -> int:
    """``gyrojax simulate``: build a plan, simulate it with a truth file, write the records; exit code."""
    from .records import record_paths, save_record
    from .simulate import simulate
    from .truth import Truth, load_truth

    plan = _plan_from_arg(args.plan, _options(args.option))
    truth = load_truth(args.truth) if args.truth else Truth()
    out = Path(args.out)
    recs = simulate(plan, truth, seed=args.seed, dynamics=args.dynamics)
    if not args.force:
        for r in recs:
            for p in record_paths(out / r.name):
                if p.exists():
                    raise UsageError(f"{p}: exists; pass --force to overwrite")
    paths = [str(save_record(r, out, force=True)) for r in recs]
    if args.json:
        print(json.dumps({"plan": plan.name, "records": paths, "seed": args.seed}))
    else:
        for p in paths:
            print(p)
    return 0


def cmd_fit(args) -> int:
    """``gyrojax fit``: fit named effects to records and print the coefficient table (report units); exit code."""
    from .identify import fit
    from .records import load_records
    from .report import fit_table

    recs = load_records(args.records)
    res = fit(recs, _terms(args.terms) or None)
    if args.json:
        print(json.dumps(res.to_json()))
    else:
        print(fit_table(res))
    if args.save:
        res.save(args.save, force=args.force)
    return 0


def cmd_diagnose(args) -> int:
    """``gyrojax diagnose``: fit, then test every missing effect and print the verdict; exit code."""
    from .diagnose import diagnose
    from .records import load_records
    from .report import diagnosis_text

    if not 0.0 < args.alpha < 1.0:
        raise UsageError(f"--alpha must lie in (0, 1), got {args.alpha}")
    recs = load_records(args.records)
    d = diagnose(recs, _terms(args.terms) or None, alpha=args.alpha)
    if args.json:
        print(json.dumps(d.to_json()))
    else:
        print(diagnosis_text(d))
    return 0


def cmd_demo(args) -> int:
    """``gyrojax demo``: run the hidden-effect walkthrough into ``--out``; exit code."""
    from .demo import run_demo

    path = run_demo(args.out, force=args.force, quick=args.quick)
    print(f"report: {path}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``gyrojax`` command, with every sub-command (also those registered)."""
    p = _Parser(prog="gyrojax", description="Identify gyroscope error coefficients from turntable tests.")
    p.add_argument("--version", action="store_true", help="print the version and exit")
    sub = p.add_subparsers(dest="command", parser_class=_Parser)

    s = sub.add_parser("plans", help="list the built-in test plans")
    s.set_defaults(func=cmd_plans)

    s = sub.add_parser("simulate", help="simulate a plan into records (CONVENTIONS §5)")
    s.add_argument("plan", help="built-in plan name (see `gyrojax plans`) or a plan JSON file")
    s.add_argument("--truth", help="truth JSON (CONVENTIONS §8); default: a perfect gyro")
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--option", "-o", action="append", metavar="NAME=VALUE", help="plan builder option")
    s.add_argument("--dynamics", choices=("quasi-static", "loop"), default="quasi-static",
                   help="quasi-static balance equation, or through the analog rebalance loop")
    s.add_argument("--force", action="store_true", help="overwrite existing records")
    s.add_argument("--json", action="store_true")
    s.set_defaults(func=cmd_simulate)

    s = sub.add_parser("fit", help="fit named effects to records (CONVENTIONS §7)")
    s.add_argument("records", nargs="+", help="record files (.csv or .json) or directories")
    s.add_argument("--terms", help="comma-separated effect names (CONVENTIONS §6)")
    s.add_argument("--json", action="store_true")
    s.add_argument("--save", help="write the result as JSON to this path")
    s.add_argument("--force", action="store_true")
    s.set_defaults(func=cmd_fit)

    s = sub.add_parser("diagnose", help="rank the effects the model is missing (CONVENTIONS §7)")
    s.add_argument("records", nargs="+")
    s.add_argument("--terms", help="comma-separated effect names of the current model")
    s.add_argument("--alpha", type=float, default=0.01, help="family-wise significance level (default 0.01)")
    s.add_argument("--json", action="store_true")
    s.set_defaults(func=cmd_diagnose)

    s = sub.add_parser("demo", help="the hidden-effect walkthrough: simulate, fit, diagnose, add, refit, report")
    s.add_argument("--out", default="demo-report")
    s.add_argument("--force", action="store_true")
    s.add_argument("--quick", action="store_true", help="shorter records (for tests)")
    s.set_defaults(func=cmd_demo)

    for extra in _EXTRA_COMMANDS:
        extra(sub)
    return p


_EXTRA_COMMANDS = []
"""Hooks for sub-commands defined in other modules: each takes the sub-parsers object and adds its parser."""


def register_command(adder):
    """Decorator: ``adder(subparsers)`` adds a sub-command to the ``gyrojax`` parser; returns ``adder``."""
    _EXTRA_COMMANDS.append(adder)
    return adder


def _load_extras():
    import importlib

    for mod in ("gyrojax.allan", "gyrojax.design", "gyrojax.montecarlo", "gyrojax.optical"):
        try:
            importlib.import_module(mod)
        except ModuleNotFoundError as e:
            if e.name != mod:
                raise


def main(argv=None) -> int:
    """Run the ``gyrojax`` command on ``argv`` (default ``sys.argv[1:]``); returns the exit code (0, 1 or 2)."""
    _load_extras()
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.version:
            from . import __version__

            print(__version__)
            return 0
        if not getattr(args, "command", None):
            parser.print_help()
            return 0
        return args.func(args)
    except GyrojaxError as e:
        print(f"gyrojax: error: {e}".replace("\n", " "), file=sys.stderr)
        return 2
    except BrokenPipeError:
        return 0
    except OSError as e:  # a file the user named cannot be written or read: an input error, not a crash
        where = f"{e.filename}: " if e.filename else ""
        print(f"gyrojax: error: {where}{e.strerror or e}".replace("\n", " "), file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("gyrojax: interrupted", file=sys.stderr)
        return 1
    except Exception as e:  # an internal error: say what it was, briefly; GYROJAX_DEBUG=1 for the traceback
        import os

        if os.environ.get("GYROJAX_DEBUG"):
            raise
        print(f"gyrojax: internal error: {type(e).__name__}: {e}".replace("\n", " "), file=sys.stderr)
        return 1
