"""Servo coverage (issue 28): is (θ̂ − θ)/σ̂ standard normal for a polar servo campaign with a quantised readout?

Hu's polar servo test, north and south mountings (:func:`gyrojax.data.plans.polar_servo_north_south`), 2 h per
mounting, the table angle read every 10 s and quantised at 0.18″; the model D_F, D_I, D_O, D_S equal to the truth
(coefficients drawn from N(0, 0.3²) deg/h, deg/h/g per campaign). Noise: white rate noise N = 0.0007 deg/√h
integrated into the angle, and the same with a Gauss–Markov rate σ = 0.005 deg/h, τ = 1800 s. Printed per noise
case: the fraction of coefficients with |θ̂ − θ| ≤ 2σ̂ (0.9545 for an honest σ̂) and the sd of z = (θ̂ − θ)/σ̂ (1),
pooled over the four coefficients, with the readout noise known (the quantisation step found in the angles,
:mod:`gyrojax.noise.readout`) and, for comparison, ignored (the angles jittered off the grid by ±0.01″ so no step is
found: the quantisation then passes for white rate noise, as before issue 28). Then, per coefficient (readout
known): the sd over campaigns of θ̂ − θ beside the rms of σ̂ and the median σ̂, and the share of campaigns whose
fit kept a Gauss–Markov drift (on white rate noise: the drift test's false alarms).

Run: PYTHONPATH=. python benchmarks/study_servo_coverage.py [--campaigns 80] [--first-seed 5000]
"""

import argparse
import time

import numpy as np

from benchmarks.study_adequacy_null import Q_ARCSEC
from gyrojax.data.plans import polar_servo_north_south
from gyrojax.data.record import Record
from gyrojax.inference.identify import fit
from gyrojax.simulation.simulator import quantise_angles, simulate

TERMS = ("D_F", "D_I", "D_O", "D_S")
NOISES = {"white": {"white": 0.0007}, "white+GM": {"white": 0.0007, "gauss_markov": [0.005, 1800.0]}}


def _off_grid(records, rng):
    out = []
    for r in records:
        cols = dict(r.columns)
        for a in r.axis_names:
            key = f"angle_{a}_deg"
            cols[key] = np.asarray(cols[key]) + rng.uniform(-0.01, 0.01, len(cols[key])) / 3600.0
        out.append(Record(r.meta, cols))
    return out


def study(noise: dict, campaigns: int, first_seed: int = 5000):
    """z of every coefficient, (campaigns, 4), with the readout known and ignored; with the readout known also
    θ̂ − θ and σ̂ (campaigns, 4) and whether the fit kept a drift (campaigns,)."""
    plan = polar_servo_north_south(2.0, 10.0)
    rng = np.random.default_rng(first_seed)
    known, ignored, err, std, drift = [], [], [], [], []
    for s in range(first_seed, first_seed + campaigns):
        truth = dict(zip(TERMS, rng.normal(0.0, 0.3, len(TERMS))))
        recs = quantise_angles(simulate(plan, {"coefficients": truth, "noise": noise}, seed=s), Q_ARCSEC)
        for recs_, out in ((recs, known), (_off_grid(recs, rng), ignored)):
            res = fit(recs_, TERMS)
            out.append([(res.values[k] - truth[k]) / res.stds[k] for k in TERMS])
            if out is known:
                err.append([res.values[k] - truth[k] for k in TERMS])
                std.append([res.stds[k] for k in TERMS])
                drift.append(any(nz.gm_variance > 0 for nz in res.noise if nz.gauss_markov))
    return np.array(known), np.array(ignored), np.array(err), np.array(std), np.array(drift)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaigns", type=int, default=80)
    ap.add_argument("--first-seed", type=int, default=5000)
    a = ap.parse_args(argv)
    print(f"{'noise':10s} {'readout':8s} {'±2σ coverage':>13s} {'sd z':>6s}  (n = {4 * a.campaigns} coefficients)")
    for name, noise in NOISES.items():
        t0 = time.perf_counter()
        known, ignored, err, std, drift = study(noise, a.campaigns, a.first_seed)
        for label, z in (("known", known), ("ignored", ignored)):
            print(f"{name:10s} {label:8s} {np.mean(np.abs(z) <= 2.0):13.3f} {np.std(z):6.3f}", flush=True)
        print(f"{'':10s} readout known, {np.mean(drift):.3f} of the fits kept a drift; per coefficient:")
        for k, name_k in enumerate(TERMS):
            print(
                f"{'':12s}{name_k:5s} sd(θ̂ − θ) {np.std(err[:, k]):.3g}, rms σ̂ {np.sqrt(np.mean(std[:, k] ** 2)):.3g},"
                f" median σ̂ {np.median(std[:, k]):.3g}, sd z {np.std(known[:, k]):.3f}",
                flush=True,
            )
        print(f"{'':10s} ({time.perf_counter() - t0:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
