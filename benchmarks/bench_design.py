"""Optimal design benchmark: time to design a 24-position plan, designed vs classical plans, Monte Carlo check; and
the hand protocol of an IMU triad as a user waits for it.

Run: ``python -m benchmarks.bench_design`` (add ``--quick`` for fewer Monte Carlo draws).

``python -m benchmarks.bench_design --triad [--baseline-dir DIR] [--repeat N]``: ``gyrojax design --instrument
imu-triad --poses 12 --minutes 10 --arw 1.2`` as a process, this checkout beside the one in DIR (e.g. the previous
commit, ``git worktree add /tmp/old HEAD~1``; each with its own ``.venv`` when it has one, the versions of its
lock) run alternately in the same run: cold (compilation cache off) and warm (a fresh cache filled by the run
before), wall and CPU seconds, compile ≈ cold − warm; then the designs' predicted σ of every coefficient, each
beside Ferraris' and imu_tk's protocols as the command prints them.
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.timing import compile_here, python_of, run_process
from gyrojax.data import plans
from gyrojax.inference.campaign import Campaign, linearize
from gyrojax.noise.processes import random_drift
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics.model import Model
from gyrojax.planning import baselines, criteria, fisher
from gyrojax.planning import optimal as D
from gyrojax.report import figures
from gyrojax.simulation.simulator import simulate

ARW = 0.01
NOISE = NoiseSpec(white=ARW)
HOURS = 4.0
SDF6 = ("D_F", "D_I", "D_O", "D_S", "D_II", "D_IS")


def timing_24():
    print("== time to design a 24-position D-optimal plan (9-term SDF model, 8 starts, 600 Adam + 40 L-BFGS) ==")
    res = D.design(D.SDF9, 24, HOURS, "D", noise=NOISE)
    print(
        f"compile {res.timing['compile_s']:.1f} s, run {res.timing['run_s']:.2f} s, loss {res.loss:.6f}, "
        f"|grad| {res.grad_norm:.1e}"
    )
    print("start losses:", " ".join(f"{v:.4f}" for v in res.start_losses))
    h = res.history
    print("history (every 60th):", " ".join(f"{v:.4f}" for v in h[::60]), f"... {h[-1]:.6f}")
    t = time.perf_counter()
    D.design(D.SDF9, 24, HOURS, "D", noise=NOISE, seed=5)
    print(f"second design (compiled optimiser reused): {time.perf_counter() - t:.2f} s")
    return res


def comparison(res24):
    for terms, counts in ((SDF6, (8,)), (D.SDF9, (16, 24))):
        designed = {}
        for n in counts:
            r = res24 if (n == 24 and terms == D.SDF9) else D.design(terms, n, HOURS, "D", noise=NOISE)
            designed[f"designed-{n} (D)"] = r
        if terms == SDF6:  # a free-orientation fixture (E-N-U Euler chain) instead of the two-axis table
            designed["designed-8 fixture (D)"] = D.design(
                terms, 8, HOURS, "D", noise=NOISE, table=fisher.Table.fixture()
            )
        print(
            f"\n== {', '.join(terms)}: {HOURS} h of data each (white noise N = {ARW} deg/√h); "
            "Cramér–Rao std per coefficient =="
        )
        rows = baselines.compare(terms, HOURS, NOISE, designed)
        print(baselines.table_text(rows))
        path = f"/tmp/bench_design_{len(terms)}terms.png"
        figures.save(figures.design_figure(rows), path)
        print(f"figure: {path}")


def monte_carlo(res, draws=1000):
    print(f"\n== Monte Carlo: {draws} gyros on the designed 24-position plan (dt 10 s), linear LS ==")
    m9 = Model.of(D.SDF9)
    plan = plans.with_dt(res.plan(), 10.0)
    truth = {"coefficients": {"D_F": 1.0, "D_I": 0.3, "D_SS": 0.05}, "noise": {"white": ARW}}
    rec = simulate(plan, truth, seed=0)[0]
    camp = Campaign.of([rec])
    ((r, j, _, _),) = linearize(m9, np.zeros(m9.size), camp)
    t = np.asarray(rec.time_s)
    r0 = r - np.asarray(random_drift(jax.random.fold_in(jax.random.PRNGKey(0), 0), t, {"white": ARW}))
    keys = jax.random.split(jax.random.PRNGKey(11), draws)
    noise = np.asarray(jax.vmap(lambda k: random_drift(k, t, {"white": ARW}))(keys))
    theta = np.linalg.lstsq(j, (r0[None, :] + noise).T, rcond=None)[0]
    emp = theta.std(axis=1, ddof=1)
    seg = plan.runs[0].segments
    f = fisher.static_fisher(
        m9,
        res.table,
        jnp.deg2rad(jnp.asarray([s.start_deg for s in seg])),
        jnp.asarray([s.duration_s for s in seg]),
        NOISE,
        10.0,
    )
    pred = np.sqrt(np.diag(np.linalg.inv(np.asarray(f))))
    print(f"{'coef':6s} {'predicted':>10s} {'MC':>10s} {'ratio':>7s}   (1σ of the ratio: {1 / np.sqrt(2 * draws):.3f})")
    for c, p, e in zip(m9.coefficient_names, pred, emp):
        print(f"{c:6s} {p:10.4e} {e:10.4e} {e / p:7.3f}")


def detect():
    print("\n== detectability: score-test noncentrality of an omitted scale-factor error (E_SF = 1000 ppm) ==")
    m9 = Model.of(D.SDF9)
    rd = D.design(m9, 24, HOURS, "D", noise=NOISE)
    rs = D.design(m9, 24, HOURS, "detect:sf_error=1000", noise=NOISE)
    crit = criteria.Criterion.parse("detect:sf_error=1000", m9)
    for name, r in (("D-optimal", rd), ("detect:sf_error", rs)):
        lam = criteria.detect_noncentrality(m9, crit, r.table, np.deg2rad(r.angles_deg), r.dwell_s, NOISE)
        print(
            f"{name:18s} λ = {lam:8.2f}  power(1 %) = {criteria.detect_power(lam):.3f}  "
            f"D = {criteria.criterion_values(r.fisher, m9)['D']:.3f}"
        )
    try:
        D.design(m9, 24, HOURS, "detect:D_OO", noise=NOISE)
    except Exception as e:  # D_OO is aliased in every static 1-g plan
        print("detect:D_OO ->", e)


TRIAD_COMMAND = ("design", "--instrument", "imu-triad", "--poses", "12", "--minutes", "10", "--arw", "1.2")
"""The command of the speed issue's first row (the CLI's defaults: 8 starts, 600 Adam steps)."""


def triad_process(root: Path, out: Path, cache: Path | None) -> tuple[float, float, dict]:
    """(wall s, CPU s, the printed JSON) of one ``gyrojax design --instrument imu-triad`` process of the checkout
    ``root`` (run in ``out``'s folder, so that no other checkout shadows it on ``sys.path``): compilation cache off
    (``cache`` None) or in ``cache``."""
    env = {k: v for k, v in os.environ.items() if k not in ("GYROJAX_NO_CACHE", "GYROJAX_CACHE_DIR")}
    env["PYTHONPATH"] = str(root)
    if cache is None:
        env["GYROJAX_NO_CACHE"] = "1"
    else:
        env["GYROJAX_CACHE_DIR"] = str(cache)
    cmd = [python_of(root), "-m", "gyrojax", *TRIAD_COMMAND, "--out", str(out), "--force", "--json"]
    wall, cpu, stdout = run_process(cmd, env=env, cwd=out.parent)
    return wall, cpu, json.loads(stdout)


def triad_row(baseline: Path | None, repeat: int) -> None:
    """The triad design's wait, this checkout against ``baseline`` (module doc), and the designs' quality."""
    here = Path(__file__).resolve().parents[1]
    roots = {"new": here} | ({"old": baseline.resolve()} if baseline else {})
    print(f"== gyrojax {' '.join(TRIAD_COMMAND)}: process wall / CPU s (load {os.getloadavg()[0]:.1f}) ==")
    times = {k: {"cold": [], "warm": []} for k in roots}
    docs = {}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeat):
            for name, root in roots.items():  # alternately, so that the machine's load falls on both alike
                out = Path(tmp) / f"{name}.json"
                times[name]["cold"].append(triad_process(root, out, None)[:2])
                cache = Path(tmp) / f"cache-{name}-{i}"
                triad_process(root, out, cache)  # fills the cache
                wall, cpu, docs[name] = triad_process(root, out, cache)
                times[name]["warm"].append((wall, cpu))
    best = {k: {m: min(v, key=lambda t: t[1]) for m, v in d.items()} for k, d in times.items()}
    for name, b in best.items():
        cold, warm = b["cold"], b["warm"]
        print(
            f"{name}: cold {cold[0]:6.1f} s wall {cold[1]:6.1f} s CPU; warm {warm[0]:6.1f} s wall "
            f"{warm[1]:6.1f} s CPU; compile ≈ {cold[1] - warm[1]:.1f} s CPU (best of {repeat}, by CPU)"
        )
    if "old" in best:
        for mode in ("cold", "warm"):
            n, o = best["new"][mode], best["old"][mode]
            print(f"new / old, {mode}: wall {n[0] / o[0]:.3f}, CPU {n[1] / o[1]:.3f}")
    for name, doc in docs.items():
        rows = doc["comparison"]
        sig = [r["sigma"] for r in rows]
        p = len(sig[0])
        ratios = [math.exp((r["criterion"] - rows[0]["criterion"]) / (2 * p)) for r in rows]
        print(
            f"{name}: D criterion designed {rows[0]['criterion']:.4f}, Ferraris {rows[1]['criterion']:.4f}, imu_tk "
            f"{rows[2]['criterion']:.4f}; geometric-mean σ ratio baseline/designed {ratios[1]:.3f}, {ratios[2]:.3f}; "
            f"search converged {doc['search']['converged']}"
        )
    if "old" in docs:
        new, old = docs["new"]["comparison"][0]["sigma"], docs["old"]["comparison"][0]["sigma"]
        worse = {k: round(new[k] / old[k], 4) for k in new if new[k] > old[k]}
        ratio = [new[k] / old[k] for k in new]
        print(
            f"designed σ new / old per coefficient: {min(ratio):.3f} … {max(ratio):.3f}, geometric mean "
            f"{math.exp(np.mean(np.log(ratio))):.4f}; larger for {worse or 'none'}"
        )


if __name__ == "__main__":
    if "--triad" in sys.argv:
        args = sys.argv[sys.argv.index("--triad") + 1 :]
        base = Path(args[args.index("--baseline-dir") + 1]) if "--baseline-dir" in args else None
        triad_row(base, int(args[args.index("--repeat") + 1]) if "--repeat" in args else 1)
        sys.exit(0)
    compile_here()
    res = timing_24()
    comparison(res)
    detect()
    monte_carlo(res, 200 if "--quick" in sys.argv else 1000)
