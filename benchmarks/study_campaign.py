"""Monte Carlo study of the campaign loop (:mod:`gyrojax.adaptive`) on simulated laboratories with hidden effects.

``python -m benchmarks.study_campaign [--kind sdf] [--truths 50] [--seed 0] [--out study_campaign.json]
[--per-process 5]`` (worker processes of a few truths each, resumable from ``--out``); ``--only 10,16`` runs the
chosen truths alone

Each truth is an SDF gyro whose lab knows D_F, D_I, D_S (each drawn uniformly in ±[0.1, 1] deg/h or deg/h/g) and
whose truth holds two effects hidden from the lab's first test, a single-mount polar tumble (2 revolutions at 20
Earth rates, OA along the polar axis, 30 s samples; 2.4 table hours):

* one **aliased** under it: D_SS or D_II (a_I² + a_S² is constant when OA lies along the table axis), and
* one **not excited** by it: D_O, D_IO or D_OS (a_O is constant: they read as D_F, D_I, D_S),

each of size log-uniform in [10, 100] × the target σ with a random sign (plausible: Hu's floated gyros have
anisoelastic terms to ~0.1 deg/h/g², unbalances to ~1 deg/h/g; far below the plausibility limits), with white noise
N = 0.005 deg/√h. The goal is σ ≤ 0.003 (in each coefficient's unit) for every coefficient of the final model,
with a campaign-wide false-effect rate α = 0.05. Every coefficient starts far from its target (D_F's σ is ~10× it
after the first test). The loop designs its tests on a two-axis table (trunnion East, platform Up), one mounting,
12 positions, at most 8 h a test and 100 h in all, sampled every 30 s as the first test (coarse samples keep each
step cheap; white-noise information depends on the time, not the interval).

Per truth: whether the goal was met, the loop's table hours and those of Hu's classical sequence scaled to the same
σ on the same truth (:mod:`gyrojax.adaptive.classical`), effects added that the truth does not hold (false
effects), true effects missed, and whether θ̂ ± 2σ covers the truth for every coefficient of the final model.
Beside it, the fewest table hours any campaign from the same first test needs to meet the requirements of the loop's
last look — the final model's σ and ruling out the watched candidates at the sizes that matter
(:mod:`gyrojax.adaptive.bound`): where that bound is above 1/3 of the classical hours, 1/3 cannot be reached by any
design. The ratio is summarised overall, per truth class (the two hidden effects) and over the truths where 1/3 is
possible. Prints the summary and writes every truth's row to ``--out``.

``--kind`` runs the same study on the loop's other instruments and tables (:data:`KINDS`), each truth with one
effect its first test does not see:

* ``sdf-one-axis``: the SDF study above, its tests designed on the first test's one-axis polar table with the case
  turned on its faces (two mountings a test) instead of the two-axis table;
* ``servo``: an SDF gyro whose first test is a 2 h polar servo run (IA along the servo axis: a_I = g·sin φ is
  constant, so D_F and D_I read as one), hidden D_O, D_II or D_IS; tests on the two-axis table, σ ≤ 0.01;
* ``tdf``: a TDF gyro whose lab knows DX_F, DY_F, DX_X, DX_Y, DY_X, DY_Y, first tested in Hu's eight positions
  (10 min each, 30 s samples): every a of them lies along one case axis, so one cross term (DX_XY … DY_YZ) is
  hidden; tests on the two-axis table, σ ≤ 0.01;
* ``accel``: a pendulous accelerometer whose lab knows K_0, K_1, K_2 (K_1 within 10⁻³ of 1), first tested on the
  dividing head with its output axis along the head axis (36 positions of 60 s, 10 s samples: a_O = 0), hidden K_IO;
  noise 3·10⁻⁷ g·√h (60·N/√Δt ≈ 6 μg a sample), σ ≤ 2·10⁻⁶ in each coefficient's unit; tests on the dividing head
  with the case turned.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

BASE = ("D_F", "D_I", "D_S")
ALIASED = ("D_SS", "D_II")
UNEXCITED = ("D_O", "D_IO", "D_OS")
TARGET = 0.003
WHITE = 0.005


TDF_BASE = ("DX_F", "DY_F", "DX_X", "DX_Y", "DY_X", "DY_Y")
TDF_CROSS = tuple(f"D{c}_{t}" for c in "XY" for t in ("XY", "XZ", "YZ"))
ACCEL_BASE = ("K_0", "K_1", "K_2")


def _signed(rng, lo, hi) -> float:
    return float(rng.choice([-1, 1]) * rng.uniform(lo, hi))


def _hidden(rng, target) -> float:
    return float(rng.choice([-1, 1]) * target * 10 ** rng.uniform(1.0, 2.0))


def _sdf(rng, target, groups) -> dict:
    coeffs = {c: _signed(rng, 0.1, 1.0) for c in BASE}
    for group in groups:
        name = str(rng.choice(group))  # drawn before its size: the truths of a seed stay those of earlier studies
        coeffs[name] = _hidden(rng, target)
    return {"coefficients": coeffs, "noise": {"white": WHITE}}


def _tdf(rng, target) -> dict:
    coeffs = {c: _signed(rng, 0.1, 1.0) for c in TDF_BASE}
    name = str(rng.choice(TDF_CROSS))
    coeffs[name] = _hidden(rng, target)
    return {"coefficients": coeffs, "noise": {"white": WHITE}}


def _accel(rng, target) -> dict:
    coeffs = {"K_0": _signed(rng, 1e-4, 1e-3), "K_1": 1.0 + _signed(rng, 1e-5, 1e-3), "K_2": _signed(rng, 1e-5, 1e-4)}
    coeffs["K_IO"] = _hidden(rng, target)
    return {"coefficients": coeffs, "noise": {"white": 3e-7}}


def _plans():
    from gyrojax.data import plans

    return plans


TWO_AXIS_ONE_MOUNT = {"turn_case": False, "mountings_per_test": 1}
KINDS = {
    # name: (truth drawer, first test, the lab's model, target σ, lab options beyond the first test's table)
    "sdf": (
        lambda rng: _sdf(rng, TARGET, (ALIASED, UNEXCITED)),
        lambda p: p.tumble(revolutions=2.0, earth_rates=20.0, dt_s=30.0, flip=False, both_directions=False),
        BASE,
        TARGET,
        lambda p: {"axes": p.TWO_AXIS, **TWO_AXIS_ONE_MOUNT},
    ),
    "sdf-one-axis": (
        lambda rng: _sdf(rng, TARGET, (ALIASED, UNEXCITED)),
        lambda p: p.tumble(revolutions=2.0, earth_rates=20.0, dt_s=30.0, flip=False, both_directions=False),
        BASE,
        TARGET,
        lambda p: {"turn_case": True, "mountings_per_test": 2},
    ),
    "servo": (
        lambda rng: _sdf(rng, 0.01, (("D_O", "D_II", "D_IS"),)),
        lambda p: p.servo("polar", hours=2.0, dt_s=30.0),
        BASE,
        0.01,
        lambda p: {"axes": p.TWO_AXIS, **TWO_AXIS_ONE_MOUNT},
    ),
    "tdf": (
        lambda rng: _tdf(rng, 0.01),
        lambda p: p.eight_position(10.0, dt_s=30.0, kind="tdf-gyro"),
        TDF_BASE,
        0.01,
        lambda p: {"axes": p.TWO_AXIS, **TWO_AXIS_ONE_MOUNT},
    ),
    "accel": (
        lambda rng: _accel(rng, 2e-6),
        lambda p: p.accel_tumble(36, 60.0, 10.0),
        ACCEL_BASE,
        2e-6,
        lambda p: {"turn_case": True, "mountings_per_test": 1},
    ),
}
"""The study's laboratories (module doc)."""


def draw_truth(rng, kind: str = "sdf") -> dict:
    """One truth (conventions §8 dict) of the study of ``kind`` (module doc)."""
    return KINDS[kind][0](rng)


def first_test(kind: str = "sdf"):
    """The lab's first test of ``kind`` (module doc)."""
    return KINDS[kind][1](_plans())


def one(truth: dict, seed: int, kind: str = "sdf") -> dict:
    """Run one campaign of ``kind`` and score it."""
    from gyrojax.adaptive.goal import Goal
    from gyrojax.adaptive.simulated import run_campaign

    _, _, base, target, lab = KINDS[kind]
    t0 = time.perf_counter()
    res = run_campaign(
        truth,
        first_test(kind),
        list(base),
        Goal(sigma=target),
        seed=seed,
        lab_options=lab(_plans()),
    )
    wall = time.perf_counter() - t0
    true = set(truth["coefficients"])
    terms = set(res.last.terms)
    fit = res.last.fit
    covered, z = {}, {}
    if fit is not None:
        for c in fit.coefficient_names:
            v, s = fit.values[c], fit.stds[c]
            t = truth["coefficients"].get(c, 0.0)
            covered[c] = bool(abs(v - t) <= 2.0 * s)
            z[c] = (v - t) / s
    added = sorted(terms - set(base))
    cl = res.classical
    return {
        "seed": seed,
        "truth": truth["coefficients"],
        "goal_met": res.goal_met,
        "status": res.status,
        "reason": res.reason if not res.goal_met else "",
        "tests": len(res.steps),
        "table_hours": res.table_hours,
        "classical_hours": cl.hours if cl else None,
        "classical_best_split_hours": cl.best_split_hours if cl else None,
        "ratio": res.table_hours / cl.hours if cl and cl.hours else None,
        "bound": res.hours_bound(),
        "class": "+".join(c for c in truth["coefficients"] if c not in base),
        "terms": sorted(terms),
        "added": added,
        "false_effects": sorted(terms - true),
        "missed_effects": sorted(true - terms),
        "covered": covered,
        "z": z,
        "sigma_over_target": {c: fit.stds[c] / target for c in fit.coefficient_names} if fit else {},
        "looks": res.last.looks,
        "wall_s": wall,
        "steps": [{"plan": s.plan.name, "hours": s.hours, "reason": s.reason[:300]} for s in res.steps],
    }


def summary(rows: list) -> dict:
    """The study's numbers: goal reached, hours ratio (median, quartiles, range), false effects, coverage."""
    from scipy import stats

    n = len(rows)
    met = [r for r in rows if r["goal_met"]]
    ratios = np.array([r["ratio"] for r in met if r["ratio"] is not None])
    false = sum(1 for r in rows if r["false_effects"])
    cov = [v for r in met for v in r["covered"].values()]
    k = int(sum(cov))

    def ci(k, n):
        if n == 0:
            return (math.nan, math.nan)
        lo = stats.beta.ppf(0.025, k, n - k + 1) if k else 0.0
        hi = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
        return (float(lo), float(hi))

    def spread(x):
        x = np.asarray(x, dtype=float)
        if not x.size:
            return None
        return {
            "n": int(x.size),
            "median": float(np.median(x)),
            "q25": float(np.percentile(x, 25)),
            "q75": float(np.percentile(x, 75)),
            "min": float(x.min()),
            "max": float(x.max()),
            "share_at_most_one_third": float(np.mean(x <= 1 / 3)),
        }

    bounded = [r for r in met if r.get("bound") and r["bound"].get("ratio_lower") is not None]
    by_class = {}
    for cls in sorted({r.get("class", "") for r in met}):
        rs = [r for r in met if r.get("class", "") == cls and r["ratio"] is not None]
        lows = [r["bound"]["ratio_lower"] for r in rs if r in bounded]
        by_class[cls] = {
            "ratio": spread([r["ratio"] for r in rs]),
            "ratio_lower_bound": spread(lows),
            "one_third_impossible": sum(1 for x in lows if x > 1 / 3),
            "loop_over_its_bound_median": float(
                np.median([r["table_hours"] / r["bound"]["table_hours_lower"] for r in rs if r in bounded])
            )
            if lows
            else None,
        }
    possible = [r["ratio"] for r in bounded if r["bound"]["ratio_lower"] <= 1 / 3 and r["ratio"] is not None]
    return {
        "truths": n,
        "goal_met": len(met),
        "by_class": by_class,
        "one_third_impossible": sum(1 for r in bounded if r["bound"]["ratio_lower"] > 1 / 3),
        "ratio_where_one_third_possible": spread(possible),
        "loop_over_bound_median": float(
            np.median([r["table_hours"] / r["bound"]["table_hours_lower"] for r in bounded])
        )
        if bounded
        else None,
        "not_met": [
            {"seed": r["seed"], "status": r["status"], "reason": r["reason"][:300]} for r in rows if not r["goal_met"]
        ],
        "hours_ratio": {
            "median": float(np.median(ratios)) if ratios.size else None,
            "q25": float(np.percentile(ratios, 25)) if ratios.size else None,
            "q75": float(np.percentile(ratios, 75)) if ratios.size else None,
            "min": float(ratios.min()) if ratios.size else None,
            "max": float(ratios.max()) if ratios.size else None,
            "mean": float(ratios.mean()) if ratios.size else None,
            "share_at_most_one_third": float(np.mean(ratios <= 1 / 3)) if ratios.size else None,
        },
        "loop_hours_median": float(np.median([r["table_hours"] for r in met])) if met else None,
        "classical_hours_median": float(np.median([r["classical_hours"] for r in met if r["classical_hours"]]))
        if met
        else None,
        "ratio_to_best_split_median": float(
            np.median(
                [r["table_hours"] / r["classical_best_split_hours"] for r in met if r["classical_best_split_hours"]]
            )
        )
        if met
        else None,
        "tests_median": float(np.median([r["tests"] for r in rows])),
        "false_effect_campaigns": false,
        "false_effect_rate": false / n,
        "false_effect_rate_ci95": ci(false, n),
        "missed_effect_campaigns": sum(1 for r in rows if r["missed_effects"]),
        "coverage_2sigma": k / len(cov) if cov else None,
        "coverage_ci95": ci(k, len(cov)),
        "coefficients_scored": len(cov),
        "wall_s_total": float(sum(r["wall_s"] for r in rows)),
        "wall_s_median": float(np.median([r["wall_s"] for r in rows])),
    }


def _load(path) -> list:
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)["rows"]
    except (OSError, ValueError, KeyError):
        return []


def _save(path, rows, extra=None) -> None:
    s = summary(rows)
    s.update(extra or {})
    tmp = f"{path}.tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump({"rows": rows, "summary": s}, f, indent=1)
    import os

    os.replace(tmp, path)


def worker(args) -> int:
    """Run the next ``--per-process`` truths not yet in ``--out`` (truth i drawn from the seed sequence (seed, i),
    so a study split over processes draws the same truths)."""
    import warnings

    from gyrojax.errors import ConvergenceWarning

    warnings.simplefilter("ignore", ConvergenceWarning)
    rows = _load(args.out)
    chosen = args.only if args.only is not None else range(len(rows), min(args.truths, len(rows) + args.per_process))
    for i in chosen:
        truth = draw_truth(np.random.default_rng([args.seed, i]), args.kind)
        row = one(truth, args.seed * 1000 + i, args.kind)
        rows.append(row)
        print(
            f"{i + 1:3d}/{args.truths}  met={row['goal_met']!s:5s} tests={row['tests']} "
            f"loop={row['table_hours']:6.1f} h "
            f"classical={row['classical_hours'] or math.nan:6.1f} h ratio={row['ratio'] or math.nan:5.2f} "
            f"(≥ {(row['bound'] or {}).get('ratio_lower') or math.nan:4.2f}) "
            f"false={row['false_effects']} missed={row['missed_effects']} "
            f"covered={sum(row['covered'].values())}/{len(row['covered'])} ({row['wall_s']:.0f} s)",
            flush=True,
        )
        _save(args.out, rows)
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kind", default="sdf", choices=sorted(KINDS), help="the laboratory (module doc)")
    ap.add_argument("--truths", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="study_campaign.json")
    ap.add_argument("--per-process", type=int, default=5, help="truths per worker process (bounds its memory)")
    ap.add_argument(
        "--only",
        type=lambda v: [int(x) for x in v.split(",")],
        help="run only these truths (comma-separated indices, in this process; rows appended to --out)",
    )
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker or args.only is not None:
        return worker(args)
    import subprocess
    import sys

    # worker processes of a few truths each: a process that compiles for every new record length grows; the
    # persistent compilation cache carries the compiled code from one worker to the next; a study stopped part-way
    # resumes from --out
    t0 = time.perf_counter()
    while len(_load(args.out)) < args.truths:
        before = len(_load(args.out))
        cmd = [sys.executable, "-m", "benchmarks.study_campaign", "--worker", "--truths", str(args.truths)]
        cmd += ["--seed", str(args.seed), "--out", args.out, "--per-process", str(args.per_process)]
        cmd += ["--kind", args.kind]
        subprocess.run(cmd, check=False)
        if len(_load(args.out)) == before:
            print("a worker made no progress; stopping", file=sys.stderr)
            return 1
    rows = _load(args.out)
    _save(args.out, rows, {"wall_s_this_run": time.perf_counter() - t0})
    with open(args.out, encoding="utf-8") as f:
        print(json.dumps(json.load(f)["summary"], indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
