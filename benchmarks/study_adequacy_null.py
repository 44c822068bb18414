"""Null campaigns of the model-free adequacy tests: how often does ``diagnose`` report residual structure that no
named effect explains, or any missing effect, when the model is right? (issue 19: ``unexplained`` empty in at least
95 % of seeds.)

Three null campaigns, the model D_F, D_I, D_O, D_S equal to the truth:
  white   24-position test, 3-min dwells at 2 s, white noise N = 0.0008 deg/√h;
  gm      the same with Gauss–Markov drift σ = 0.01 deg/h, τ = 300 s;
  rrw     a long one: 24 positions × 10 min at 2 s (4 h) with rate random walk K = 0.005 deg/h/√h beside the white.
Prints, per campaign, the fraction of seeds with a non-empty ``unexplained``, with verdict ``missing-effect``, and
the time per diagnosis.
Run: PYTHONPATH=. python benchmarks/study_adequacy_null.py [seeds]
"""

import sys
import time

import numpy as np

from gyrojax import plans, simulate
from gyrojax.inference.diagnose import diagnose

BASE = {"D_F": 0.4, "D_I": 0.6, "D_O": -0.2, "D_S": 0.3}
TERMS = ["D_F", "D_I", "D_O", "D_S"]
CAMPAIGNS = {
    "white": (lambda: plans.multiposition(24, minutes=3, dt_s=2), {"white": 0.0008}),
    "gm": (lambda: plans.multiposition(24, minutes=3, dt_s=2), {"white": 0.0008, "gauss_markov": [0.01, 300.0]}),
    "rrw": (lambda: plans.multiposition(24, minutes=10, dt_s=2), {"white": 0.0008, "random_walk": 0.005}),
}


def study(name: str, seeds: int = 40, first_seed: int = 1000):
    """(fraction with unexplained structure, fraction missing-effect, seconds per diagnosis, findings)."""
    build, noise = CAMPAIGNS[name]
    plan = build()
    found, missing, seconds, what = 0, 0, [], []
    for s in range(first_seed, first_seed + seeds):
        recs = simulate(plan, {"coefficients": BASE, "noise": noise}, seed=s)
        t0 = time.perf_counter()
        d = diagnose(recs, TERMS, suggest_tests=False)
        seconds.append(time.perf_counter() - t0)
        found += bool(d.unexplained)
        missing += d.verdict == "missing-effect"
        what += [(s, u.versus, u.shape, u.p_adjusted) for u in d.unexplained]
        what += [(s, c.name, "named", c.p_adjusted) for c in d.candidates if c.df > 0 and c.p_adjusted < d.alpha]
    return found / seeds, missing / seeds, float(np.median(seconds)), what


def main(seeds: int = 40):
    for name in CAMPAIGNS:
        f_un, f_miss, sec, what = study(name, seeds)
        print(
            f"{name:6s} seeds {seeds}: unexplained non-empty {f_un:.3f}, missing-effect {f_miss:.3f}, "
            f"{sec:.2f} s per diagnosis",
            flush=True,
        )
        for w in what:
            print("   ", w, flush=True)


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:2]))
