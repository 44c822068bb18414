"""Big records: write a 10⁷-sample slow-tumble record, then load and fit it; report time and peak memory.

    python -m benchmarks.bench_big_record [--n 10000000] [--paths standard,chunked] [--mem-cap-gb 8]

The record is a polar tumble (OA on the polar axis, IA and SA turning through g at 0.036 deg/s, 100 revolutions per
10⁶ s) sampled at 1 s, with D_F, D_I, D_S, D_IS and white noise. It is simulated for 10⁶ samples and repeated
(with fresh noise) to reach n samples, then written with ``save_record``. Each fit runs in a fresh subprocess so
its peak resident memory (``resource.getrusage(RUSAGE_SELF).ru_maxrss``) is its own:

* ``standard``: ``load_record`` + ``identify.fit(..., noise="white")`` (whole record in memory), run under an
  address-space cap (``--mem-cap-gb``) so that a path that does not fit fails instead of swapping the machine;
* ``chunked``: ``gyrojax.inference.bigfit.fit_chunked`` (streams the CSV, accumulates JᵀJ, Jᵀr, rᵀr).

The target is a peak under 4 GB.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TRUTH = {"coefficients": {"D_F": 0.5, "D_I": 0.3, "D_S": 0.1, "D_IS": 0.05}}
TERMS = ["D_F", "D_I", "D_S", "D_IS"]
WHITE = 0.01  # deg/√h
TILE = 1_000_000


def peak_rss_gb() -> float:
    """Peak resident memory of this process, GB: ``getrusage`` (Linux: kB; it includes what a process inherited at
    fork, hence every step runs in a fresh subprocess started by a small parent), cross-checked by VmHWM."""
    ru = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
    try:
        with open("/proc/self/status") as fh:
            hwm = next(int(line.split()[1]) for line in fh if line.startswith("VmHWM")) / 1024**2
    except (OSError, StopIteration):
        hwm = ru
    return min(ru, hwm)


def write_record(directory: Path, n: int, seed: int = 0) -> Path:
    import numpy as np

    from gyrojax.data import plans
    from gyrojax.data.record import Record
    from gyrojax.data.records import save_record
    from gyrojax.simulation.simulator import simulate

    axis = plans.polar_axis(plans.DEFAULT_LATITUDE)
    tile = min(n, TILE)
    rate = 360.0 * 100 / TILE  # 100 revolutions per 10⁶ s: tiles join smoothly
    seg = plans.Segment((0.0,), float(tile), 1.0, rate_dps=(rate,))
    run = plans.Run("big", (("polar", axis),), plans.sdf_mount(plans.E, axis), (seg,))
    rec = simulate(plans.Plan("big", (run,)), TRUTH)[0]
    reps = math.ceil(n / tile)
    rng = np.random.default_rng(seed)
    cols = {}
    for k, v in rec.columns.items():
        if k == "time_s":
            cols[k] = (v[None, :] + tile * np.arange(reps)[:, None]).ravel()[:n]
        else:
            cols[k] = np.tile(v, reps)[:n]
    cols["angle_polar_deg"] = np.mod(cols["angle_polar_deg"], 360.0)
    sigma = WHITE * 60.0  # deg/h per 1 s sample
    cols["current_mA"] = cols["current_mA"] + rng.standard_normal(n) * sigma / rec.scale_factor
    big = Record(rec.meta, cols)
    return save_record(big, directory, force=True)


def run_fit(path: str, how: str) -> dict:
    """Load and fit in this process (the subprocess side); returns timings and peak memory."""
    t0 = time.perf_counter()
    if how == "standard":
        from gyrojax.data.records import load_record
        from gyrojax.inference.identify import fit

        rec = load_record(path)
        t1 = time.perf_counter()
        res = fit([rec], TERMS, noise="white")
        values, stds = res.values, res.stds
    else:
        from gyrojax.inference.bigfit import fit_chunked

        t1 = t0
        res = fit_chunked(path, TERMS)
        values, stds = res.values, res.stds
    t2 = time.perf_counter()
    return {
        "how": how,
        "load_s": t1 - t0,
        "fit_s": t2 - t1,
        "total_s": t2 - t0,
        "peak_rss_gb": peak_rss_gb(),
        "values": values,
        "stds": stds,
    }


def write_step(directory: str, n: int) -> dict:
    t0 = time.perf_counter()
    path = write_record(Path(directory), n)
    return {"path": str(path), "write_s": time.perf_counter() - t0, "peak_rss_gb": peak_rss_gb()}


def _child(call: str, cap_gb: float | None = None, how: str = "write") -> dict:
    code = (
        "import json, resource, sys\n"
        f"cap = {cap_gb!r}\n"
        "if cap: resource.setrlimit(resource.RLIMIT_AS, (int(cap * 2**30), int(cap * 2**30)))\n"
        "from benchmarks.bench_big_record import run_fit, write_step\n"
        f"print(json.dumps({call}))\n"
    )
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]), JAX_PLATFORMS="cpu")
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    if p.returncode != 0:
        last = (p.stderr.strip().splitlines() or ["?"])[-1]
        return {"how": how, "failed": f"exit {p.returncode}: {last[:200]}", "wall_s": time.perf_counter() - t0}
    return json.loads(p.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10_000_000)
    ap.add_argument("--paths", default="standard,chunked")
    ap.add_argument("--mem-cap-gb", type=float, default=8.0, help="address-space cap for the standard path")
    ap.add_argument("--dir", help="keep the record here (default: a temporary directory)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(args.dir or tmp)
        w = _child(f"write_step({str(d)!r}, {args.n})")
        if "failed" in w:
            print(f"writing failed: {w['failed']}")
            return 1
        path = w["path"]
        size = sum(f.stat().st_size for f in d.glob("big.*")) / 2**30
        print(
            f"wrote {args.n:.3g} samples ({size:.2f} GiB) with save_record in {w['write_s']:.1f} s; "
            f"writer peak RSS {w['peak_rss_gb']:.2f} GB"
        )
        for how in args.paths.split(","):
            cap = args.mem_cap_gb if how == "standard" else None
            r = _child(f"run_fit({path!r}, {how!r})", cap, how)
            if "failed" in r:
                print(f"{how:9s} FAILED under a {args.mem_cap_gb:g} GB cap after {r['wall_s']:.1f} s: {r['failed']}")
                continue
            est = ", ".join(f"{k}={r['values'][k]:.5f}±{r['stds'][k]:.5f}" for k in TERMS)
            ok = "under" if r["peak_rss_gb"] < 4 else "OVER"
            print(
                f"{how:9s} load {r['load_s']:.1f} s, fit {r['fit_s']:.1f} s, total {r['total_s']:.1f} s, "
                f"peak RSS {r['peak_rss_gb']:.2f} GB ({ok} the 4 GB target); {est}"
            )
        print(f"truth: {TRUTH['coefficients']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
