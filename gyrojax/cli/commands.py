"""What each ``gyrojax`` sub-command does. Each imports the library it needs when it runs, so the command line
starts fast (:mod:`gyrojax.cli.app` builds the parser). Every function takes the parsed arguments and returns the
exit code; bad input raises a :class:`gyrojax.errors.GyrojaxError` that :func:`gyrojax.cli.app.main` prints as one
line with exit code 2."""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

from gyrojax.cli.app import UsageError, parse_gm, parse_options, parse_terms


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


def _plan_from_arg(arg: str, options: dict):
    from gyrojax.data import plans

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
    from gyrojax.data.records import record_paths, save_record
    from gyrojax.data.truth import Truth, load_truth
    from gyrojax.simulation.simulator import simulate

    plan = _plan_from_arg(args.plan, parse_options(args.option))
    effects_from_args(args, plan.runs[0].instrument.get("kind", "sdf-gyro") if plan.runs else "sdf-gyro")
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
    from gyrojax.data.records import load_records
    from gyrojax.inference.identify import fit
    from gyrojax.report.figures import fit_table

    recs = load_records(args.records)
    names = effects_from_args(args, recs[0].kind)
    res = fit(recs, terms_with_effects(parse_terms(args.terms), names, recs[0].kind))
    if args.json:
        print(json.dumps(res.to_json()))
    else:
        print(fit_table(res))
    if args.save:
        res.save(args.save, force=args.force)
    return 0


def cmd_diagnose(args) -> int:
    """``gyrojax diagnose``: fit, then test every missing effect and print the verdict; exit code."""
    from gyrojax.data.records import load_records
    from gyrojax.inference.diagnose import diagnose
    from gyrojax.report.figures import diagnosis_text

    if not 0.0 < args.alpha < 1.0:
        raise UsageError(f"--alpha must lie in (0, 1), got {args.alpha}")
    recs = load_records(args.records)
    names = effects_from_args(args, recs[0].kind)
    d = diagnose(recs, terms_with_effects(parse_terms(args.terms), names, recs[0].kind), alpha=args.alpha)
    if args.json:
        print(json.dumps(d.to_json()))
    else:
        print(diagnosis_text(d))
    return 0


def cmd_demo(args) -> int:
    """``gyrojax demo``: run the hidden-effect walkthrough into ``--out``; exit code."""
    from gyrojax.report.demo import run_demo

    path = run_demo(args.out, force=args.force, quick=args.quick)
    print(f"report: {path}")
    return 0


# ---- noise, design and Monte Carlo -----------------------------------------------------------------------------


def cmd_noise(args) -> int:
    """``gyrojax noise``: Allan deviation (deg/h against τ in s) and noise fit of static records; exit code."""
    from gyrojax.data.records import load_records
    from gyrojax.noise.allan import UNITS, analyze, noise_json, static_rate_segments
    from gyrojax.report.figures import allan_figure, save

    if args.plot and Path(args.plot).exists() and not args.force:
        raise UsageError(f"{args.plot}: exists; pass --force to overwrite")

    recs = load_records(args.records)
    segs, tau0 = static_rate_segments(recs)
    res, fit = analyze(segs, tau0, gauss_markov=args.gauss_markov)
    if args.plot:
        save(allan_figure(res, fit, title=", ".join(r.name for r in recs)), args.plot)
    if args.json:
        print(json.dumps(noise_json(res, fit)))
        return 0
    print(f"{'tau_s':>12s} {'adev_deg_per_h':>16s} {'low':>12s} {'high':>12s}")
    for t, a, lo, hi in zip(res.taus_s, res.adev, res.low, res.high, strict=True):
        print(f"{t:12.4g} {a:16.6g} {lo:12.6g} {hi:12.6g}")
    for k in fit.included:
        if k == "gauss_markov":
            print(f"gauss_markov: sigma {fit.gauss_markov[0]:.6g} deg/h, tau {fit.gauss_markov[1]:.6g} s")
        else:
            print(f"{k}: {fit.values[k]:.6g} {UNITS[k]}")
    return 0


def cmd_design(args) -> int:
    """``gyrojax design``: design a static plan (ARW in deg/√h, GM as σ deg/h and τ s, total dwell in h), write
    the plan file to ``--out`` and print its comparison with the classical set; exit code."""
    import jax.numpy as jnp
    import numpy as np

    from gyrojax.data import plans
    from gyrojax.data.io import atomic_write_text
    from gyrojax.planning.optimal import SDF9, Noise, criterion_values, design, static_fisher, table_text

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
    noise = Noise(args.arw, gm)
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
    atomic_write_text(out, plans.plan_to_json(plan))
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
    """``gyrojax mc``: run a study file and write draws, summary and plot into ``--out``; exit code."""
    from gyrojax.montecarlo.study import StudyError, load_study, run_study, save_result, summarize

    study = load_study(args.study)
    if args.draws is not None:
        if args.draws < 1:
            raise StudyError("--draws must be >= 1")
        study = replace(study, draws=args.draws)
    out = Path(args.out)
    if not args.force and (out / "study.json").exists():
        raise StudyError(f"{out / 'study.json'} exists; use --force to overwrite")
    res = run_study(study, progress=study.draws >= 2000 or sys.stderr.isatty())
    files = save_result(res, out, force=args.force)
    summ = summarize(res)
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
    return 0
