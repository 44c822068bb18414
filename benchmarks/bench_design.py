"""Optimal design benchmark: time to design a 24-position plan, designed vs classical plans, Monte Carlo check.

Run: ``python -m benchmarks.bench_design`` (add ``--quick`` for fewer Monte Carlo draws).
"""

from __future__ import annotations

import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.timing import compile_here
from gyrojax.data import plans
from gyrojax.inference.campaign import Campaign, linearize
from gyrojax.noise.processes import random_drift
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics.model import Model
from gyrojax.planning import baselines, criteria, fisher
from gyrojax.planning import optimal as D
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
        D.figure(rows, path)
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


if __name__ == "__main__":
    compile_here()
    res = timing_24()
    comparison(res)
    detect()
    monte_carlo(res, 200 if "--quick" in sys.argv else 1000)
