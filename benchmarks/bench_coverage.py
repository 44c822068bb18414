"""Identification coverage study: is (θ̂ − θ)/σ̂ standard normal for the classical plans?

For each plan, ≥ 500 simulated gyros (coefficients from N(0, 0.5²) in report units) are fitted with the effects the
plan can separate (alias groups of the noise-free regressors reduced greedily, :func:`identifiable_terms`; the
24-position plan uses the 9-term model, D_OO dropped). Printed per coefficient: mean of (θ̂ − θ)/σ̂ and the fraction
of draws with |θ̂ − θ| ≤ 2σ̂ (0.9545 for an honest σ̂; binomial sd √(0.9545·0.0455/n)).

Noises: white; white + Gauss–Markov with τ = 60 s; white + Gauss–Markov with τ = 300 s (as slow as a position, so
seen mostly in the scatter of the position means). Two fits on each:

* the fast JAX path (:mod:`gyrojax.montecarlo`, white least squares; its σ̂ is honest under white noise only);
* the GLS fit of :func:`gyrojax.inference.identify.fit` (white + Gauss–Markov / AR noise model by REML, pooled over the
  campaign's records), with the draws written as records (servo plans: simulated by
  :func:`gyrojax.simulation.simulator.simulate` with the draw's truth).

    python -m benchmarks.bench_coverage [--draws 500] [--gls-draws 500] [--plans 8-position,tumble] [--noises gm300]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from gyrojax.data import plans
from gyrojax.inference import identify
from gyrojax.montecarlo import pipeline, runner
from gyrojax.montecarlo import study as mc
from gyrojax.simulation.simulator import simulate

CANDIDATES = ["D_F", "D_I", "D_O", "D_S", "D_II", "D_SS", "D_IO", "D_IS", "D_OS", "D_OO"]
PLANS = {
    "8-position": ("eight-position", {"minutes": 5, "dt_s": 2}, CANDIDATES),
    "24-position": ("multiposition", {"n": 24, "minutes": 2, "dt_s": 2}, list(mc.SDF_NINE_TERMS)),
    "tumble": ("tumble", {"revolutions": 1, "dt_s": 10}, CANDIDATES),
    "polar-servo": ("servo", {"orientation": "polar", "hours": 2, "dt_s": 10}, CANDIDATES),
    "rate-ladder": (
        "rate-ladder",
        {"seconds": 20, "dt_s": 0.5},
        ["D_F", "D_I", "D_O", "D_S", "sf_error", "sf_asymmetry", "sf_quadratic"],
    ),
}
WHITE = {"white": 0.01}
COLOURED = {"white": 0.01, "gauss_markov": [0.3, 60.0]}
SLOW = {"white": 0.001, "gauss_markov": [0.05, 300.0]}  # drift as slow as a position: seen only between positions
NOISES = {"white": WHITE, "gm60": COLOURED, "gm300": SLOW}
NOISE_LABELS = {"white": "white", "gm60": "white+GM(0.3 deg/h, 60 s)", "gm300": "white+GM(0.05 deg/h, 300 s)"}


def _row(label, names, z):
    inside = np.mean(np.abs(z) <= 2.0, axis=0)
    print(f"  {label:34s} " + " ".join(f"{c:>8s}" for c in names))
    print(f"  {'   mean (θ̂−θ)/σ̂':34s} " + " ".join(f"{v:8.3f}" for v in z.mean(axis=0)))
    print(f"  {'   fraction in ±2σ̂':34s} " + " ".join(f"{v:8.3f}" for v in inside))
    print(
        f"  {'':34s} pooled {np.mean(np.abs(z) <= 2.0):.3f}  (n = {len(z)}, binomial sd "
        f"{np.sqrt(0.9545 * 0.0455 / len(z)):.3f})"
    )


def gls_z(pipe, st, plan, n):
    """(θ̂ − θ)/σ̂ of identify.fit (GLS) on the first n draws of a study."""
    fast = runner.run_study(st, pipeline=pipe, draws=n)
    truth = fast.truth_of_fit()
    servo = any(d.mode == "servo" for d in pipe.data)
    z = []
    for d in range(n):
        if servo:
            coeffs = dict(zip(pipe.truth_model.coefficient_names, map(float, fast.truth[d])))
            recs = simulate(plan, {"coefficients": coeffs, "noise": st.noise}, seed=10_000 + d)
        else:
            recs = pipeline.draw_records(pipe, d)
        f = identify.fit(recs, list(pipe.fit_model.terms), noise="ar")
        z.append((f.theta - truth[d]) / f.std)
    return np.array(z)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=500)
    ap.add_argument("--gls-draws", type=int, default=500)
    ap.add_argument("--plans", default=",".join(PLANS))
    ap.add_argument("--noises", default=",".join(NOISES), help="white, gm60, gm300")
    args = ap.parse_args(argv)
    for name in args.plans.split(","):
        builder, opts, cand = PLANS[name]
        plan = plans.build(builder, **opts)
        recs = pipeline.nominal_records(plan)
        terms, dropped = pipeline.identifiable_terms(recs, cand) if name != "24-position" else (cand, ["D_OO"])
        print(
            f"\n== {name}: {builder} {opts}; fitted {', '.join(terms)}; dropped (aliased/unexcited) "
            f"{', '.join(dropped) or '-'}"
        )
        for key in args.noises.split(","):
            noise_name, noise = NOISE_LABELS[key], NOISES[key]
            st = mc.Study(
                plan=builder,
                plan_options=opts,
                terms=terms,
                priors={c: {"normal": [0.0, 0.5]} for c in terms},
                noise=noise,
                draws=args.draws,
                seed=7,
            )
            pipe = pipeline.build_pipeline(st, plan=plan, records=recs)
            t = time.perf_counter()
            res = runner.run_study(st, pipeline=pipe)
            z = (res.estimate - res.truth_of_fit()) / res.std
            _row(
                f"{noise_name}: fast JAX white LS ({time.perf_counter() - t:.1f} s)",
                pipe.fit_model.coefficient_names,
                z,
            )
            if args.gls_draws:
                t = time.perf_counter()
                zg = gls_z(pipe, st, plan, args.gls_draws)
                _row(
                    f"{noise_name}: identify.fit GLS ({time.perf_counter() - t:.0f} s)",
                    pipe.fit_model.coefficient_names,
                    zg,
                )


if __name__ == "__main__":
    main()
