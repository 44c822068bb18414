"""Null campaigns of the model-free adequacy tests: how often does ``diagnose`` report residual structure that no
named effect explains, or any missing effect, when the model is right? (issue 19, and issue 28 for servo records:
``unexplained`` empty and the verdict adequate — or the colour named ``gauss_markov`` where there is drift — in at
least 95 % of seeds.)

Rebalance campaigns, the model D_F, D_I, D_O, D_S equal to the truth:
  white   24-position test, 3-min dwells at 2 s, white noise N = 0.0008 deg/√h;
  gm      the same with Gauss–Markov drift σ = 0.01 deg/h, τ = 300 s;
  rrw     a long one: 24 positions × 10 min at 2 s (4 h) with rate random walk K = 0.005 deg/h/√h beside the white.
Servo campaigns (issue 28), the table angle read every ``--dt`` s and quantised at 0.18″, white rate noise
N = 0.0007 deg/√h integrated into the angle (``gm``: and a Gauss–Markov rate σ = 0.005 deg/h, τ = 1800 s):
  polar-12h / polar-24h          Hu's polar servo test, IA along the Earth's axis, north and south mountings,
                                 the model D_F, D_I, D_O, D_S, D_IS, D_OO, D_OS (the truth inside it);
  vertical-12h / vertical-24h    IA up (Hu 3-60): the truth D_F, D_I, the model D_F (only D_F + g·D_I is seen);
  horizontal-12h / -24h          IA north (Hu 3-74): D_F, D_O, D_S, D_OO, D_OS.
Prints, per campaign, the fraction of seeds with a non-empty ``unexplained``, with verdict ``missing-effect``, with
the colour reported, and the time per diagnosis.

Run: PYTHONPATH=. python benchmarks/study_adequacy_null.py [--seeds 40] [--dt 10] [--only polar-12h-white,...]
"""

import argparse
import time

import numpy as np

from gyrojax import plans, simulate
from gyrojax.inference.diagnose import diagnose
from gyrojax.simulation.simulator import quantise_angles

BASE = {"D_F": 0.4, "D_I": 0.6, "D_O": -0.2, "D_S": 0.3}
TERMS = ["D_F", "D_I", "D_O", "D_S"]
CAMPAIGNS = {
    "white": (lambda dt: plans.multiposition(24, minutes=3, dt_s=2), {"white": 0.0008}, BASE, TERMS),
    "gm": (
        lambda dt: plans.multiposition(24, minutes=3, dt_s=2),
        {"white": 0.0008, "gauss_markov": [0.01, 300.0]},
        BASE,
        TERMS,
    ),
    "rrw": (
        lambda dt: plans.multiposition(24, minutes=10, dt_s=2),
        {"white": 0.0008, "random_walk": 0.005},
        BASE,
        TERMS,
    ),
}
Q_ARCSEC = 0.18
SERVO_WHITE = {"white": 0.0007}
SERVO_GM = {"white": 0.0007, "gauss_markov": [0.005, 1800.0]}
SERVO_TRUTH = {
    "polar": {"D_F": 0.5, "D_I": 0.3, "D_O": -0.2, "D_S": 0.25, "D_IS": 0.02, "D_OO": 0.015, "D_OS": -0.01},
    "vertical": {"D_F": 0.5, "D_I": 0.3},
    "horizontal": {"D_F": 0.5, "D_O": -0.2, "D_S": 0.25, "D_OO": 0.015, "D_OS": -0.01},
}
SERVO_TERMS = {o: list(t) for o, t in SERVO_TRUTH.items()}
SERVO_TERMS["vertical"] = ["D_F"]  # a_I = g throughout: D_F + g·D_I is what the test sees


def _servo_plan(orientation: str, hours: float):
    if orientation == "polar":
        return lambda dt: plans.polar_servo_north_south(hours, dt)
    return lambda dt: plans.servo(orientation, hours=hours, dt_s=dt)


for _o in ("polar", "vertical", "horizontal"):
    for _h in (12, 24):
        for _nn, _nz in (("white", SERVO_WHITE), ("gm", SERVO_GM)):
            CAMPAIGNS[f"{_o}-{_h}h-{_nn}"] = (_servo_plan(_o, float(_h)), _nz, SERVO_TRUTH[_o], SERVO_TERMS[_o])


def study(name: str, seeds: int = 40, first_seed: int = 1000, dt_s: float = 10.0):
    """(fraction with unexplained structure, fraction missing-effect, fraction with colour, seconds per diagnosis,
    findings)."""
    build, noise, truth, terms = CAMPAIGNS[name]
    plan = build(dt_s)
    servo = "-" in name
    found, missing, colour, seconds, what = 0, 0, 0, [], []
    for s in range(first_seed, first_seed + seeds):
        recs = simulate(plan, {"coefficients": truth, "noise": noise}, seed=s)
        recs = quantise_angles(recs, Q_ARCSEC) if servo else recs
        t0 = time.perf_counter()
        d = diagnose(recs, terms, suggest_tests=False)
        seconds.append(time.perf_counter() - t0)
        found += bool(d.unexplained)
        missing += d.verdict == "missing-effect"
        colour += any(c.name == "gauss_markov" for c in d.candidates)
        what += [(s, u.versus, u.shape, u.p_adjusted) for u in d.unexplained]
        what += [(s, c.name, "named", c.p_adjusted) for c in d.candidates if c.df > 0 and c.p_adjusted < d.alpha]
    return found / seeds, missing / seeds, colour / seeds, float(np.median(seconds)), what


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=40)
    ap.add_argument("--dt", type=float, default=10.0, help="servo sample interval, s")
    ap.add_argument("--only", default="", help="comma-separated campaign names (default: all)")
    a = ap.parse_args(argv)
    names = [n for n in a.only.split(",") if n] or list(CAMPAIGNS)
    for name in names:
        f_un, f_miss, f_col, sec, what = study(name, a.seeds, dt_s=a.dt)
        print(
            f"{name:22s} seeds {a.seeds}: unexplained non-empty {f_un:.3f}, missing-effect {f_miss:.3f}, "
            f"colour {f_col:.3f}, {sec:.2f} s per diagnosis",
            flush=True,
        )
        for w in what:
            print("   ", w, flush=True)


if __name__ == "__main__":
    main()
