"""``gyrojax design --separate A,B --from RECORDS``: the follow-up test on the records' table that separates two
effects the campaign cannot tell apart (:mod:`gyrojax.planning.separate`); its own function so that
``cmd_design`` only dispatches to it."""

from __future__ import annotations

import json
from pathlib import Path

from gyrojax.cli.args import UsageError


def parse_pair(text: str) -> tuple[str, str]:
    """``A,B`` -> (A, B); UsageError unless exactly two names."""
    names = [t.strip() for t in text.split(",") if t.strip()]
    if len(names) != 2:
        raise UsageError(f"--separate takes two effect names A,B, got {text!r}")
    return names[0], names[1]


def cmd_design_separate(args) -> int:
    """Design, print each predicted power (dimensionless) and the time it needs (h of dwell), write the plan file to
    ``--out``; exit code."""
    from gyrojax.cli.args import parse_terms
    from gyrojax.data.planfile import plan_to_json
    from gyrojax.data.records import load_records
    from gyrojax.physics import effects as fx
    from gyrojax.planning.separate import ALPHA, TARGET_POWER, separate
    from gyrojax.protocol import atomic_write_text

    if not args.separate:
        raise UsageError("--from gives the records of --separate A,B; pass --separate too")
    ignored = [
        option
        for option, given in (
            ("--criterion", args.criterion != "D"),
            ("--arw", args.arw != 0.01),
            ("--gm", args.gm is not None),
            ("--noise-model", args.noise_model is not None),
            ("--dt", args.dt != 1.0),
            ("--effect", bool(getattr(args, "effect", None))),
            ("--effects-file", bool(getattr(args, "effects_file", None))),
        )
        if given
    ]
    if ignored:
        raise UsageError(
            f"{', '.join(ignored)}: not used by --separate (criterion, noise and sampling come from the records)"
        )
    a, b = parse_pair(args.separate)
    if not args.from_records:
        raise UsageError("design --separate needs the campaign's records: --from RECORD...")
    out = Path(args.out)
    if out.exists() and not args.force:
        raise UsageError(f"{out}: exists; pass --force to overwrite")
    if not 0 < args.hours < float("inf"):
        raise UsageError(f"--hours must be finite and positive, got {args.hours}")
    if args.adam_steps is None:
        args.adam_steps = 600
    for option, value in (
        ("--positions", args.positions),
        ("--starts", args.starts),
        ("--adam-steps", args.adam_steps),
    ):
        if value < 1:
            raise UsageError(f"{option} must be >= 1, got {value}")
    records = load_records(args.from_records)
    terms = parse_terms(args.terms) if args.terms else None
    res, _fit = separate(
        records,
        a,
        b,
        terms,
        args.hours,
        n_positions=args.positions,
        starts=args.starts,
        steps=args.adam_steps,
        seed=args.seed,
    )
    plan = res.plan()
    atomic_write_text(out, plan_to_json(plan))
    summary = res.summary()
    if args.json:
        print(json.dumps({"plan": args.out, **summary}, indent=1, default=float))
        return 0
    s, t = res.setup, res.triad
    print(
        f"test separating {a} from {b}: {len(res.dwell_s)} positions of the table "
        f"({', '.join(s.table.axis_names)}), {args.hours:g} h of dwell, gyro mounted IA {_vec(t[0])} OA {_vec(t[1])} "
        f"(platform axes) -> {args.out}"
    )
    for name, other, power, lam, delta in (
        (a, b, res.power_a, res.lambda_a, s.delta_a),
        (b, a, res.power_b, res.lambda_b, s.delta_b),
    ):
        unit = fx.get(name).units[0]
        size = ", ".join(f"{v:.4g}" for v in delta)
        print(
            f"{name} with {other} in the model: power {power:.3f} at {ALPHA:g} "
            f"(noncentrality {lam:.3g}, at the current estimate's size {size} {unit})"
        )
    if res.hours_needed is None:
        print(f"power {TARGET_POWER:g} for both needs more than the searched {max(args.hours, 48.0):g} h of dwell")
    else:
        print(f"power {TARGET_POWER:g} for both needs {res.hours_needed:.3g} h of dwell (searched)")
        if res.hours_needed > args.hours:
            print(f"warning: the {args.hours:g} h plan written falls short of power {TARGET_POWER:g}; pass --hours")
    return 0


def _vec(v) -> str:
    return "(" + ", ".join(f"{x:.3f}" for x in v) + ")"
