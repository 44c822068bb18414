"""``gyrojax import table``: a turntable data system's log into a conventions record (:mod:`gyrojax.data.tablelog`).

Its options (:func:`add_table_arguments`) join the ``import`` sub-command's; every one of them is refused by the other
importers (:func:`refuse_table_options`), and the ``import`` options that do not apply to a table log are refused
here. Imports nothing heavy at start-up (argparse only): the command line answers ``--help`` at once.
"""

from __future__ import annotations

import json

from gyrojax.cli.args import UsageError, save_new_records

TABLE_OPTIONS = {
    "setup": "--setup",
    "kind": "--kind",
    "mode": "--mode",
    "servo_axis": "--servo-axis",
    "axes": "--axes",
    "mounting": "--mounting",
    "scale": "--scale",
    "angle_unit": "--angle-unit",
    "counts_per_rev": "--counts-per-rev",
    "rate_unit": "--rate-unit",
    "output_unit": "--output-unit",
    "temperature_unit": "--temperature-unit",
    "gyro_time_unit": "--gyro-time-unit",
    "clock_offset": "--clock-offset",
    "keep_transitions": "--keep-transitions",
}
"""The options of ``import table`` alone (destination → flag)."""
NOT_FOR_TABLE = ("sections", "rate_hz", "acc_unit", "angle", "angle_std", "min_rest", "static_threshold", "gyro_scale")
"""``import`` options of the IMU importers that a table log does not take."""


def add_table_arguments(parser) -> None:
    """The options of ``import table`` on the ``import`` sub-command's parser."""
    g = parser.add_argument_group("table: a turntable data system's log (docs/cli.md#import-table)")
    g.add_argument("--setup", metavar="FILE", help="table: set-up file (TOML or JSON): columns, units, site, axes, …")
    g.add_argument("--kind", help="table: instrument kind (sdf-gyro, tdf-gyro, pendulous-accel, fog, rlg)")
    g.add_argument("--mode", help="table: rebalance or servo")
    g.add_argument("--servo-axis", help="table: the servo axis (servo mode)")
    g.add_argument("--axes", metavar="NAME=E,N,U[;…]", help="table: table axes in ENU at zero, outermost first")
    g.add_argument("--mounting", metavar="IA=x,y,z;OA=x,y,z", help="table: instrument axes in platform coordinates")
    g.add_argument("--scale", metavar="'VALUE UNIT'", help="table: nominal scale, e.g. '0.02 V/(deg/s)', '17 deg/h/mA'")
    g.add_argument("--angle-unit", choices=("deg", "rad", "arcsec", "counts"), help="table: unit of the angles")
    g.add_argument("--counts-per-rev", type=float, help="table: encoder counts in one revolution")
    g.add_argument("--rate-unit", choices=("deg/s", "rad/s", "deg/h", "rpm"), help="table: unit of the table rates")
    g.add_argument("--output-unit", help="table: unit of the output (mA, A, uA, V, mV, pulses, deg/h, deg/s, …)")
    g.add_argument("--temperature-unit", choices=("C", "K", "F"), help="table: unit of the temperature")
    g.add_argument("--gyro-time-unit", choices=("s", "ms", "us", "ns", "iso"), help="table: the second log's clock")
    g.add_argument("--clock-offset", type=float, metavar="S", help="table: second log's time + offset = table's time")
    g.add_argument("--keep-transitions", action="store_true", default=None, help="table: keep the transitions")


def refuse_table_options(args) -> None:
    """Refuse the options of ``import table`` on the other importers (one line naming the option)."""
    for dest, flag in TABLE_OPTIONS.items():
        if getattr(args, dest, None) is not None:
            raise UsageError(f"import {args.format}: option {flag} does not apply (it is for import table)")


def _pairs(text: str) -> dict:
    pairs = [p.split("=", 1) for p in text.split(",")]
    if any(len(p) != 2 or not p[0].strip() or not p[1].strip() for p in pairs):
        raise UsageError(f"import table: option --map {text!r}: give KEY=COLUMN pairs separated by commas")
    return {k.strip(): v.strip() for k, v in pairs}


def cmd_import_table(args) -> int:
    """``gyrojax import table TABLE.csv [INSTRUMENT.csv] --out DIR``: one record from a table data system's log(s)."""
    from gyrojax.data.tablelog import import_summary, import_table
    from gyrojax.data.tablesetup import TableSetup, apply_flags, read_setup_file, setup_from_dict

    for dest in NOT_FOR_TABLE:
        if getattr(args, dest, None) is not None:
            raise UsageError(f"import table: option --{dest.replace('_', '-')} does not apply (it is for IMU logs)")
    if len(args.inputs) not in (1, 2):
        raise UsageError("import table takes the table's log and, on a clock of its own, the instrument's log")
    setup = setup_from_dict(read_setup_file(args.setup), args.setup) if args.setup else TableSetup()
    # the table's own options laid over the set-up file, then the import options it shares with the IMU importers
    flags = {flag: getattr(args, dest) for dest, flag in TABLE_OPTIONS.items() if dest != "setup"}
    flags.update({"--name": args.name, "--id": args.id, "--latitude": args.latitude, "--gravity": args.gravity})
    flags.update({"--map": _pairs(args.map) if args.map else None, "--time-unit": args.time_unit})
    setup = apply_flags(setup, flags)
    gyro_log = args.inputs[1] if len(args.inputs) == 2 else None
    rec = import_table(args.inputs[0], gyro_log, setup, delimiter=args.delimiter)
    (path,) = save_new_records([rec], args.out, args.force)
    report = rec.meta["import"]
    if args.json:
        print(json.dumps({"record": str(path), "n_samples": rec.n, "output": rec.meta["output"], "import": report}))
    else:
        print(f"{path}: {rec.n} samples, {rec.kind} in {rec.mode} mode")
        print(f"output: {rec.meta['output'].get('note', '')}")
        print("\n".join(import_summary(report)))
    return 0
