"""Slow candidates (``bias_trend``) beside long-memory drift: the rejection rate of each way of testing them, on null
campaigns and with a trend hidden (issue 16: the JAX noise fit must not turn drift into false alarms).

For each draw, the model D_F, D_I, D_O, D_S is fitted and ``bias_trend`` is tested three ways:

  score   the diagnosis' test (``p_value`` of ``bias_trend`` from :func:`gyrojax.inference.diagnose.diagnose`): the
          score statistic under the diagnosis' noise model (τ capped at the record span / 8), F(1, n − p);
  wald    the trend's coefficient fitted beside the drift re-estimated with it, Wald with Satterthwaite ν
          (:func:`gyrojax.inference.turntable_diagnosis.wald_beside_drift`; ``p_value_drift_refitted`` in the
          diagnosis JSON);
  lr      profile likelihood ratio, white + Gauss–Markov re-fitted by maximum likelihood under both hypotheses
          (τ up to the record span), χ²(1).

Campaigns (24-position test at 2 s; the drift of ``benchmarks/study_adequacy_null.py``):
  gm      4-min dwells, white N = 0.0008 deg/√h + Gauss–Markov σ = 0.01 deg/h, τ = 300 s;
  rrw     10-min dwells (4 h), white + rate random walk K = 0.005 deg/h/√h.
Prints the fraction of draws with p below 0.05, 0.01, 0.001 and 3.6e-4 (the first Holm step of a family of ~28
candidates at α = 0.01), per test, and the fraction of diagnoses (named candidates only) with verdict
``missing-effect``.

Run: python -m benchmarks.study_slow_candidates [draws] [D_T deg/h/h] [gm|rrw]
"""

from __future__ import annotations

import sys
import time

import numpy as np
from scipy import stats

from gyrojax import plans, simulate
from gyrojax.inference import identify
from gyrojax.inference.campaign import Campaign, linearize
from gyrojax.inference.diagnose import diagnose
from gyrojax.inference.noisefit import group_series
from gyrojax.inference.turntable_diagnosis import wald_beside_drift
from gyrojax.noise import reml
from gyrojax.physics.model import Model

BASE = {"D_F": 0.4, "D_I": 0.6, "D_O": -0.2, "D_S": 0.3}
TERMS = ("D_F", "D_I", "D_O", "D_S")
CAMPAIGNS = {
    "gm": (lambda: plans.multiposition(24, minutes=4, dt_s=2), {"white": 0.0008, "gauss_markov": [0.01, 300.0]}),
    "rrw": (lambda: plans.multiposition(24, minutes=10, dt_s=2), {"white": 0.0008, "random_walk": 0.005}),
}
LEVELS = (0.05, 0.01, 0.001, 3.6e-4)


def _lr_p(lin, start) -> float:
    r, j, lab, t = group_series(lin, list(range(len(lin))))
    f = []
    for p in (len(TERMS), len(TERMS) + 1):
        s = reml.prepare(r, j[:, :p], lab, t, 1.0)
        f.append(reml.fit(s, start, reml=False).value)
    return float(stats.chi2.sf(max(f[0] - f[1], 0.0), 1))


def study(name: str, draws: int, trend: float = 0.0, first_seed: int = 100):
    """Rejection fractions {test: [fraction at each of LEVELS]} and seconds per draw."""
    build, noise = CAMPAIGNS[name]
    plan = build()
    p = {"score": [], "wald": [], "lr": []}
    missing = 0
    t0 = time.perf_counter()
    for seed in range(first_seed, first_seed + draws):
        recs = simulate(plan, {"coefficients": {**BASE, "D_T": trend}, "noise": noise}, seed=seed)
        camp = Campaign.of(recs)
        res = identify.fit(recs, TERMS, campaign=camp)
        full = Model(TERMS + ("bias_trend",), res.model.kind)
        lin = linearize(full, np.concatenate([res.theta, [0.0]]), camp)
        d = diagnose(recs, TERMS, result=res, campaign=camp, suggest_tests=False, model_free=False)
        missing += d.verdict == "missing-effect"
        p["score"].append(next(c.p_value for c in d.candidates if c.name == "bias_trend"))
        p["wald"].append(wald_beside_drift(camp, lin, np.arange(len(TERMS) + 1), len(TERMS))[0])
        nz = res.noise[0]
        start = nz.whitening_theta() if nz.gauss_markov else (300.0, 1e-4, 1e-3)
        p["lr"].append(_lr_p(lin, start))
    sec = (time.perf_counter() - t0) / draws
    return {k: [float(np.mean(np.array(v) < a)) for a in LEVELS] for k, v in p.items()}, missing / draws, sec


def main(draws: int = 100, trend: float = 0.0, names=tuple(CAMPAIGNS)):
    for name in names:
        rates, missing, sec = study(name, draws, trend)
        print(
            f"{name}, D_T = {trend} deg/h/h, {draws} draws ({sec:.2f} s each), missing-effect {missing:.3f}; "
            f"rejected at p < {LEVELS}:"
        )
        for k, v in rates.items():
            print(f"   {k:6s} " + "  ".join(f"{x:.3f}" for x in v), flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    main(
        int(args[0]) if args else 100,
        float(args[1]) if len(args) > 1 else 0.0,
        (args[2],) if len(args) > 2 else tuple(CAMPAIGNS),
    )
