"""Overlapping Allan deviation of 10⁶ samples: gyrojax (JAX, cumulative sums) against allantools.oadev.

Prints wall times (compile excluded and included) and the ratio, the max relative difference, and the time of
the whole `gyrojax noise` analysis (ADEV + EDF + noise fit) and of the CLI on a 10⁶-sample record.
Run: PYTHONPATH=. python benchmarks/bench_allan.py [n]
"""

import sys
import tempfile
import time
from pathlib import Path

import allantools
import numpy as np

from benchmarks.timing import compile_here
from gyrojax import save_record, simulate
from gyrojax.cli.app import main
from gyrojax.data import plans
from gyrojax.noise import allan


def best_of(f, k=3):
    ts = []
    for _ in range(k):
        t = time.perf_counter()
        out = f()
        ts.append(time.perf_counter() - t)
    return min(ts), out


def run(n: int = 1_000_000):
    rng = np.random.default_rng(0)
    y = 0.1 * rng.normal(size=n) + np.cumsum(1e-4 * rng.normal(size=n))
    m = allan.default_m_list(n)
    t = time.perf_counter()
    np.asarray(allan.overlapping_adev(y, 1.0, m))
    first = time.perf_counter() - t
    t_ours, ours = best_of(lambda: np.asarray(allan.overlapping_adev(y, 1.0, m)))
    t_ref, ref = best_of(lambda: allantools.oadev(y, rate=1.0, data_type="freq", taus=m * 1.0)[1], k=1)
    print(f"n = {n}, {len(m)} taus (m = 1 … {m[-1]})")
    print(f"gyrojax overlapping_adev: {t_ours:.3f} s (first call incl. compile {first:.3f} s)")
    print(f"allantools.oadev:         {t_ref:.3f} s   ratio allantools/gyrojax = {t_ref / t_ours:.1f}")
    print(f"max relative difference:  {np.max(np.abs(ours / ref - 1)):.2e}")
    t_an, (res, fit) = best_of(lambda: allan.analyze(y, 1.0), k=1)
    print(f"allan.analyze (ADEV + EDF + fit, two passes): {t_an:.3f} s; terms {fit.names}")
    with tempfile.TemporaryDirectory() as d:
        hours = n / 3600.0
        t = time.perf_counter()
        rec = simulate(plans.fixed_position(hours=hours), {"noise": {"white": 0.002, "random_walk": 0.01}}, seed=1)[0]
        p = save_record(rec, d)
        print(f"simulate + save a {n}-sample record: {time.perf_counter() - t:.1f} s")
        t = time.perf_counter()
        main(["noise", str(p), "--json", "--plot", str(Path(d) / "a.png")])
        print(f"\ngyrojax noise (load CSV + analyse + plot): {time.perf_counter() - t:.1f} s")


if __name__ == "__main__":
    compile_here()
    run(int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000)
