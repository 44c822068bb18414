"""The next hand session (``gj.next_test`` on imu-triad records): does a Monte Carlo of the two sessions confirm the σ
the step predicts after the designed session?

1. A first session (imu_tk's 7 random poses in 2 min; ARW 1.2 deg/√h at 50 Hz, accelerometer 0.002 g, placement
   1°, the MEMS truth of :func:`gyrojax.montecarlo.triad.mems_truth`) and the next session designed for a goal
   (D_F 5 deg/h, E_SF 300 ppm on every channel) by :func:`gyrojax.adaptive.step.next_test`; its predicted σ of all
   21 coefficients after the session, (prior + F)^{-1/2} (:func:`gyrojax.adaptive.hand.predicted_sigma`).
2. Monte Carlo: ``--seeds`` pairs of sessions — the first protocol and the designed one, each simulated anew
   (placement errors, random headings, the Earth rate), fitted jointly by ``gj.fit`` (noise estimated, REML
   components on). Printed per coefficient: the sd of the estimates / the predicted σ, with the sampling sd of
   that ratio, √(1/(2(n−1))). The prediction is conditional on the first fit's noise estimate (its noisiest
   channel's ARW), so the ratios are expected at or a little below 1.

Measured (80 seeds, 2-core machine): the session 2.72 min; ratios mean 1.009, from 0.846 (D_I[z]) to 1.179 (D_S[x],
D_F[z]), sampling sd 0.080 each; next_test 99 s with the compile of its search.

Run: PYTHONPATH=. python benchmarks/study_next_session.py [--seeds 100]
"""

from __future__ import annotations

import argparse
import math
import time
import warnings

import numpy as np

import gyrojax as gj
from gyrojax.adaptive.hand import HandLab, predicted_sigma, prior_information
from gyrojax.montecarlo.triad import mems_truth
from gyrojax.planning import triad_protocol as tpr
from gyrojax.simulation.triad_session import simulate_session

TERMS = ("D_F", "D_I", "D_O", "D_S", "sf_error", "ia_misalignment")
RATE, ARW, PLACEMENT = 50.0, 1.2, 1.0
GYRO_DPS = ARW * 60.0 * math.sqrt(RATE) / 3600.0


def session(c0, steps, seed):
    """One simulated session of the protocol (start attitude ``c0``, ``steps``)."""
    kw = {"rate_hz": RATE, "gyro_noise_dps": GYRO_DPS, "placement_deg": PLACEMENT, "seed": seed}
    return simulate_session(steps, mems_truth(), start_attitude=c0, **kw)


def main() -> None:
    """Design the next session, then the Monte Carlo of both sessions (module doc)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=100)
    args = ap.parse_args()
    c0, steps = tpr.random_steps(7, 120.0, seed=2)
    t0 = time.perf_counter()
    nt = gj.next_test(
        [session(c0, steps, 3)],
        TERMS,
        gj.Goal(targets={"D_F": 5.0, "E_SF": 300.0}),
        HandLab(poses=8, max_minutes=10.0),
        starts=4,
        steps=150,
    )
    print(f"next_test: {nt.status}, {nt.hours * 60:.3g} min, {time.perf_counter() - t0:.1f} s (compile included)")
    model = tpr.triad_model(TERMS)
    pred = predicted_sigma(model, prior_information(nt.fit, model), nt.design)
    proto = nt.design
    est = []
    for k in range(args.seeds):
        recs = [session(c0, steps, 1000 + 2 * k), session(proto.start_attitude, proto.steps, 1001 + 2 * k)]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            est.append(gj.fit(recs, list(TERMS)).theta)
    ratio = np.asarray(est).std(axis=0, ddof=1) / pred
    sampling = math.sqrt(1.0 / (2.0 * (args.seeds - 1)))
    names = nt.fit.names
    print(f"sd of the estimates / predicted σ over {args.seeds} pairs of sessions (sampling sd {sampling:.3f} each):")
    for name, r, p in zip(names, ratio, pred):
        print(f"  {name:8s} {r:6.3f}   predicted σ {p:.4g}")
    print(f"mean {ratio.mean():.3f}, min {ratio.min():.3f}, max {ratio.max():.3f}")


if __name__ == "__main__":
    main()
