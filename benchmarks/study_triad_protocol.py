"""Hand IMU protocols (issue 27): does the Monte Carlo of a designed protocol confirm its predicted σ, and does it
beat imucal's Ferraris protocol and imu_tk's random poses at equal time?

1. Design (:func:`gyrojax.planning.triad_protocol.design_protocol`, D criterion, the six linear terms, ARW
   1.2 deg/√h = 0.2 deg/s per sample at 100 Hz, accelerometer 0.002 g, placement 0.5°, latitude unknown).
2. Monte Carlo: ``--seeds`` sessions simulated from the protocol's steps
   (:func:`gyrojax.simulation.triad_session.simulate_session`: the MEMS truth of
   :func:`gyrojax.montecarlo.triad.mems_truth`, placement errors drawn, random session heading, Earth rate on or
   off), each fitted by :func:`gyrojax.inference.triad.fit_triad` (noise estimated, REML components on). Printed
   per coefficient: the sd of the estimates over the seeds / the predicted σ, and its sampling sd √(1/(2(n−1))).
3. The comparison table (predicted σ, criterion, ratios) beside Ferraris and imu_tk (docs/mems_imu.md).

Run: PYTHONPATH=. python benchmarks/study_triad_protocol.py [--poses 12] [--minutes 10] [--seeds 200]
"""

from __future__ import annotations

import argparse
import math
import time
import warnings

import numpy as np

from gyrojax.inference.triad import fit_triad
from gyrojax.montecarlo.triad import mems_truth
from gyrojax.physics.triad import channel_names
from gyrojax.planning import triad_protocol as tpr
from gyrojax.planning.triad_fisher import TriadNoise
from gyrojax.report.protocol_text import comparison_text, table_text
from gyrojax.simulation.triad_session import simulate_session

TERMS = ("D_F", "D_I", "D_O", "D_S", "sf_error", "ia_misalignment")


def monte_carlo(proto, seeds: int, earth_rate: bool) -> np.ndarray:
    """sd of the estimates over ``seeds`` simulated sessions / predicted σ, per coefficient."""
    model = tpr.triad_model(TERMS)
    noise = proto.noise
    pred = tpr.sigma(proto.fisher(), model)
    gyro_dps = noise.arw * 60.0 * math.sqrt(noise.rate_hz) / 3600.0
    est = []
    for seed in range(seeds):
        rec = simulate_session(
            proto.steps,
            mems_truth(),
            start_attitude=proto.start_attitude,
            rate_hz=noise.rate_hz,
            gyro_noise_dps=gyro_dps,
            acc_noise_g=noise.acc_noise_g,
            placement_deg=noise.placement_deg,
            earth_rate=earth_rate,
            seed=1000 + seed,
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            est.append(fit_triad(rec, list(TERMS)).theta)
    sd = np.asarray(est).std(axis=0, ddof=1)
    return sd / np.array([pred[k] for k in channel_names(model)])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=12)
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--seeds", type=int, default=200)
    ap.add_argument("--starts", type=int, default=4)
    ap.add_argument("--steps", type=int, default=300)
    a = ap.parse_args()
    t0 = time.perf_counter()
    for earth in (False, True):
        noise = TriadNoise(arw=1.2, placement_deg=0.5, earth_rate=earth)
        proto = tpr.design_protocol(TERMS, a.poses, a.minutes, "D", noise, starts=a.starts, steps=a.steps)
        rows = tpr.comparison(proto)
        print(
            f"== Earth rate {'on (latitude unknown, random heading)' if earth else 'off'}; "
            f"design {time.perf_counter() - t0:.0f} s"
        )
        print(table_text(proto.table()))
        print(comparison_text(rows, proto.criterion, proto.criterion_name))
        r = monte_carlo(proto, a.seeds, earth)
        names = channel_names(tpr.triad_model(TERMS))
        print(
            f"Monte Carlo, {a.seeds} seeds: sd of the estimates / predicted sigma "
            f"(sampling sd {1 / math.sqrt(2 * (a.seeds - 1)):.3f})"
        )
        for n, x in zip(names, r):
            print(f"  {n:<10} {x:6.3f}")
        print(
            f"  mean {r.mean():.3f}, min {r.min():.3f}, max {r.max():.3f}, "
            f"rms of (ratio - 1) {np.sqrt(np.mean((r - 1) ** 2)):.3f}"
        )
        print(f"({time.perf_counter() - t0:.0f} s so far)", flush=True)


if __name__ == "__main__":
    main()
