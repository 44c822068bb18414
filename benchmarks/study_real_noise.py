"""Ten campaigns of real sensors' noise and slow effects (tests/real_noise_cases.py, written by the independent
writers): what the plain reference analysis says of them (tests/reference_analysis.py), the power of each planted
effect's test at the truth, what gyrojax's diagnosis loop answers, and Monte Carlo null rates of both.

Subcommands:

* ``reference [--seeds 1,2]``: the reference's forward selection at the true noise model, and the numbers of the
  issue's claims (the trend's LM under the independent per-rest scatter, the walk's preference in −2ℓ_R, the rest
  means' residual lag-1 autocorrelation, the trend beside the power-up step, the temperature shapes' LM beside every
  named candidate, the fitted knee).
* ``power``: λ and the power at the first Holm step (families 27 and 60) of each planted effect's test.
* ``baseline [--seeds 1,2,3,4] [--cases a,b]``: ``gyrojax diagnose --json`` followed through its proposals; a
  markdown table of verdicts, proposals, estimates and named noise, and how many cases it answers right.
* ``nulls [--draws 200] [--gyrojax]``: the reference's rate of any Holm-significant candidate on each null case
  (the triads drawn in memory; the turntable null by N(0, V) draws on one campaign's regressors, the writer's drift
  being checked against V in tests/test_real_noise.py), the rate at which the reference itself finds a trend when
  it assumes independent scatter on a walk, and with ``--gyrojax`` the rate of deterministic proposals by gyrojax's
  diagnosis (written records, one diagnosis per draw). Rates with Clopper–Pearson 95 % intervals.
* ``walk-nulls [--draws 100] [--workers 1] [--full-size] [--drifts steps,rrw,scatter] [--power-ups]``: gyrojax's
  rate of deterministic proposals on triad nulls whose bias walks (steps at each move; a rate random walk) and on the
  independent scatter, the rate at which it names the walk, and how often it says a candidate cannot be told from
  the walk (small sessions of 16 rests unless ``--full-size``); with ``--power-ups``, two power-ups of one IMU and
  no step between them, each walking from the common turn-on bias (the step must not be proposed for the walk).
* ``walk-coverage [--draws 40] [--step 250] [--walk 20] [--workers 1]``: ±2σ coverage of the triad fit's planted
  power-up step, a zero step and the bias on two power-ups whose bias walks between rests (small sessions), against
  the binomial band of 0.954: whether the fit's σ carry the walk.
* ``step-walk [--draws 20] [--step 250] [--walk 20] [--workers 1]``: gyrojax's proposals on the same two power-ups
  (the step beside the walk): bias_turn_on proposed in n/N, what else, how often the proposal is marked
  indistinguishable, and after adding it the verdict and the step's ±2σ coverage.
* ``colour [--draws 30] [--planted-draws 10] [--workers 1]``: the rule that judges colour against input-following
  shapes (a hinge with a fitted knee, the linear temperature, the trend): gyrojax's rate of deterministic
  proposals on the turntable null with slow Gauss–Markov drift and a temperature cycle, from D_F…D_S and from
  D_F…D_S + bias_temperature (the hinge's own null); its rate of proposing the planted effect on the linear
  temperature in drift and on the two slopes (with bias_temperature in the model), and how often the hinge's fitted
  knee lies within 2σ of 20 °C. One diagnosis per draw, in bounded worker processes (a few draws each).

Run: python -m benchmarks.study_real_noise reference | power | baseline | nulls | walk-nulls | walk-coverage |
step-walk | colour [options]
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # the reference's small factorisations: threads only contend

import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

from tests import real_noise_cases as rc  # noqa: E402
from tests import reference_analysis as ra  # noqa: E402

TRIAD_NULLS = ("walk-steps", "walk-rrw", "pose-scatter", "power-up-null")


def _seeds(text):
    return [int(s) for s in text.split(",")]


def interval(k: int, n: int) -> str:
    """k/n with its Clopper–Pearson 95 % interval."""
    ci = stats.binomtest(k, n).proportion_ci(0.95)
    return f"{k}/{n} = {k / n:.3f} [{ci.low:.3f}, {ci.high:.3f}]"


def _fmt(x):
    if isinstance(x, float | np.floating):
        return f"{x:.3g}"
    if isinstance(x, dict):
        return "{" + ", ".join(f"{k}: {_fmt(v)}" for k, v in x.items()) + "}"
    if isinstance(x, list | tuple):
        return "[" + ", ".join(_fmt(v) for v in x) + "]"
    return str(x)


def reference(seeds) -> None:
    for name, case in rc.CASES.items():
        for seed in seeds:
            paths, _ = case.build(tempfile.mkdtemp(), seed)
            out = rc.reference(case, paths)
            print(f"## {name}, seed {seed}")
            for k, v in out.items():
                print(f"  {k}: {_fmt(v)}")


def _pw(p: float) -> str:
    return f"{p:.6f} ({1 - p:.1e})"


def power() -> None:
    print("power at the first Holm step at α = 0.01 (1 − power in brackets)")
    print("| case | planted | λ | power, family 27 | power, family 60 | beside | λ | power, family 60 |")
    print("|---|---|---|---|---|---|---|---|")
    for name, case in rc.CASES.items():
        if case.planted:
            paths, _ = case.build(tempfile.mkdtemp(), 1)
            p = rc.planted_power(case, paths)
            planted = ", ".join(f"{k} = {v:g}" for k, v in case.planted.items())
            row = f"| {name} | {planted} | {p['lambda']:.1f} | {_pw(p['power_F27'])} | {_pw(p['power_F60'])} |"
            if "rivals" in p:
                lam_r, pow_r = p["lambda_beside_rivals"], p["power_beside_rivals_F60"]
                row += f" {', '.join(p['rivals'])} | {lam_r:.1f} | {_pw(pow_r)} |"
            else:
                row += " — | | |"
            print(row)


def baseline(seeds, names) -> None:
    rows, right = [], {}
    for name in names:
        case = rc.CASES[name]
        for seed in seeds:
            paths, _ = case.build(tempfile.mkdtemp(), seed)
            t0 = time.time()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                chain = rc.gyrojax_loop(paths, case.terms)
            ok = rc.judged(case, chain)
            right.setdefault(seed, []).append(ok)
            steps = []
            for c in chain:
                est = f" {_fmt(c['estimate'])}" if c["estimate"] else ""
                extra = f", unexplained {', '.join(c['unexplained'])}" if c["unexplained"] else ""
                steps.append(
                    f"+{','.join(c['terms'][len(case.terms) :]) or '∅'}: {c['verdict']}, proposes {c['proposal']}"
                    f" (top {c['top']}{est}); noise {', '.join(c['noise']) or '—'}{extra}"
                )
            rows.append(f"| {name} | {seed} | {'right' if ok else '**miss**'} | {' → '.join(steps)} |")
            print(rows[-1], f"({time.time() - t0:.0f} s)", flush=True)
    print("\n| case | seed | answer | gyrojax's loop |\n|---|---|---|---|")
    print("\n".join(rows))
    for seed, oks in right.items():
        print(f"seed {seed}: {sum(oks)} of {len(oks)} right")


def _triad_null_rates(draws) -> None:
    for name in TRIAD_NULLS:
        case = rc.CASES[name]
        hits, trend_under_scatter = 0, 0
        for i in range(draws):
            recs, _ = case.build.records(10_000 + i)
            taken, _ = ra.triad_select(recs, rc.TRIAD_NOISE_DPS, case.noise)
            hits += bool(taken)
            if case.noise != "scatter":
                sc = ra.triad_reference(recs, rc.TRIAD_NOISE_DPS, "scatter")
                trend_under_scatter += min(sc.p_holm[f"bias_trend[{c}]"] for c in "xyz") < ra.ALPHA
        print(f"reference, {name} ({case.noise} at REML): any Holm-significant candidate {interval(hits, draws)}")
        if case.noise != "scatter":
            print(f"  under the independent scatter instead: a trend found {interval(trend_under_scatter, draws)}")


def _turntable_null_rate(draws) -> None:
    case = rc.CASES["slow-drift-null"]
    paths, _ = case.build(tempfile.mkdtemp(), 1)
    tt = ra.turntable(paths)
    v = ra.turntable_covariance(tt, rc.ARW, case.noise)
    chol = np.linalg.cholesky(v)
    wh = ra.whitener(v)
    model = list(case.terms)
    named = [n for n in ra.TURNTABLE_NAMED if n not in model]
    cand = {n: wh(ra.turntable_columns(tt, [n])) for n in named + list(ra.SHAPES)}
    x0w = wh(ra.turntable_columns(tt, model))
    rng = np.random.default_rng(7)
    hits, smallest = 0, []
    for _ in range(draws):
        yw = wh(chol @ rng.standard_normal(len(tt.y)))
        p = [ra.score_test(yw, x0w, h)[2] for h in cand.values()]
        adj = ra.holm(p)
        smallest.append(adj.min())
        hits += adj.min() < ra.ALPHA
    print(f"reference, slow-drift-null (V known): any Holm-significant candidate {interval(hits, draws)}")


def _gyrojax_null_rates(draws) -> None:
    for name in TRIAD_NULLS + ("slow-drift-null",):
        case = rc.CASES[name]
        proposals, named = 0, []
        t0 = time.time()
        for i in range(draws):
            paths, _ = case.build(tempfile.mkdtemp(), 20_000 + i)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                d = rc.gyrojax_json(paths, case.terms)
            if d.get("proposal"):
                proposals += 1
                named.append(d["proposal"])
        found = f" ({', '.join(sorted(set(named)))})" if named else ""
        rate = interval(proposals, draws)
        print(f"gyrojax, {name}: a deterministic proposal {rate}{found}, {time.time() - t0:.0f} s")


WALK_SMALL = {"poses": 16, "rest_s": 1.0, "move_s": 1.0, "rate_hz": 50.0}  # tests/test_real_noise.py's SMALL
WALKS = (("steps", rc.STEP_DPH), ("rrw", rc.STEP_DPH * np.sqrt(3600.0 / 2.2)), ("scatter", rc.STEP_DPH))


def _walk_draw(job):
    """One triad null with walking drift (in a worker; written by the writer and read as a user would): (drift, seed,
    proposal, named noise, a candidate marked indistinguishable from the walk)."""
    import gyrojax as gj
    from tests import independent_triad_writer as itw

    drift, size, seed, small, two = job
    kw = WALK_SMALL if small else {"rest_s": rc.REST_S, "move_s": rc.MOVE_S}
    if two:  # two power-ups with no step, each walking from the common turn-on bias
        kw = kw | {"poses": kw.get("poses", rc.POWER_UP_POSES), "gap_s": rc.POWER_UP_GAP_S}
        recs, _ = itw.power_up_records(seed, drift=drift, scatter_dph=size, **kw)
    else:
        recs, _ = itw.hand_session_records(seed, drift=drift, drift_size=size, **kw)
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = gj.diagnose(gj.load_records(itw.write(folder, recs)), itw.MODEL)
    drifting = any("bias_random_walk" in c.indistinguishable for c in d.candidates)
    return drift, seed, d.proposal, [c.name for c in d.noise_processes], drifting


def walk_nulls(draws, workers, small, drifts=None, power_ups=False) -> None:
    """gyrojax's deterministic proposals on triad nulls whose bias walks between rests (steps at each move, a rate
    random walk) and on the independent scatter, drawn in memory by the independent writer (with ``power_ups``: two
    power-ups of one IMU with no step between them, each walking from the common turn-on bias); bounded worker
    processes (a few draws each, then replaced)."""
    import multiprocessing as mp

    walks = [(d, size) for d, size in WALKS if drifts is None or d in drifts]
    jobs = [(drift, size, 30_000 + i, small, power_ups) for drift, size in walks for i in range(draws)]
    t0 = time.time()
    with mp.get_context("spawn").Pool(workers, maxtasksperchild=10) as pool:
        out = []
        for o in pool.imap_unordered(_walk_draw, jobs):
            out.append(o)
            if len(out) % 20 == 0:
                print(f"  {len(out)}/{len(jobs)} draws, {time.time() - t0:.0f} s", flush=True)
    what = "two power-ups of " if power_ups else ""
    print(f"{what}{'small' if small else 'full-size'} sessions, {draws} draws per drift, {time.time() - t0:.0f} s")
    for drift, _size in walks:
        rows = [o for o in out if o[0] == drift]
        props = [o[2] for o in rows if o[2]]
        walk = sum("bias_random_walk" in o[3] for o in rows)
        near = sum(o[4] for o in rows)
        found = f" ({', '.join(sorted(set(props)))})" if props else ""
        print(f"gyrojax, {drift}: a deterministic proposal {interval(len(props), len(rows))}{found}")
        print(f"  bias_random_walk named {interval(walk, len(rows))}; a candidate indistinguishable from it {near}")


WALK_COVERAGE = ("D_F_step_1[y]", "D_F_step_1[x]", "D_F[x]", "D_F[y]", "D_F[z]")
"""The coefficients whose ±2σ coverage the walk-coverage study counts: the planted power-up step, a zero step, and
the first power-up's bias."""


def _coverage_draw(job):
    """One fit of two power-ups whose bias walks, with a planted step (in a worker; written by the writer and read as a
    user would): ({coefficient: (estimate − truth) / σ}, the fit's bias walk or None)."""
    from gyrojax.data.records import load_records
    from gyrojax.inference.triad import fit_triad
    from tests import independent_triad_writer as itw

    seed, step, walk = job
    kw = WALK_SMALL | {"gap_s": rc.POWER_UP_GAP_S}
    recs, truth = itw.power_up_records(seed, step={"y": step}, drift="steps", scatter_dph=walk, **kw)
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_triad(load_records(itw.write(folder, recs)), itw.MODEL + ("bias_turn_on",))
    z = {n: (fit.values[n] - truth["coefficients"][n]) / fit.stds[n] for n in WALK_COVERAGE}
    return z, fit.variance_components.get("bias_walk_deg_per_h_per_sqrt_pose")


def walk_coverage(draws: int, step: float, walk: float, workers: int) -> None:
    """±2σ coverage of the triad fit's coefficients (:data:`WALK_COVERAGE`) on two power-ups of small sessions whose
    bias walks by ``walk`` deg/h at each move, the second's bias ``step`` deg/h higher on y: the σ are honest when
    the coverage lies within the binomial band of 0.954 (the fraction of a normal within ±2σ)."""
    import multiprocessing as mp

    t0 = time.time()
    jobs = [(40_000 + i, step, walk) for i in range(draws)]
    with mp.get_context("spawn").Pool(workers, maxtasksperchild=10) as pool:
        out = pool.map(_coverage_draw, jobs, chunksize=1)
    lo, hi = stats.binom.ppf(0.025, draws, 0.9545), stats.binom.ppf(0.975, draws, 0.9545)
    walks = [w for _, w in out if w]
    print(f"{draws} draws, step {step:g} deg/h on y, walk {walk:g} deg/h per move, {time.time() - t0:.0f} s")
    print(f"  the fit's σ carry a bias walk in {len(walks)}/{draws} (median {np.median(walks or [np.nan]):.3g})")
    print(f"  95 % binomial band of the count within ±2σ: [{lo:g}, {hi:g}] of {draws}")
    for n in WALK_COVERAGE:
        z = np.array([d[n] for d, _ in out])
        print(f"  {n}: within ±2σ {interval(int((abs(z) < 2).sum()), draws)}; rms z {np.sqrt(np.mean(z**2)):.2f}")


def _step_walk_draw(job):
    """One diagnosis of two power-ups whose bias walks, with a planted step on y (in a worker): (proposal, whether the
    proposed candidate is marked indistinguishable from another, the verdict after adding bias_turn_on where it was
    proposed, its step on y and σ)."""
    import gyrojax as gj
    from tests import independent_triad_writer as itw

    seed, step, walk = job
    kw = WALK_SMALL | {"gap_s": rc.POWER_UP_GAP_S}
    recs, _ = itw.power_up_records(seed, step={"y": step}, drift="steps", scatter_dph=walk, **kw)
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loaded = gj.load_records(itw.write(folder, recs))
        d = gj.diagnose(loaded, itw.MODEL)
        near = any(c.indistinguishable for c in d.candidates if d.proposal and c.name.split("[")[0] == d.proposal)
        after, est = None, None
        if d.proposal == "bias_turn_on":
            a = gj.diagnose(loaded, itw.MODEL + ("bias_turn_on",))
            after, est = a.verdict, (a.fit.values["D_F_step_1[y]"], a.fit.stds["D_F_step_1[y]"])
    return d.proposal, near, after, est


def step_walk(draws: int, step: float, walk: float, workers: int) -> None:
    """gyrojax's proposals on two power-ups whose bias walks by ``walk`` deg/h at each move, the second's bias
    ``step`` deg/h higher on y: how often bias_turn_on is proposed, what else is, how often the proposal is marked
    indistinguishable, and after adding it the verdict and the step's coverage within ±2σ."""
    import multiprocessing as mp

    t0 = time.time()
    jobs = [(40_000 + i, step, walk) for i in range(draws)]
    with mp.get_context("spawn").Pool(workers, maxtasksperchild=4) as pool:
        out = pool.map(_step_walk_draw, jobs, chunksize=1)
    right = [o for o in out if o[0] == "bias_turn_on"]
    other = sorted({str(o[0]) for o in out if o[0] != "bias_turn_on"})
    print(f"{draws} draws, step {step:g} deg/h on y, walk {walk:g} deg/h per move, {time.time() - t0:.0f} s")
    print(f"  bias_turn_on proposed {interval(len(right), draws)}; otherwise {other}")
    print(f"  the proposal marked indistinguishable: {sum(o[1] for o in out)}/{draws}")
    if right:
        adequate = sum(o[2] == "adequate" for o in right)
        inside = sum(abs(v - step) < 2 * sd for *_x, (v, sd) in right)
        print(f"  after adding it: adequate {adequate}/{len(right)}; step within ±2σ {interval(inside, len(right))}")


def nulls(draws, with_gyrojax) -> None:
    t0 = time.time()
    _triad_null_rates(draws)
    _turntable_null_rate(draws)
    print(f"reference: {time.time() - t0:.0f} s")
    if with_gyrojax:
        _gyrojax_null_rates(draws)


COLOUR_CASES = (
    ("slow-drift-null", (), None),
    ("slow-drift-null", ("bias_temperature",), None),
    ("linear-temperature-in-drift", (), "bias_temperature"),
    ("two-slope-temperature", ("bias_temperature",), "temperature_hinge"),
)
"""(case, terms added to its model, the effect a diagnosis should propose: None for a null)."""


def _colour_draw(job):
    """One diagnosis of one drawn campaign (a worker's task): (proposal, the knee's value and σ when the proposal
    is the hinge)."""
    name, extra, seed = job
    case = rc.CASES[name]
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        paths, _ = case.build(Path(tmp), seed)
        d = rc.gyrojax_json(paths, tuple(case.terms) + tuple(extra))
    knee = None
    if d.get("proposal") == "temperature_hinge":
        c = next(c for c in d["candidates"] if c["name"] == "temperature_hinge")
        knee = (c["estimate"]["T_KNEE"]["value"], c["estimate"]["T_KNEE"].get("std"))
    return d.get("proposal"), knee


def colour(draws: int, planted_draws: int, workers: int) -> None:
    import multiprocessing as mp

    ctx = mp.get_context("spawn")
    for name, extra, want in COLOUR_CASES:
        n = draws if want is None else planted_draws
        if n == 0:
            continue
        jobs = [(name, extra, 30_000 + i) for i in range(n)]
        t0 = time.time()
        with ctx.Pool(workers, maxtasksperchild=4) as pool:
            out = pool.map(_colour_draw, jobs, chunksize=1)
        props = [p for p, _ in out]
        label = f"{name} from {', '.join(rc.CASES[name].terms + extra)}"
        if want is None:
            k = sum(p is not None for p in props)
            found = sorted({p for p in props if p})
            rate = interval(k, n)
            print(f"{label}: a deterministic proposal {rate} {found or ''}, {time.time() - t0:.0f} s", flush=True)
        else:
            k = sum(p == want for p in props)
            print(f"{label}: {want} proposed {interval(k, n)}, {time.time() - t0:.0f} s", flush=True)
            knees = [kn for _, kn in out if kn is not None and kn[1]]
            if knees:
                inside = sum(abs(v - 20.0) < 2 * sd for v, sd in knees)
                print(f"  knee within 2σ of 20 °C: {interval(inside, len(knees))}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.study_real_noise", description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("reference")
    r.add_argument("--seeds", type=_seeds, default=[1, 2])
    sub.add_parser("power")
    b = sub.add_parser("baseline")
    b.add_argument("--seeds", type=_seeds, default=[1, 2, 3, 4])
    b.add_argument("--cases", type=lambda s: s.split(","), default=list(rc.CASES))
    n = sub.add_parser("nulls")
    n.add_argument("--draws", type=int, default=200)
    n.add_argument("--gyrojax", action="store_true", help="also gyrojax's proposal rate (slow: a diagnosis a draw)")
    w = sub.add_parser("walk-nulls")
    w.add_argument("--draws", type=int, default=100)
    w.add_argument("--workers", type=int, default=1)
    w.add_argument("--full-size", action="store_true", help="the cases' own rests and moves (slower)")
    w.add_argument("--drifts", type=lambda s: s.split(","), default=None, help="steps,rrw,scatter (default: all)")
    w.add_argument("--power-ups", action="store_true", help="two power-ups of one IMU, no step between them")
    v = sub.add_parser("walk-coverage")
    v.add_argument("--draws", type=int, default=40)
    v.add_argument("--step", type=float, default=250.0, help="deg/h, the second power-up's bias step on y")
    v.add_argument("--walk", type=float, default=20.0, help="deg/h, the bias step at each move")
    v.add_argument("--workers", type=int, default=1)
    sw = sub.add_parser("step-walk")
    sw.add_argument("--draws", type=int, default=20)
    sw.add_argument("--step", type=float, default=250.0, help="deg/h, the second power-up's bias step on y")
    sw.add_argument("--walk", type=float, default=20.0, help="deg/h, the bias step at each move")
    sw.add_argument("--workers", type=int, default=1)
    c = sub.add_parser("colour")
    c.add_argument("--draws", type=int, default=30, help="draws of each null")
    c.add_argument("--planted-draws", type=int, default=10, help="draws of each planted case")
    c.add_argument("--workers", type=int, default=1)
    args = ap.parse_args(argv)
    if args.cmd == "reference":
        reference(args.seeds)
    elif args.cmd == "power":
        power()
    elif args.cmd == "baseline":
        baseline(args.seeds, args.cases)
    elif args.cmd == "walk-nulls":
        walk_nulls(args.draws, args.workers, not args.full_size, args.drifts, args.power_ups)
    elif args.cmd == "walk-coverage":
        walk_coverage(args.draws, args.step, args.walk, args.workers)
    elif args.cmd == "step-walk":
        step_walk(args.draws, args.step, args.walk, args.workers)
    elif args.cmd == "colour":
        colour(args.draws, args.planted_draws, args.workers)
    else:
        nulls(args.draws, args.gyrojax)


if __name__ == "__main__":
    main()
