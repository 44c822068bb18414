"""``gyrojax next`` (one step of the campaign loop: the next test from the records so far) and ``gyrojax campaign``
(the loop end to end on a laboratory simulated from a truth file): :mod:`gyrojax.adaptive`."""

from __future__ import annotations

import json
import math
from pathlib import Path

from gyrojax.cli.args import UsageError, parse_options, parse_terms


def add_goal_arguments(s) -> None:
    """The goal's options (shared by ``next`` and ``campaign``)."""
    s.add_argument("--terms", help="the current model: comma-separated effect names (default: the fit's default)")
    s.add_argument("--target-sigma", type=float, help="one target σ for every coefficient, in its own report unit")
    s.add_argument("--target", metavar="COEF=S,...", help="target σ per coefficient (report units)")
    s.add_argument("--watch", help="the candidate effects to rule out (default: the instrument's drift model)")
    s.add_argument("--detect", type=float, help="the size of a watched candidate that matters (default 10 × target)")
    s.add_argument("--alpha", type=float, default=0.05, help="campaign-wide false-effect rate (default 0.05)")


def add_lab_arguments(s) -> None:
    """The lab's table options (shared by ``next`` and ``campaign``)."""
    s.add_argument("--table", default="records", choices=("records", "two-axis"), help="the table of the next tests")
    s.add_argument("--hours", type=float, default=8.0, help="table hours one test may take (default 8)")
    s.add_argument("--budget", type=float, default=100.0, help="table hours the campaign may take (default 100)")
    s.add_argument("--positions", type=int, default=12, help="positions per mounting of a designed test")
    s.add_argument("--settle", type=float, default=30.0, help="settle time at each position, s (default 30)")
    s.add_argument("--rate-limit", type=float, default=10.0, help="table rate between positions, deg/s")
    s.add_argument("--angle-limit", action="append", metavar="AXIS=LO:HI", help="angle limits of a table axis, deg")
    s.add_argument("--no-turn", action="store_true", help="keep the records' mounting (the case is not turned)")
    s.add_argument("--mountings", type=int, default=3, help="mountings per designed test, 1 to 3 (default 3)")
    s.add_argument("--remount", type=float, default=900.0, help="time to remount the instrument, s (default 900)")
    s.add_argument("--dt", type=float, help="sample interval of the designed tests, s (default: the records')")
    s.add_argument("--starts", type=int, default=3, help="random starts of the design search per mounting")
    s.add_argument("--steps", type=int, default=300, help="Adam iterations of the design search")


def add_hand_arguments(s) -> None:
    """The hand lab's options (``next`` on imu-triad records, ``campaign`` on an imu-triad truth: a person turning a
    box)."""
    g = s.add_argument_group("a hand-held triad (imu-triad records or truth): the hand sessions")
    g.add_argument("--poses", type=int, help="rests of the designed session (default 12)")
    g.add_argument("--minutes", type=float, help="the longest session a person runs, min (default 30)")
    g.add_argument("--placement-deg", type=float, help="σ of the hand's placement about each axis, deg (default 1)")
    g.add_argument("--acc-noise", type=float, help="accelerometer white noise, g per sample (default: the records')")
    g.add_argument("--turn-pairs", help="known-angle turn structures searched, e.g. 0,1,2 (default 0,1,2)")
    g.add_argument("--lbfgs-steps", type=int, help="L-BFGS refinement of the session search at most (default 400)")
    g.add_argument("--budget-minutes", type=float, help="minutes the campaign's sessions may take in all")


HAND_FLAGS = ("poses", "minutes", "placement_deg", "acc_noise", "turn_pairs", "lbfgs_steps", "budget_minutes")
"""The hand lab's options (``args`` names): refused on turntable records."""
HAND_FIELDS = {
    "poses": "poses",
    "minutes": "max_minutes",
    "placement_deg": "placement_deg",
    "acc_noise": "acc_noise_g",
    "turn_pairs": "turn_pairs",
    "budget_minutes": "budget_minutes",
}
"""The hand lab's options (``args`` names) by the :class:`~gyrojax.adaptive.hand.HandLab` field they set."""
TABLE_DEFAULTS = {
    "table": "records",
    "hours": 8.0,
    "budget": 100.0,
    "positions": 12,
    "settle": 30.0,
    "rate_limit": 10.0,
    "angle_limit": None,
    "no_turn": False,
    "mountings": 3,
    "remount": 900.0,
    "dt": None,
    "hours_spent": 0.0,
}
"""The table's options with their defaults: given otherwise with imu-triad records, they are refused."""


def hand_lab_from_args(args):
    """The :class:`~gyrojax.adaptive.hand.HandLab` of the options; a table option given is refused."""
    from gyrojax.adaptive.hand import HandLab
    from gyrojax.errors import ModelError

    for key, default in TABLE_DEFAULTS.items():
        if getattr(args, key, default) != default:
            raise UsageError(f"--{key.replace('_', '-')} is an option of a turntable test, not of a hand session")
    over = {}
    for key, name in HAND_FIELDS.items():
        if key != "turn_pairs" and getattr(args, key) is not None:
            over[name] = getattr(args, key)
    if args.turn_pairs is not None:
        try:
            over["turn_pairs"] = tuple(int(k) for k in parse_terms(args.turn_pairs))
        except ValueError:
            raise UsageError(f"--turn-pairs {args.turn_pairs!r}: expected integers, e.g. 0,1,2") from None
    if args.lbfgs_steps is not None and args.lbfgs_steps < 0:
        raise UsageError(f"--lbfgs-steps must be >= 0, got {args.lbfgs_steps}")
    try:
        return HandLab(**over)
    except ModelError as e:
        field = str(e).split("'")[1] if "'" in str(e) else ""
        flags = {name: f"--{key.replace('_', '-')}" for key, name in HAND_FIELDS.items()}
        raise UsageError(f"{flags.get(field, 'hand lab')}: {e}") from None


LAB_FLAGS = {
    "hours_per_test": "--hours",
    "budget_hours": "--budget",
    "positions": "--positions",
    "settle_s": "--settle",
    "rate_limit_dps": "--rate-limit",
    "angle_limits_deg": "--angle-limit",
    "mountings_per_test": "--mountings",
    "remount_s": "--remount",
    "dt_s": "--dt",
}
"""The option that sets each field of the lab (:class:`~gyrojax.adaptive.lab.Lab`), named in its errors."""


def goal_from_args(args):
    """The :class:`~gyrojax.adaptive.goal.Goal` of the command's options."""
    from gyrojax.adaptive.goal import Goal

    targets = {}
    for item in parse_terms(args.target):
        name, _, value = item.partition("=")
        try:
            targets[name.strip()] = float(value)
        except ValueError:
            raise UsageError(f"--target {item!r}: expected COEF=SIGMA with a number") from None
    if args.target_sigma is None and not targets:
        raise UsageError("give the goal: --target-sigma S (every coefficient) and/or --target COEF=S,...")
    if args.target_sigma is not None and not (math.isfinite(args.target_sigma) and args.target_sigma > 0):
        raise UsageError(f"--target-sigma must be a finite number > 0, got {args.target_sigma}")
    watch = tuple(parse_terms(args.watch)) if args.watch else None
    return Goal(sigma=args.target_sigma, targets=targets, watch=watch, detect=args.detect, alpha=args.alpha)


def lab_from_args(args, records):
    """The :class:`~gyrojax.adaptive.lab.Lab` of the records' table (or ``--table two-axis``) and the options."""
    from gyrojax.adaptive.lab import Lab
    from gyrojax.data import plans
    from gyrojax.errors import ModelError

    over = {
        "hours_per_test": args.hours,
        "budget_hours": args.budget,
        "positions": args.positions,
        "settle_s": args.settle,
        "rate_limit_dps": args.rate_limit,
        "turn_case": not args.no_turn,
        "mountings_per_test": args.mountings,
        "remount_s": args.remount,
    }
    if args.dt is not None:
        over["dt_s"] = args.dt
    if args.table == "two-axis":
        over["axes"] = plans.TWO_AXIS
    axes = over.get("axes") or tuple((a["name"], tuple(a["axis_enu"])) for a in records[0].meta["table"]["axes"])
    if args.angle_limit:
        names = [n for n, _ in axes]
        limits = [None] * len(names)
        for item in args.angle_limit:
            name, _, rng = item.partition("=")
            lo, _, hi = rng.partition(":")
            if name not in names:
                raise UsageError(f"--angle-limit {item!r}: no table axis {name!r}; axes: {', '.join(names)}")
            try:
                limits[names.index(name)] = (float(lo), float(hi))
            except ValueError:
                raise UsageError(f"--angle-limit {item!r}: expected AXIS=LOW:HIGH in deg") from None
        over["angle_limits_deg"] = tuple(limits)
    try:
        return Lab.from_records(records, **over)
    except ModelError as e:
        flag = next((f for key, f in LAB_FLAGS.items() if f"'{key}" in str(e)), None)
        if flag is None:
            raise
        raise UsageError(f"{flag}: {e}") from None


def _requirements_table(rows) -> list[str]:
    out = [f"{'requirement':10s} {'coefficient':12s} {'target':>10s} {'σ now':>10s} {'σ after':>10s}  unit"]
    for r in rows:
        now = "∞" if r["sigma_now"] is None else f"{r['sigma_now']:.4g}"
        after = r.get("sigma_after", "")
        after = "∞" if after is None else (f"{after:.4g}" if after != "" else "")
        out.append(f"{r['kind']:10s} {r['coefficient']:12s} {r['target']:10.4g} {now:>10s} {after:>10s}  {r['unit']}")
    return out


def cmd_next(args) -> int:
    """``gyrojax next``: diagnose the records, then stop (goal met), refuse (unreachable: exit 2) or design and write
    the next test's plan; exit code."""
    from gyrojax.adaptive.step import next_test
    from gyrojax.data.planfile import save_plan
    from gyrojax.data.records import load_records
    from gyrojax.errors import ModelError
    from gyrojax.protocol import strict

    goal = goal_from_args(args)
    out = Path(args.out)
    if out.exists() and not args.force:
        raise UsageError(f"{out}: exists; pass --force to overwrite")
    records = load_records(args.records)
    hand = bool(records) and records[0].kind == "imu-triad"
    if hand:
        lab, search = hand_lab_from_args(args), {"lbfgs_steps": args.lbfgs_steps}
    else:
        given = [f"--{k.replace('_', '-')}" for k in HAND_FLAGS if getattr(args, k) is not None]
        if given:
            raise UsageError(f"{given[0]} is an option of a hand session (imu-triad records), not of a turntable test")
        lab, search = lab_from_args(args, records), {}
    nt = next_test(
        records,
        parse_terms(args.terms) or None,
        goal,
        lab,
        looks=args.looks,
        hours_spent=args.hours_spent,
        name=out.stem,
        seed=args.seed,
        starts=args.starts,
        steps=args.steps,
        **search,
    )
    if nt.status == "unreachable":
        raise ModelError(f"next: the goal cannot be reached: {nt.reason}")
    j = nt.to_json()
    if nt.plan is not None:
        save_plan(nt.plan, out, force=args.force)
        j["plan_file"] = str(out)
    if nt.protocol is not None:
        from gyrojax.planning.triad_protocol import save_protocol

        save_protocol(out, nt.protocol, force=args.force)
        j["protocol_file"] = str(out)
    if args.json:
        print(json.dumps(strict(j), indent=1))
        return 0
    print(
        f"status: {nt.status}   model: {', '.join(nt.terms)}   looks: {nt.looks} (next at α = {nt.alpha_next:.2g}; "
        f"a lone missing candidate among its {nt.family} tests at α/{nt.family} = {nt.alpha_detect:.2g})"
    )
    for a in nt.added:
        print(f"  added {a['effect']} (look {a['look']}, Holm-adjusted p = {a['p_adjusted']:.2g} < {a['alpha']:.2g})")
    if nt.alias:
        print(f"  aliased in the records: {' / '.join(nt.alias)}")
    print("\n".join("  " + line for line in _requirements_table(j["requirements"])))
    for note in nt.notes:
        print(f"  note: {note}")
    print(nt.reason)
    if nt.plan is not None:
        print(f"plan written to {out} ({nt.hours:.3g} table hours)")
    if nt.protocol is not None:
        from gyrojax.report.protocol_text import table_text

        print(table_text(nt.protocol["table"]))
        print(f"protocol written to {out} ({nt.hours * 60.0:.3g} min by hand)")
    return 0


HAND_FIRST = {"ferraris": ("minutes",), "random": ("poses", "minutes", "seed")}
"""The built-in first sessions of a hand campaign and their ``--option`` names: imucal's Ferraris protocol
(:func:`~gyrojax.planning.triad_protocol.ferraris_steps`) and imu_tk's random poses
(:func:`~gyrojax.planning.triad_protocol.random_steps`)."""
FIRST_MINUTES = 10.0
"""A built-in first session's length, min (default)."""


def hand_first_from_arg(arg: str, options: dict) -> tuple:
    """The first session a hand campaign names: (start attitude, steps, protocol file content). A built-in session of
    :data:`HAND_FIRST` with its ``--option`` values, or a protocol file (``design --instrument imu-triad``, ``next``;
    options refused)."""
    import numpy as np

    from gyrojax.errors import FormatError, ModelError
    from gyrojax.planning import triad_protocol as tpr

    if arg in HAND_FIRST:
        bad = [k for k in options if k not in HAND_FIRST[arg]]
        if bad:
            raise UsageError(f"--option {bad[0]}: the {arg} session takes {', '.join(HAND_FIRST[arg])}")
        minutes = options.get("minutes", FIRST_MINUTES)
        try:
            if arg == "ferraris":
                start, steps = tpr.ferraris_steps(60.0 * float(minutes))
            else:
                start, steps = tpr.random_steps(
                    int(options.get("poses", 12)), 60.0 * float(minutes), int(options.get("seed", 0))
                )
        except (ModelError, TypeError, ValueError) as e:
            raise UsageError(f"--first {arg}: {e}") from None
        return start, steps, None
    if options:
        raise UsageError("--option applies to built-in sessions only, not to a protocol file")
    p = Path(arg)
    if not (p.suffix == ".json" or p.exists()):
        raise UsageError(f"{arg!r} is neither a built-in hand session ({', '.join(HAND_FIRST)}) nor a protocol file")
    try:
        doc = tpr.load_protocol(p)
    except FormatError as e:
        raise UsageError(f"--first {arg}: {e}") from None
    return np.asarray(doc["session"]["start_attitude"], dtype=float), list(doc["session"]["steps"]), doc


def _first_payload(name: str, start, steps, truth, terms) -> dict:
    """The protocol file of a built-in first session (the keys :func:`~gyrojax.planning.triad_protocol.load_protocol`
    reads; its ``noise`` the truth's, at which it is simulated)."""
    import numpy as np

    from gyrojax.planning import triad_protocol as tpr

    opts = truth.session_options()
    return {
        "instrument": "imu-triad",
        "name": name,
        "terms": list(terms),
        "total_s": tpr.session_seconds(steps),
        "noise": {
            "arw_deg_per_sqrt_h": truth.arw,
            "acc_noise_g": opts["acc_noise_g"],
            "rate_hz": opts["rate_hz"],
            "placement_deg": opts["placement_deg"],
            "earth_rate": opts["earth_rate"],
        },
        "session": {"start_attitude": np.asarray(start).tolist(), "steps": steps},
    }


def _table_campaign(args, truth, terms, goal, loop):
    """The turntable plug-in of ``campaign``: the first plan and the table lab of the options, the loop
    (:func:`~gyrojax.adaptive.simulated.run_campaign`) on them with ``loop`` (seed, max_tests, on_step, starts,
    steps); (result, writer of its plan files)."""
    from gyrojax.adaptive.simulated import run_campaign
    from gyrojax.cli.commands import plan_from_arg
    from gyrojax.data.planfile import save_plan
    from gyrojax.simulation.simulator import simulate

    given = [f"--{k.replace('_', '-')}" for k in HAND_FLAGS if getattr(args, k) is not None]
    if given:
        raise UsageError(f"{given[0]} is an option of a hand session (an imu-triad truth), not of a turntable test")
    first = plan_from_arg(args.first, parse_options(args.option))
    lab = lab_from_args(args, simulate(first, {"coefficients": {}}))
    res = run_campaign(truth, first, terms, goal, lab, **loop)

    def write(out):
        for step in res.steps:
            step.file = str(save_plan(step.plan, out / f"{step.plan.name}.plan.json", force=True))

    return res, write


def _hand_campaign(args, truth, terms, goal, loop):
    """The hand-held triad plug-in of ``campaign``: the first session and the hand lab of the options (table options
    refused), the loop (:func:`~gyrojax.adaptive.simulated.run_hand_campaign`) on them with ``loop``; (result,
    writer of its protocol files). The sessions' budget defaults to ``--max-tests`` sessions of the longest a person
    runs."""
    from dataclasses import replace

    from gyrojax.adaptive.simulated import run_hand_campaign
    from gyrojax.planning.triad_protocol import save_protocol

    lab = hand_lab_from_args(args)
    if lab.budget_minutes is None:
        lab = replace(lab, budget_minutes=lab.max_minutes * args.max_tests)
    start, steps, doc = hand_first_from_arg(args.first, parse_options(args.option))
    search = {} if args.lbfgs_steps is None else {"lbfgs_steps": args.lbfgs_steps}
    res = run_hand_campaign(truth, (start, steps), terms, goal, lab, **loop, **search)

    def write(out):
        first = doc if doc is not None else _first_payload(args.first, start, steps, truth, terms)
        res.steps[0].file = str(save_protocol(out / "first.protocol.json", first, force=True))
        for step in res.steps[1:]:
            step.file = str(save_protocol(out / f"{step.name}.protocol.json", step.protocol, force=True))

    return res, write


def cmd_campaign(args) -> int:
    """``gyrojax campaign --simulate TRUTH --first PLAN``: the loop on a simulated laboratory — a turntable, or a
    person turning a box when the truth is an imu-triad's — prints the steps and the comparison with the classical
    calibration, or ``--json``; writes the plans (protocols), records and figure into ``--out``."""
    from gyrojax.data.records import save_record
    from gyrojax.data.truth import TriadTruth, load_truth
    from gyrojax.protocol import atomic_write_text, strict

    if not args.simulate:
        raise UsageError("campaign needs --simulate TRUTH.json (the laboratory is simulated from it)")
    goal = goal_from_args(args)
    truth = load_truth(args.simulate)
    terms = parse_terms(args.terms)
    if not terms:
        raise UsageError("--terms: give the lab's model before any test, e.g. --terms D_F,D_I,D_S")
    out = Path(args.out) if args.out else None
    if out is not None and out.exists() and any(out.iterdir()) and not args.force:
        raise UsageError(f"{out}: exists and is not empty; pass --force to overwrite")
    if args.max_tests < 1:
        raise UsageError(f"--max-tests must be at least 1, got {args.max_tests}")
    hand = isinstance(truth, TriadTruth)  # the one place the instrument's plug-in is chosen
    plug_in = _hand_campaign if hand else _table_campaign

    def progress(nt):
        if not args.json:
            print(f"  [{nt.status}] model {', '.join(nt.terms)}; {nt.reason[:160]}", flush=True)

    loop = {"seed": args.seed, "max_tests": args.max_tests, "on_step": progress, "starts": args.starts}
    res, write = plug_in(args, truth, terms, goal, {**loop, "steps": args.steps})
    j = res.to_json()
    if out is not None:
        from gyrojax.report.figures import campaign_figure, save

        out.mkdir(parents=True, exist_ok=True)
        write(out)
        for r in res.records:
            save_record(r, out / "records", force=True)
        save(campaign_figure(res), out / "campaign.png")
        j = res.to_json()
        atomic_write_text(out / "campaign.json", json.dumps(strict(j), indent=1))
    if args.json:
        print(json.dumps(strict(j), indent=1))
        return 0
    print(f"goal met: {res.goal_met} ({res.status}); model: {', '.join(j['terms'])}; verdict: {j['verdict']}")
    for s in j["steps"]:
        print(f"  {s['plan']}: {s['hours']:.3g} h (total {s['cumulative_hours']:.3g} h) — {s['reason'][:200]}")
    c = j["classical_table_hours"]
    ratio = j["hours_ratio"]
    why = (j["classical"] or {}).get("reason") or "not run"
    what, which = ("session", "the first session repeated") if hand else ("table", "Hu's classical sequence")
    print(
        f"{what} hours: loop {j['table_hours']:.3g} h; {which} for the same σ: "
        + (f"{c:.3g} h (ratio {ratio:.2f})" if c else f"not reached ({why})")
    )
    if c and (j["classical"] or {}).get("reason"):
        print(f"  note: {why}")
    bound = j["hours_lower_bound"]
    if bound and bound.get("statement"):
        print(f"lower bound: {bound['statement']}")
    if not res.goal_met:
        print(f"why: {res.reason}")
    return 0
