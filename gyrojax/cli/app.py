"""The ``gyrojax`` command line: the parser of every sub-command, start-up and error handling.

Exit codes: 0 success; 2 usage or input error (one line on stderr, no traceback); 1 internal error.
Every sub-command that writes files refuses to overwrite without ``--force`` and writes atomically.
Start-up imports only argparse: each command imports the part of the library it needs when it runs
(:mod:`gyrojax.cli.commands`), so ``gyrojax --help`` and bad-usage errors answer at once.

The command's process is gyrojax's alone, so it turns JAX's persistent compilation cache on for every compiled
function (:func:`gyrojax.runtime.cache.use_persistent_cache`: ``$XDG_CACHE_HOME/gyrojax/jax`` or
``~/.cache/gyrojax/jax``; ``GYROJAX_NO_CACHE=1`` turns it off and ``GYROJAX_CACHE_DIR`` moves it); the executables of
gyrojax's kept functions live beside it (:mod:`gyrojax.runtime.kept`), so a fresh process neither traces nor compiles
them again. The settings reach JAX through its environment variables when JAX is not yet imported: ``gyrojax --help``,
``plans`` and ``import`` never import it.
"""

from __future__ import annotations

import argparse
import atexit
import os
import sys
import threading

from gyrojax.cli.args import UsageError
from gyrojax.cli.import_table import add_table_arguments
from gyrojax.errors import GyrojaxError
from gyrojax.runtime.cache import use_persistent_cache
from gyrojax.runtime.threads import POOL_PREFIX, single_threaded_blas, stop_workers


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse would print usage and exit 2; keep it to one line
        raise UsageError(f"{self.prog}: {message}")


def add_effect_arguments(parser) -> None:
    """``--effect NAME=EXPR`` and ``--effects-file PATH`` (both repeatable) on a sub-command
    (:mod:`gyrojax.physics.expression`)."""
    parser.add_argument(
        "--effect",
        action="append",
        metavar="NAME=EXPR",
        help="an effect NAME·EXPR of your own (deg/h per unit of EXPR), EXPR in the instrument inputs",
    )
    parser.add_argument(
        "--effects-file",
        action="append",
        metavar="PATH",
        help='a TOML/JSON file with an [effects] table of NAME = "EXPR"',
    )


def _add_campaign_arguments(parser) -> None:
    """The goal and lab options of ``next`` and ``campaign`` (:mod:`gyrojax.cli.campaign`, imported only here, where
    its module has no import of the library)."""
    from gyrojax.cli.campaign import add_goal_arguments, add_lab_arguments

    add_goal_arguments(parser)
    add_lab_arguments(parser)


def _add_hand_arguments(parser) -> None:
    """The hand lab's options of ``next`` on imu-triad records and ``campaign`` on an imu-triad truth
    (:func:`gyrojax.cli.campaign.add_hand_arguments`)."""
    from gyrojax.cli.campaign import add_hand_arguments

    add_hand_arguments(parser)


def _command(name: str):
    """A lazy handler: imports :mod:`gyrojax.cli.commands` only when the sub-command runs."""

    def run(args) -> int:
        if name == "noise":  # gyrojax noise: a module of its own
            from gyrojax.cli.noise import cmd_noise

            return cmd_noise(args)
        from gyrojax.cli import commands

        return getattr(commands, f"cmd_{name}")(args)

    return run


def _campaign_command(name: str):
    """A lazy handler of :mod:`gyrojax.cli.campaign` (``next``, ``campaign``): the library is imported when it runs."""

    def run(args) -> int:
        from gyrojax.cli import campaign

        return getattr(campaign, f"cmd_{name}")(args)

    return run


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``gyrojax`` command, with every sub-command."""
    p = _Parser(prog="gyrojax", description="Identify gyroscope error coefficients from turntable tests.")
    p.add_argument("--version", action="store_true", help="print the version and exit")
    sub = p.add_subparsers(dest="command", parser_class=_Parser)

    s = sub.add_parser("plans", help="list the built-in test plans")
    s.set_defaults(func=_command("plans"))

    s = sub.add_parser("simulate", help="simulate a plan into records (conventions §5)")
    s.add_argument("plan", help="built-in plan name (see `gyrojax plans`) or a plan JSON file")
    s.add_argument("--truth", help="truth JSON (conventions §8); default: a perfect gyro")
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--option", "-o", action="append", metavar="NAME=VALUE", help="plan builder option")
    s.add_argument(
        "--dynamics",
        choices=("quasi-static", "loop"),
        default="quasi-static",
        help="quasi-static balance equation, or through the instrument's loop (rebalance, TDF capture, float)",
    )
    s.add_argument("--force", action="store_true", help="overwrite existing records")
    s.add_argument("--json", action="store_true")
    add_effect_arguments(s)
    s.set_defaults(func=_command("simulate"))

    s = sub.add_parser("fit", help="fit named effects to records (conventions §7)")
    s.add_argument("records", nargs="+", help="record files (.csv or .json) or directories")
    s.add_argument("--terms", help="comma-separated effect names (conventions §6)")
    s.add_argument("--json", action="store_true")
    s.add_argument("--save", help="write the result as JSON to this path")
    s.add_argument("--noise-model", metavar="NOISE.json", help="GLS with this noise model (gyrojax noise --json)")
    s.add_argument("--force", action="store_true")
    add_effect_arguments(s)
    s.add_argument(
        "--per-instrument", action="store_true", help="fit each instrument (JSON instrument.id/channel) on its own"
    )
    s.set_defaults(func=_command("fit"))

    s = sub.add_parser("diagnose", help="rank the effects the model is missing (conventions §7)")
    s.add_argument("records", nargs="+")
    s.add_argument("--terms", help="comma-separated effect names of the current model")
    s.add_argument("--alpha", type=float, help="family-wise significance level (default: the library's, 0.01)")
    s.add_argument("--json", action="store_true")
    add_effect_arguments(s)
    s.set_defaults(func=_command("diagnose"))

    s = sub.add_parser("noise", help="Allan deviation, GMWM noise model and its adequacy for static records")
    s.add_argument("records", nargs="+", help="static SDF record files (.csv or .json) or directories")
    s.add_argument("--json", action="store_true")
    s.add_argument("--plot", metavar="PNG", help="write a log-log Allan plot: empirical band, model and processes")
    s.add_argument("--taus", help="octave | decade | all | comma-separated taus in s (default: 10 per decade)")
    s.add_argument("--method", default="gmwm", choices=("gmwm", "avlr", "ieee952"), help="noise-model fit")
    s.add_argument("--model", default="auto", help="auto (identified selection) or a sum: white+gm+rw, white+2gm")
    s.add_argument("--gauss-markov", action="store_true", help="add a Gauss-Markov term to the IEEE 952 read-off")
    s.add_argument("--robust", action="store_true", help="robust GMWM (biweight wavelet variance), glitches unmasked")
    s.add_argument("--kalibr", metavar="YAML", help="write Kalibr's imu.yaml (noise densities, random walks)")
    s.add_argument("--rostopic", default="/imu0", help="the rostopic written into the Kalibr file (default /imu0)")
    s.add_argument("--kalibr-accel", metavar="ND,RW", help="Kalibr accelerometer pair of a gyro-only record")
    s.add_argument("--force", action="store_true", help="overwrite the plot / Kalibr file")
    s.set_defaults(func=_command("noise"))

    s = sub.add_parser("design", help="design a static multi-position plan by gradients (D/A/E/c/detect)")
    s.add_argument("--terms", help="comma-separated effect names (default: the 9-term SDF model, D_OO left out)")
    s.add_argument("--table", default="two-axis", choices=("two-axis",))
    s.add_argument("--positions", type=int, default=24)
    s.add_argument("--hours", type=float, default=4.0, help="total dwell time")
    s.add_argument("--criterion", default="D", help="D | A | E | c:COEF=w,... | detect:NAME[=magnitude]")
    s.add_argument("--arw", type=float, default=0.01, help="angle random walk, deg/√h")
    s.add_argument("--gm", help="Gauss–Markov drift 'sigma_deg_per_h,tau_s'")
    s.add_argument("--noise-model", metavar="NOISE.json", help="noise from a white+gm model of gyrojax noise")
    s.add_argument("--dt", type=float, default=1.0, help="sample interval, s")
    s.add_argument("--starts", type=int, default=8)
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--adam-steps", type=int, help="Adam steps (default 600; imu-triad 150)")
    s.add_argument(
        "--lbfgs-steps", type=int, help="L-BFGS steps after Adam (default 40; imu-triad at most 400, until settled)"
    )
    s.add_argument("--out", required=True, help="the plan JSON to write")
    s.add_argument("--force", action="store_true", help="overwrite an existing plan file")
    s.add_argument("--json", action="store_true")
    s.add_argument("--separate", metavar="A,B", help="design the test on the records' table that separates A from B")
    s.add_argument("--from", dest="from_records", nargs="+", metavar="RECORD", help="the records of --separate")
    add_effect_arguments(s)
    s.add_argument("--instrument", choices=("imu-triad",), help="imu-triad: a hand calibration protocol for a MEMS IMU")
    s.add_argument("--poses", type=int, help="imu-triad: number of rests (default 12)")
    s.add_argument("--minutes", type=float, help="imu-triad: total time of rests and turns (default 10)")
    s.add_argument("--placement-deg", type=float, help="imu-triad: hand placement error per axis, deg (default 0)")
    s.set_defaults(func=_command("design"))

    s = sub.add_parser("next", help="the next test: diagnose the records, design the test that nears the goal most")
    s.add_argument("records", nargs="+", help="the campaign's records so far (files or directories)")
    s.add_argument("--out", required=True, help="the plan JSON of the next test to write")
    s.add_argument("--looks", type=int, default=0, help="diagnoses the campaign has already made (default 0)")
    s.add_argument("--hours-spent", type=float, default=0.0, help="table hours the campaign has already used")
    s.add_argument("--seed", type=int, default=0, help="seed of the design search's random starts")
    s.add_argument("--force", action="store_true", help="overwrite an existing plan file")
    s.add_argument("--json", action="store_true")
    _add_campaign_arguments(s)
    _add_hand_arguments(s)
    s.set_defaults(func=_campaign_command("next"))

    s = sub.add_parser("campaign", help="the test campaign loop on a laboratory simulated from a truth file")
    s.add_argument("--simulate", metavar="TRUTH.json", help="the truth of the simulated laboratory (conventions §8)")
    s.add_argument("--first", required=True, help="the lab's first test: a built-in plan or hand session, or a file")
    s.add_argument("--option", "-o", action="append", metavar="NAME=VALUE", help="option of the first plan's builder")
    s.add_argument("--seed", type=int, default=0, help="noise seed of the campaign")
    s.add_argument("--max-tests", type=int, default=8, help="designed tests at most (default 8)")
    s.add_argument("--out", help="directory for the plans, records, campaign.json and campaign.png")
    s.add_argument("--force", action="store_true", help="write into a non-empty --out")
    s.add_argument("--json", action="store_true")
    _add_campaign_arguments(s)
    _add_hand_arguments(s)
    s.set_defaults(func=_campaign_command("campaign"))

    s = sub.add_parser("mc", help="Monte Carlo study: simulate and fit many gyros (docs/montecarlo.md)")
    s.add_argument("study", help="study JSON (gyrojax.montecarlo.study.Study)")
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument("--draws", type=int, help="override the study's number of draws")
    s.add_argument("--start", type=int, default=0, help="first draw index (split a study by index ranges)")
    s.add_argument("--noise-model", metavar="NOISE.json", help="draw the noise from this model (gyrojax noise)")
    s.add_argument("--json", action="store_true")
    s.add_argument("--force", action="store_true", help="overwrite existing results")
    g = s.add_argument_group("one jax.distributed job of N processes (process 0 writes; docs/montecarlo.md)")
    g.add_argument("--coordinator", metavar="HOST:PORT", help="process 0's address (or JAX_COORDINATOR_ADDRESS)")
    g.add_argument("--num-processes", type=int, metavar="N", help="number of processes in the job")
    g.add_argument("--process-id", type=int, metavar="K", help="this process's index, 0 … N−1")
    s.set_defaults(func=_command("mc"))

    s = sub.add_parser("mc-merge", help="merge Monte Carlo results of disjoint draw ranges (mc --start/--draws)")
    s.add_argument("dirs", nargs="+", help="result directories written by gyrojax mc")
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument("--json", action="store_true")
    s.add_argument("--force", action="store_true", help="overwrite existing results")
    s.set_defaults(func=_command("mc_merge"))

    s = sub.add_parser(
        "import",
        help="convert an IMU session or rest log (imucal, imu_tk, CSV, ROS bag) or a turntable's log into records",
    )
    s.add_argument("format", choices=("imucal", "imutk", "csv", "bag", "table"))
    s.add_argument(
        "inputs",
        nargs="+",
        help="imucal: SESSION.csv; imutk: ACC GYRO; csv: FILE.csv (or .mat); bag: BAG; table: TABLE.csv [GYRO.csv]",
    )
    s.add_argument("--topic", help="bag: the sensor_msgs/Imu topic (default: the bag's only one)")
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument("--sections", help='imucal: section list {"x_p": {"start": s, "end": e}, …} (JSON or CSV)')
    s.add_argument(
        "--rate-hz",
        type=float,
        help="imucal: sample rate (default 204.8); csv: the log's rate (checked with its clock)",
    )
    s.add_argument(
        "--gyro-unit", choices=("counts", "dps", "rad/s"), help="default counts (bag: rad/s, sensor_msgs/Imu's)"
    )
    s.add_argument("--gyro-scale", type=float, help="nominal gyro scale, counts per deg/s (raw counts)")
    s.add_argument("--acc-unit", choices=("g", "m/s^2", "counts"), help="imutk (default counts), csv (default g)")
    s.add_argument(
        "--acc-scale", type=float, metavar="COUNTS_PER_G", help="imutk, csv: a rest log's nominal accelerometer scale"
    )
    s.add_argument("--angle", type=float, help="imucal: total angle of each hand rotation, deg (default 360)")
    s.add_argument("--angle-std", type=float, help="imucal: 1-sigma error of that angle, deg (default 0)")
    s.add_argument("--latitude", type=float, help="site latitude, deg (default: unknown)")
    s.add_argument(
        "--gravity", type=float, help="local gravity, m/s^2 (default: WGS-84 normal gravity at --latitude, else g0)"
    )
    s.add_argument("--map", help="csv: column mapping time=COL (or sample=COL),gyro_x=COL,…[,acc_x=COL,…]")
    s.add_argument(
        "--rotations", metavar="SPEC|FILE", help="csv, gyro only (no acc_<c>): the turns, x:360,y:360,z:360 or a file"
    )
    s.add_argument("--delimiter", help="imucal, csv: ',', ';', 'tab' or 'auto' (default: detected)")
    s.add_argument(
        "--time-unit",
        choices=("s", "ms", "us", "ns", "iso"),
        help="csv, table: unit of the time column (default s; csv reads ISO 8601 date-times without one)",
    )
    s.add_argument("--min-rest", type=float, metavar="S", help="imutk, csv: shortest rest kept, s (default 0.5)")
    s.add_argument(
        "--static-threshold",
        type=float,
        metavar="X",
        help="imutk, csv: rest threshold in multiples of the rest noise variance (default: from the window)",
    )
    s.add_argument("--name", help="record name (default: the input file's stem)")
    s.add_argument("--id", help="instrument id (records of different ids are never fitted together)")
    s.add_argument("--force", action="store_true")
    s.add_argument("--json", action="store_true")
    add_table_arguments(s)
    s.set_defaults(func=_command("import"))

    s = sub.add_parser("apply", help="write calibrated rates of imu-triad records with a saved triad fit")
    s.add_argument("fit", help="a triad fit saved by `gyrojax fit … --save FIT.json`")
    s.add_argument("records", nargs="+")
    s.add_argument("--out", required=True, help="output directory (NAME.calibrated.csv, deg/s)")
    s.add_argument("--force", action="store_true")
    s.add_argument("--json", action="store_true")
    s.set_defaults(func=_command("apply"))

    s = sub.add_parser("demo", help="the hidden-effect walkthrough: simulate, fit, diagnose, add, refit, report")
    s.add_argument("--out", default="demo-report")
    s.add_argument("--force", action="store_true")
    s.add_argument("--quick", action="store_true", help="shorter records (for tests)")
    s.set_defaults(func=_command("demo"))
    return p


def main(argv=None) -> int:
    """Run the ``gyrojax`` command on ``argv`` (default ``sys.argv[1:]``); returns the exit code (0, 1 or 2)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.version:
            from gyrojax import __version__

            print(__version__)
            return 0
        if not getattr(args, "command", None):
            parser.print_help()
            return 0
        use_persistent_cache()
        single_threaded_blas()
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
        if os.environ.get("GYROJAX_DEBUG"):
            raise
        print(f"gyrojax: internal error: {type(e).__name__}: {e}".replace("\n", " "), file=sys.stderr)
        return 1


def console() -> None:
    """The ``gyrojax`` command as a process (the console script and ``python -m gyrojax``): :func:`main` on
    ``sys.argv``, then the process' end without the interpreter's teardown of every object (JAX's compiled code and
    arrays that nobody sees). Before it ends, the output is flushed, the worker pool stopped and every exit handler
    run (``atexit``: JAX waits for pending effects, shuts down ``jax.distributed`` and clears its backends). The
    ordinary exit is taken instead when a flush fails (a closed pipe keeps Python's own handling) or a thread other
    than the idle workers is still alive."""
    rc = main()
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):
        raise SystemExit(rc) from None
    stop_workers()
    busy = [
        t
        for t in threading.enumerate()
        if t is not threading.main_thread() and not t.daemon and not t.name.startswith(POOL_PREFIX)
    ]
    if busy or not hasattr(atexit, "_run_exitfuncs"):
        raise SystemExit(rc)
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):  # what the handlers printed
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(rc)
