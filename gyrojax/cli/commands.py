"""What each ``gyrojax`` sub-command does. Each imports the library it needs when it runs, so the command line
starts fast (:mod:`gyrojax.cli.app` builds the parser). Every function takes the parsed arguments and returns the
exit code; bad input raises a :class:`gyrojax.errors.GyrojaxError` that :func:`gyrojax.cli.app.main` prints as one
line with exit code 2."""

from __future__ import annotations

import json
import sys
import warnings
from dataclasses import replace
from pathlib import Path

from gyrojax.cli.args import UsageError, parse_gm, parse_options, parse_terms, save_new_records
from gyrojax.errors import ConvergenceWarning, ModelError
from gyrojax.kinds import TRIAD_KIND


def effects_from_args(args, kind: str) -> list[str]:
    """Register the ``--effect``/``--effects-file`` effects of ``args`` for instruments of ``kind``; their names."""
    from gyrojax.physics.expression import command_line_effects

    return command_line_effects(getattr(args, "effect", None), getattr(args, "effects_file", None), kind)


def terms_with_effects(terms: list[str], names: list[str], kind: str) -> list[str] | None:
    """``terms`` (default: the fit's default model for ``kind``) with the user effects ``names`` appended once."""
    if not names:
        return terms or None
    from gyrojax.inference.identify import DEFAULT_TERMS

    base = list(terms) if terms else list(DEFAULT_TERMS[kind])
    return base + [n for n in names if n not in base]


# ---- records, fits and diagnoses
# ----------------------------------------------------------------------------------------------


def cmd_plans(args) -> int:
    """``gyrojax plans``: print the built-in plans, one line each; exit code."""
    from gyrojax.data.plans import BUILDERS

    for name, (_, doc) in BUILDERS.items():
        print(f"{name:18s} {doc}")
    return 0


def plan_from_arg(arg: str, options: dict):
    """The plan a command names: a built-in plan built with ``options`` (``-o NAME=VALUE``), or a plan file (options
    refused); a :class:`UsageError` naming both kinds when ``arg`` is neither."""
    from gyrojax.data import plans
    from gyrojax.data.planfile import load_plan

    if arg in plans.BUILDERS:
        return plans.build(arg, **options)
    p = Path(arg)
    if p.suffix == ".json" or p.exists():
        if options:
            raise UsageError("--option applies to built-in plans only, not to a plan file")
        return load_plan(p)
    raise UsageError(f"{arg!r} is neither a built-in plan ({', '.join(plans.BUILDERS)}) nor a plan file")


def cmd_simulate(args) -> int:
    """``gyrojax simulate``: build a plan, simulate it with a truth file, write the records; exit code."""
    from gyrojax.data.truth import Truth, load_truth
    from gyrojax.simulation.simulator import simulate

    plan = plan_from_arg(args.plan, parse_options(args.option))
    effects_from_args(args, plan.runs[0].instrument.get("kind", "sdf-gyro") if plan.runs else "sdf-gyro")
    truth = load_truth(args.truth) if args.truth else Truth()
    recs = simulate(plan, truth, seed=args.seed, dynamics=args.dynamics)
    paths = [str(p) for p in save_new_records(recs, args.out, args.force)]
    if args.json:
        print(json.dumps({"plan": plan.name, "records": paths, "seed": args.seed}))
    else:
        for p in paths:
            print(p)
    return 0


def command_terms(args, records) -> list[str] | None:
    """The model of ``--terms`` with the user effects (``--effect``, ``--effects-file``) appended once (default
    terms: the fit's for the records); each channel of an imu-triad is an SDF-like gyro, whose effects these are
    (:mod:`gyrojax.physics.triad`). Effect names only: dimensionless."""
    from gyrojax.physics.effects import SDF

    triad = records[0].kind == TRIAD_KIND
    names = effects_from_args(args, SDF if triad else records[0].kind)
    if not triad:
        return terms_with_effects(parse_terms(args.terms), names, records[0].kind)
    from gyrojax.inference.triad import default_terms

    terms = parse_terms(args.terms)
    if not names:
        return terms or None
    base = list(terms) if terms else list(default_terms(records))
    return base + [n for n in names if n not in base]


def _refuse_unconverged_triad(records, res, what: str) -> None:
    """A triad fit cut short is not an answer: one error line, nothing reported (a turntable fit warns instead)."""
    if records[0].kind == TRIAD_KIND and not res.converged:
        raise ModelError(f"the triad fit did not converge ({res.convergence_note}); {what}")


def cmd_fit(args) -> int:
    """``gyrojax fit``: fit named effects to records and print the coefficient table (report units); exit code."""
    from gyrojax.data.records import load_records
    from gyrojax.inference.identify import fit, fit_per_instrument
    from gyrojax.report.text import fit_table

    recs = load_records(args.records)
    if getattr(args, "per_instrument", False):
        if args.save:
            raise UsageError("--save takes one fit; with --per-instrument, fit each instrument's records on its own")
        results = fit_per_instrument(recs, parse_terms(args.terms) or None)
        if args.json:
            print(json.dumps({"instruments": {k or "(no id)": v.to_json() for k, v in results.items()}}))
        else:
            for k, v in results.items():
                print(f"instrument {k or '(no id)'}:")
                print(fit_table(v))
        return 0
    terms = command_terms(args, recs)
    noise = None
    if args.noise_model:
        from gyrojax.noise.gmwm_model import load_noise_model

        noise = load_noise_model(args.noise_model)
    with warnings.catch_warnings():
        if recs[0].kind == TRIAD_KIND:  # refused below when cut short: one error line, not a warning too
            warnings.simplefilter("ignore", ConvergenceWarning)
        res = fit(recs, terms, noise=noise)
    _refuse_unconverged_triad(recs, res, "no coefficients are reported")
    for note in res.notes if recs[0].kind == TRIAD_KIND else []:  # beyond the MEMS limits: said on stderr too
        if note.startswith("implausible"):
            print(f"gyrojax: warning: {note}", file=sys.stderr)
    print(json.dumps(res.to_json()) if args.json else fit_table(res))
    if args.save:
        res.save(args.save, force=args.force)
    return 0


def cmd_diagnose(args) -> int:
    """``gyrojax diagnose``: fit, then test every missing effect and print the verdict; exit code."""
    from gyrojax.data.records import load_records
    from gyrojax.inference.diagnose import diagnose
    from gyrojax.inference.scoring import ALPHA
    from gyrojax.report.text import diagnosis_text

    alpha = ALPHA if args.alpha is None else args.alpha
    if not 0.0 < alpha < 1.0:
        raise UsageError(f"--alpha must lie in (0, 1), got {alpha}")
    recs = load_records(args.records)
    terms = command_terms(args, recs)
    with warnings.catch_warnings():
        if recs[0].kind == TRIAD_KIND:  # refused below when cut short: one error line, not a warning too
            warnings.simplefilter("ignore", ConvergenceWarning)
        d = diagnose(recs, terms, alpha=alpha)
    _refuse_unconverged_triad(recs, d.fit, "nothing is diagnosed")
    print(json.dumps(d.to_json()) if args.json else diagnosis_text(d))
    return 0


def cmd_demo(args) -> int:
    """``gyrojax demo``: run the hidden-effect walkthrough into ``--out``; exit code."""
    from gyrojax.report.demo import run_demo

    path = run_demo(args.out, force=args.force, quick=args.quick)
    print(f"report: {path}")
    return 0


# ---- noise, design and Monte Carlo -----------------------------------------------------------------------------


def cmd_design(args) -> int:
    """``gyrojax design``: design a static plan (ARW in deg/√h, GM as σ deg/h and τ s, total dwell in h), write
    the plan file to ``--out`` and print its comparison with the classical set; exit code."""
    if getattr(args, "separate", None) or getattr(args, "from_records", None):  # separate two effects
        from gyrojax.cli.design_separate import cmd_design_separate

        return cmd_design_separate(args)
    if any(getattr(args, k, None) is not None for k in ("instrument", "poses", "minutes", "placement_deg")):
        from gyrojax.cli.design_triad import design_triad  # a hand IMU protocol (--instrument imu-triad)

        return design_triad(args)
    import jax.numpy as jnp
    import numpy as np

    from gyrojax.data import plans
    from gyrojax.data.planfile import plan_to_json
    from gyrojax.noise.spec import NoiseSpec
    from gyrojax.planning.baselines import table_text
    from gyrojax.planning.criteria import criterion_values
    from gyrojax.planning.fisher import static_fisher
    from gyrojax.planning.optimal import SDF9, design
    from gyrojax.protocol import atomic_write_text

    if args.lbfgs_steps is None:
        args.lbfgs_steps = 40
    if args.adam_steps is None:
        args.adam_steps = 600
    out = Path(args.out)
    if out.exists() and not args.force:
        raise UsageError(f"{out}: exists; pass --force to overwrite")
    for option, value, low in (("--positions", args.positions, 1), ("--starts", args.starts, 1)):
        if value < low:
            raise UsageError(f"{option} must be >= {low}, got {value}")
    for option, value in (("--hours", args.hours), ("--arw", args.arw), ("--dt", args.dt)):
        if not 0 < value < float("inf"):
            raise UsageError(f"{option} must be finite and positive, got {value}")
    for option, value in (("--adam-steps", args.adam_steps), ("--lbfgs-steps", args.lbfgs_steps)):
        if value < 0:
            raise UsageError(f"{option} must be >= 0, got {value}")
    terms = parse_terms(args.terms) if args.terms else list(SDF9)
    terms += [n for n in effects_from_args(args, "sdf-gyro") if n not in terms]
    gm = parse_gm(args.gm)
    noise = NoiseSpec(white=args.arw, gauss_markov=() if gm is None else (gm,))
    if args.noise_model:
        from gyrojax.noise.gmwm_model import load_noise_model

        if args.gm:
            raise UsageError("--noise-model and --gm both give the noise; pass one")
        nm = load_noise_model(args.noise_model)
        # white, quantization, Gauss-Markov, random walk, flicker: a NoiseModelError naming the file and the rest
        nm.mean_terms(args.noise_model)
        noise = nm
    res = design(
        terms,
        args.positions,
        args.hours,
        args.criterion,
        noise=noise,
        dt_s=args.dt,
        starts=args.starts,
        seed=args.seed,
        adam_steps=args.adam_steps,
        lbfgs_steps=args.lbfgs_steps,
    )
    plan = res.plan()
    atomic_write_text(out, plan_to_json(plan))
    summary = res.summary()
    rows = []
    if args.positions in plans.MULTIPOSITION_SETS:
        # the classical equal-interval set, equal dwell, same noise model (coloured included)
        pos = jnp.deg2rad(jnp.asarray(plans.MULTIPOSITION_SETS[args.positions], dtype=jnp.float64))
        dwell = jnp.full(args.positions, args.hours * 3600.0 / args.positions)
        f = np.asarray(static_fisher(res.model, res.table, pos, dwell, noise, args.dt))
        rows.append({"plan": f"multiposition-{args.positions}", **criterion_values(f, res.model)})
    rows.append(
        {"plan": f"designed-{args.positions} ({res.criterion.label()})", **criterion_values(res.fisher, res.model)}
    )
    if args.json:
        print(json.dumps({"plan": args.out, "design": summary, "comparison": rows}, indent=1, default=float))
    else:
        print(
            f"designed {args.positions}-position plan, criterion {res.criterion.label()}, "
            f"{args.hours} h of dwell -> {args.out}"
        )
        print(
            f"loss {res.loss:.6g} (best of {args.starts} starts; all: "
            f"{' '.join(f'{v:.4g}' for v in res.start_losses)}), final gradient norm {res.grad_norm:.2e}"
        )
        if "noncentrality" in summary:
            print(f"score-test noncentrality {summary['noncentrality']:.3g}, power at 1 %: {summary['power_1pct']:.3f}")
        print(table_text(rows))
    return 0


def cmd_mc(args) -> int:
    """``gyrojax mc``: run a study file and write draws, summary and plot into ``--out``; exit code.

    With ``--coordinator/--num-processes/--process-id`` (or ``JAX_COORDINATOR_ADDRESS``) this process is one of a
    ``jax.distributed`` job: each process evaluates its share of the draws, process 0 gathers and writes. A failure
    in any process (bad study, existing output) stops every process with exit 2 instead of leaving the others waiting.
    """
    from gyrojax.montecarlo import hosts

    hosts.initialize(args.coordinator, args.num_processes, args.process_id)
    import jax

    from gyrojax.errors import GyrojaxError
    from gyrojax.montecarlo.runner import run_study
    from gyrojax.montecarlo.study import StudyError, load_study

    first = jax.process_index() == 0
    err, study, out = None, None, Path(args.out)
    try:
        study = load_study(args.study)
        if args.draws is not None:
            if args.draws < 1:
                raise StudyError("--draws must be >= 1")
            study = replace(study, draws=args.draws)
        if args.noise_model:
            from gyrojax.noise.gmwm_model import load_noise_model
            from gyrojax.noise.spec import NoiseSpec

            # the simulated terms of the model (any noise --model choice); its fit details stay behind
            noise = NoiseSpec.simulation_terms(load_noise_model(args.noise_model))
            noise.mean_terms(args.noise_model)  # the fit's covariance exists (no ramp, AR), or an error naming both
            study = replace(study, noise=noise)
        if args.start < 0:
            raise StudyError(f"--start must be >= 0, got {args.start}")
        if first and not args.force and (out / "study.json").exists():
            raise StudyError(f"{out / 'study.json'} exists; use --force to overwrite")
    except GyrojaxError as e:
        err = e
    hosts.agree(err)
    res = run_study(study, start=args.start, progress=first and (study.draws >= 2000 or sys.stderr.isatty()))
    err = None
    try:
        if first:
            _write_mc(res, out, args)
    except (GyrojaxError, OSError) as e:
        err = e
    hosts.agree(err)  # the other processes exit once process 0 has written
    return 0


def _write_mc(res, out: Path, args) -> None:
    from gyrojax.montecarlo.results import save_result, summarize
    from gyrojax.montecarlo.study import StudyError
    from gyrojax.report import figures

    plot = out / "coverage.png"
    if not args.force and plot.exists():
        raise StudyError(f"{plot} exists; use --force to overwrite")
    files = save_result(res, out, force=args.force)
    summ = summarize(res)
    figures.save(figures.montecarlo_figure(res, summ), plot)
    files = {"study": files["study"], "summary": files["summary"], "plot": str(plot), **files}
    if args.json:
        print(
            json.dumps(
                {
                    "files": files,
                    "draws": int(len(res.draw)),
                    "compile_s": res.compile_s,
                    "run_s": res.run_s,
                    "summary": summ.to_dict(orient="records"),
                }
            )
        )
    else:
        print(summ.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
        print(f"{len(res.draw)} draws in {res.run_s:.2f} s (+{res.compile_s:.2f} s compile); files in {out}")


def cmd_mc_merge(args) -> int:
    """``gyrojax mc-merge DIR… --out DIR``: one result from results of disjoint draw ranges of one study."""
    import numpy as np

    from gyrojax.montecarlo.results import load_result, merge_results
    from gyrojax.montecarlo.study import StudyError

    out = Path(args.out)
    if not args.force and (out / "study.json").exists():
        raise StudyError(f"{out / 'study.json'} exists; use --force to overwrite")
    res = merge_results([load_result(d) for d in args.dirs], where=args.dirs)
    d = np.asarray(res.draw)
    if d.size and d[-1] - d[0] + 1 != d.size:
        print(f"gyrojax: note: the merged draws {d[0]}…{d[-1]} leave gaps ({d.size} draws)", file=sys.stderr)
    _write_mc(res, out, args)
    return 0


# ---- MEMS IMU triads: import and apply ---------------------------------------------------------------------------


IMPORT_OPTIONS = {
    "sections": ("imucal",),
    "rate_hz": ("imucal", "csv"),
    "acc_unit": ("imutk", "csv"),
    "acc_scale": ("imutk", "csv"),
    "angle": ("imucal",),
    "angle_std": ("imucal",),
    "map": ("csv", "table"),
    "rotations": ("csv",),
    "delimiter": ("imucal", "csv", "table"),
    "time_unit": ("csv", "table"),
    "min_rest": ("imutk", "csv", "bag"),
    "static_threshold": ("imutk", "csv", "bag"),
    "topic": ("bag",),
}
"""The ``import`` options that only some importers take; any other importer refuses them."""


def cmd_import(args) -> int:
    """``gyrojax import imucal|imutk|csv|bag|table``: convert a calibration session or a rest log into imu-triad
    records in ``--out`` (a turntable data system's log into a conventions record: :mod:`gyrojax.cli.import_table`)."""
    from gyrojax.cli.import_table import cmd_import_table, refuse_table_options
    from gyrojax.data import importers

    for dest, formats in IMPORT_OPTIONS.items():
        if getattr(args, dest) is not None and args.format not in formats:
            raise UsageError(
                f"import {args.format}: option --{dest.replace('_', '-')} does not apply (it is for import "
                f"{' and '.join(formats)})"
            )
    if args.format == "table":
        return cmd_import_table(args)
    refuse_table_options(args)
    if args.format == "bag":
        if args.gyro_unit not in (None, "rad/s") or args.acc_unit not in (None, "m/s^2") or args.gyro_scale:
            raise UsageError(
                "import bag: sensor_msgs/Imu carries rad/s and m/s^2; --gyro-unit, --gyro-scale and "
                "--acc-unit do not apply"
            )
        args.gyro_unit = "rad/s"
    args.gyro_unit = args.gyro_unit or "counts"
    if args.gyro_scale is not None and args.gyro_unit != "counts":
        raise UsageError(
            f"import {args.format}: option --gyro-scale applies to --gyro-unit counts, not {args.gyro_unit}"
        )
    common = dict(
        gyro_unit=args.gyro_unit,
        gyro_counts_per_dps=args.gyro_scale,
        latitude_deg=args.latitude,
        gravity_mps2=args.gravity,
        name=args.name,
        instrument_id=args.id,
    )
    detector = {
        k: v for k, v in (("min_rest_s", args.min_rest), ("static_threshold", args.static_threshold)) if v is not None
    }
    if args.format == "imucal":
        if len(args.inputs) != 1:
            raise UsageError("import imucal takes one SESSION.csv")
        rec = importers.import_imucal(
            args.inputs[0],
            rate_hz=args.rate_hz,
            sections=args.sections,
            angle_deg=360.0 if args.angle is None else args.angle,
            angle_std_deg=0.0 if args.angle_std is None else args.angle_std,
            delimiter=args.delimiter,
            **common,
        )
    elif args.format == "bag":
        from gyrojax.data.rosbag import import_bag

        if len(args.inputs) != 1:
            raise UsageError("import bag takes one bag (a ROS 1 .bag file or a ROS 2 bag folder)")
        common.pop("gyro_unit")
        common.pop("gyro_counts_per_dps")
        rec = import_bag(args.inputs[0], args.topic, **detector, **common)
    elif args.format == "imutk":
        if len(args.inputs) != 2:
            raise UsageError("import imutk takes two files: ACC GYRO")
        from gyrojax.data.imutk import import_imutk

        rec = import_imutk(
            args.inputs[0],
            args.inputs[1],
            acc_unit=args.acc_unit or "counts",
            acc_counts_per_g=args.acc_scale,
            **detector,
            **common,
        )
    else:
        if len(args.inputs) != 1:
            raise UsageError("import csv takes one CSV file")
        if not args.map:
            raise UsageError("import csv needs --map, e.g. time=t,gyro_x=gx,gyro_y=gy,gyro_z=gz,acc_x=ax,…")
        pairs = [p.split("=", 1) for p in args.map.split(",")]
        if any(len(p) != 2 or not p[0] or not p[1] for p in pairs):
            raise UsageError(f"import csv: option --map {args.map!r}: give KEY=COLUMN pairs separated by commas")
        if args.rotations is not None and any(k.startswith("acc_") for k, _ in pairs):
            raise UsageError("import csv: --rotations lists the turns of a gyro-only session: map no acc_<c> with it")
        long = _long_log(args, dict(pairs), common, detector)
        if long is not None:
            return long
        rec = importers.import_csv(
            args.inputs[0],
            dict(pairs),
            rotations=args.rotations,
            acc_unit=args.acc_unit or "g",
            rate_hz=args.rate_hz,
            time_unit=args.time_unit,
            delimiter=args.delimiter,
            acc_counts_per_g=args.acc_scale,
            **detector,
            **common,
        )
    (path,) = save_new_records([rec], args.out, args.force)
    kinds = [s["type"] for s in rec.meta["segments"]]
    summary = {k: kinds.count(k) for k in ("static", "rotation", "move") if k in kinds}
    report = rec.meta.get("import", {})
    if args.json:
        print(json.dumps({"record": str(path), "segments": summary, "n_samples": rec.n, "import": report}))
    else:
        from gyrojax.data.door import door_lines

        print(f"{path}: {rec.n} samples; segments " + ", ".join(f"{v} {k}" for k, v in summary.items()))
        if report.get("kind") == "rest log":
            print(f"{rec.meta['notes']}; for gyrojax noise and apply (a calibration needs at least 9 rests)")
        for line in door_lines(report):
            print(line)
        print(f"rests: {import_summary(report)}")
        for r in report.get("rotations", []) if isinstance(report.get("rotations"), list) else []:
            turned = ", ".join(f"{x:.5g}" for x in r["integrated_deg"])
            print(f"  rotation {r['axis']}:{r['angle_deg']:g} {r['start_s']:.2f}–{r['end_s']:.2f} s: {turned} deg")
        for m in report.get("moves_not_fitted", []):
            print(f"  move not fitted {m['start_s']:.2f}–{m['end_s']:.2f} s")
        for d in report.get("dropped", []):
            print(f"  dropped {d['start_s']:.2f}–{d['end_s']:.2f} s: {d['reason']} ({d['detail']})")
        for note in report.get("notes", []):
            print(f"note: {note}")
    return 0


def _long_log(args, mapping: dict, common: dict, detector: dict) -> int | None:
    """``import csv`` of a log of more than :data:`gyrojax.data.stream.STREAM_SAMPLES` rows: read in chunks as a
    rest log (:mod:`gyrojax.data.longlog`), said as any import; None for a shorter log (or a MATLAB file)."""
    from gyrojax.data.door import door_lines
    from gyrojax.data.importers import check_mapping
    from gyrojax.data.logs import is_mat_file
    from gyrojax.data.longlog import import_long_csv
    from gyrojax.data.records import read_meta
    from gyrojax.data.stream import STREAM_SAMPLES, count_rows

    path = args.inputs[0]
    if is_mat_file(path) or not Path(path).is_file() or args.rotations is not None:  # turns are read whole
        return None
    rows = count_rows(path)
    if rows <= STREAM_SAMPLES:
        return None
    check_mapping(mapping, args.time_unit)
    if args.static_threshold is not None:
        raise UsageError("import csv --static-threshold: a log this long is read in chunks; its blocks take none")
    out = import_long_csv(
        path,
        mapping,
        args.out,
        acc_unit=args.acc_unit or "g",
        acc_counts_per_g=args.acc_scale,
        rate_hz=args.rate_hz,
        time_unit=args.time_unit,
        delimiter=args.delimiter,
        force=args.force,
        rows_hint=rows,
        **{k: v for k, v in detector.items() if k == "min_rest_s"},
        **common,
    )
    meta = read_meta(out)
    report = meta["import"]
    if args.json:
        print(json.dumps({"record": str(out), "segments": {"static": len(meta["segments"])}, "import": report}))
        return 0
    print(f"{out}: {report['read_in_chunks']['rows']} samples; segments {len(meta['segments'])} static")
    print(f"{meta['notes']}; for gyrojax noise and apply (a calibration needs at least 9 rests)")
    for line in door_lines(report):
        print(line)
    for note in report["notes"]:
        print(f"note: {note}")
    return 0


def import_summary(report: dict) -> str:
    """One line of an import report: the rests found (or the sections read) and how many candidates were dropped."""
    if "sections" in report:
        return f"{report['rests_found']} faces and {report['rotations']} rotations from the {report['sections']}"
    from gyrojax.data.segments import rest_summary

    return rest_summary(report, details=False)


def cmd_apply(args) -> int:
    """``gyrojax apply FIT.json RECORDS --out DIR``: write calibrated body rates (deg/s) and specific force (g) of
    imu-triad records."""
    import numpy as np

    from gyrojax.data.records import load_records
    from gyrojax.inference.triad_result import load_triad_fit
    from gyrojax.protocol import atomic_write_text

    fit_res = load_triad_fit(args.fit)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for rec in load_records(args.records):
        target = out / f"{rec.name}.calibrated.csv"
        if target.exists() and not args.force:
            raise UsageError(f"{target}: exists; pass --force to overwrite")
        w = fit_res.apply(rec) / 3600.0
        cols = {"time_s": rec.time_s, "gyro_x_dps": w[:, 0], "gyro_y_dps": w[:, 1], "gyro_z_dps": w[:, 2]}
        acc = fit_res.specific_force(rec)  # calibrated specific force beside the calibrated rates
        if acc is not None:
            cols.update({f"acc_{c}_g": acc[:, j] for j, c in enumerate("xyz")})
        lines = [",".join(cols)] + [
            ",".join(repr(float(v)) for v in row) for row in np.column_stack(list(cols.values()))
        ]
        atomic_write_text(target, "\n".join(lines) + "\n")
        written.append(str(target))
    if args.json:
        print(json.dumps({"calibrated": written}))
    else:
        print("\n".join(written))
    return 0
