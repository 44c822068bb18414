"""Long logs: `gyrojax import csv` + `gyrojax noise` of a rest log of hours at a high rate, and `gyrojax noise` of a
10⁶-sample record, each beside allantools run on the same samples in the same session.

**The log.** A simulated MEMS rest log as a logger writes it: a preamble line ``Fs,RATE``, a header, a time column
in ms and six channels of raw counts (gyro: white noise, a rate random walk and a bias; accelerometer: white noise
about a gravity reading), ``--hours`` at ``--rate`` Hz (default 5.56 h at 1 kHz: 2·10⁷ samples × 6 channels).

**Ours**, each as a fresh process, wall time and peak resident memory (its ``ru_maxrss``) and CPU time:
``gyrojax import csv LOG --map … --time-unit ms --gyro-unit counts …`` (read in chunks, a rest log written, the
record's CSV in numpy-vectorised text), then ``gyrojax noise RECORD --json`` (read in chunks, the octave Allan
variance accumulated over them, the model fitted on the variances). No compile time is in them beyond the
persistent cache's load: a first warm-up run of both fills the cache and is reported apart (``--cold``).

**The reference**, a fresh process too: pandas reads the whole log at once; per gyro and accelerometer channel
``allantools.oadev(y, rate, data_type="freq", taus=octave)`` at the same octave τ (m = 1, 2, 4, … ≤ (n − 1)/2);
the same GMWM model selection (:func:`gyrojax.noise.gmwm.select_model`) on the dyadic wavelet variance made from
allantools' variances. Its peak memory is that of holding the samples. A log under 2^19 rows is read whole and
its τ grid is denser than the octaves: the Allan deviations are then compared with allantools at that grid (run
again in this process, not timed).

**The 10⁶-sample record.** ``gyrojax noise`` of a static SDF record of ``--n`` samples (read in chunks, since it
has more than 2^19), against the reference process that reads it with pandas, runs ``allantools.oadev`` at the
same octave τ and the same model selection; and ours on a record 4× longer, to show the memory flat in length.

    python -m benchmarks.bench_long_log [--hours 5.56] [--rate 1000] [--n 1000000] [--keep DIR] [--cold]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

MEASURE = r"""
import resource, subprocess, sys, time
t = time.perf_counter()
out = subprocess.run(sys.argv[1:], capture_output=True, text=True)
wall = time.perf_counter() - t
r = resource.getrusage(resource.RUSAGE_CHILDREN)
if out.returncode:
    sys.stderr.write(out.stderr[-3000:])
    raise SystemExit(out.returncode)
sys.stdout.write(out.stdout)
print("\n", wall, r.ru_maxrss / 1024.0, r.ru_utime + r.ru_stime)
"""

REFERENCE = r"""
import json, sys
import numpy as np, pandas as pd, allantools
from gyrojax.noise.gmwm import WaveletVariance, select_model
from gyrojax.noise.wavelet import dyadic_m
path, rate, kind = sys.argv[1], float(sys.argv[2]), sys.argv[3]
if kind == "log":
    df = pd.read_csv(path, skiprows=1)
    chans = {c: df[c].to_numpy(float) for c in ("gx", "gy", "gz", "ax", "ay", "az")}
else:
    meta = json.load(open(path[:-4] + ".json"))
    df = pd.read_csv(path)
    chans = {"gyro": meta["scale_factor_deg_per_h_per_mA"] * df["current_mA"].to_numpy()}
    rate = 1.0 / float((df["time_s"].iloc[-1] - df["time_s"].iloc[0]) / (len(df) - 1))
out = {}
for c, y in chans.items():
    n = len(y)
    m = 2 ** np.arange(int(np.log2((n - 1) // 2)) + 1)
    taus, adev, _, ns = allantools.oadev(y, rate=rate, data_type="freq", taus=m / rate)
    dy = np.isin(m, dyadic_m(n))
    est = WaveletVariance(m[dy], adev[dy] ** 2 / 2.0, np.asarray(ns, float)[dy], 1.0 / rate, n)
    out[c] = {"taus": list(map(float, taus)), "adev": list(map(float, adev)), "model": select_model(est).info["model"]}
print(json.dumps(out))
"""


def measure(cmd, env=None) -> tuple[float, float, float, str]:
    """(wall s, peak resident MB, CPU s, its stdout) of ``cmd`` as a fresh process."""
    out = subprocess.run([sys.executable, "-c", MEASURE, *map(str, cmd)], capture_output=True, text=True, env=env)
    if out.returncode:
        raise SystemExit(f"{' '.join(map(str, cmd[:5]))} …: exit {out.returncode}: {out.stderr[-2000:]}")
    text, last = out.stdout.rstrip().rsplit("\n", 1)
    wall, rss, cpu = map(float, last.split())
    return wall, rss, cpu, text


def write_log(path: Path, n: int, rate: float, seed: int = 3) -> None:
    """The simulated rest log (module doc), written in pieces of 2^20 rows."""
    from gyrojax.data.longlog import format_column

    rng = np.random.default_rng(seed)
    walk = np.zeros(3)
    with open(path, "wb") as fh:
        fh.write(f"Fs,{rate:g}\ntime_ms,ax,ay,az,gx,gy,gz\n".encode())
        for k in range(0, n, 1 << 20):
            m = min(1 << 20, n - k)
            steps = np.cumsum(rng.normal(0, 0.002, (m, 3)), axis=0) + walk
            walk = steps[-1]
            g = np.round(rng.normal(0, 8, (m, 3)) + steps + np.array([-400, 150, -60]))
            a = np.round(rng.normal(0, 40, (m, 3)) + np.array([2600, -640, 16000]))
            cols = [np.arange(k, k + m) * (1000.0 / rate), *a.T, *g.T]
            text = [format_column(c, 0) for c in cols]
            sep = np.full((m, 1), ord(","), np.uint8)
            parts = [p for t in text for p in (t, sep)][:-1] + [np.full((m, 1), 10, np.uint8)]
            fh.write(np.concatenate(parts, axis=1).tobytes())


def sdf_record(folder: Path, n: int) -> Path:
    """A static rebalance record of n samples at 1 Hz: white + random-walk + Gauss-Markov drift (deg/h)."""
    from gyrojax import save_record, simulate
    from gyrojax.data import plans

    truth = {"noise": {"white": 0.002, "random_walk": 0.01, "gauss_markov": (0.005, 300.0)}}
    rec = simulate(plans.fixed_position(hours=n / 3600.0), truth, seed=1)[0]
    return save_record(rec, folder, force=True).with_suffix(".csv")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=2e7 / 1000.0 / 3600.0)
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--n", type=int, default=1_000_000, help="samples of the SDF record")
    ap.add_argument("--keep", help="a folder for the files (default: a temporary one)")
    ap.add_argument("--cold", action="store_true", help="also time the first run, persistent cache empty")
    args = ap.parse_args(argv)
    tmp = tempfile.TemporaryDirectory()
    folder = Path(args.keep or tmp.name)
    folder.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ)
    if args.cold:
        env["GYROJAX_CACHE_DIR"] = str(folder / "cache")
    gj = [sys.executable, "-m", "gyrojax"]
    n = int(round(args.hours * 3600 * args.rate))
    log = folder / "rest.csv"
    t = time.perf_counter()
    write_log(log, n, args.rate)
    print(
        f"log: {n} samples × 6 channels at {args.rate:g} Hz ({n / args.rate / 3600:.3g} h), "
        f"{log.stat().st_size / 1e9:.2f} GB, written in {time.perf_counter() - t:.0f} s"
    )
    imp = [*gj, "import", "csv", log, "--map", "time=time_ms,gyro_x=gx,gyro_y=gy,gyro_z=gz,acc_x=ax,acc_y=ay,acc_z=az"]
    imp += ["--time-unit", "ms", "--gyro-unit", "counts", "--gyro-scale", "131", "--acc-unit", "counts"]
    imp += ["--acc-scale", "16384", "--out", folder / "rec", "--force"]
    noise = [*gj, "noise", folder / "rec", "--json"]
    if args.cold:
        c_imp, c_noise = measure(imp, env), measure(noise, env)
        print(f"first runs (empty compile cache): import {c_imp[0]:.1f} s, noise {c_noise[0]:.1f} s")
    else:
        measure(noise if (folder / "rec").exists() else imp, env)  # warm the cache (and the page cache)
    w_imp, w_noise = measure(imp, env), measure(noise, env)
    ref = measure([sys.executable, "-c", REFERENCE, log, args.rate, "log"])
    ours, theirs = json.loads(w_noise[3]), json.loads(ref[3])
    agree, denser, table = [], False, None
    for c, r in zip(("gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z"), ("gx", "gy", "gz", "ax", "ay", "az")):
        key = "adev_deg_per_h" if c.startswith("gyro") else "adev_mps2"
        a, taus = np.asarray(ours["channels"][c][key]), np.asarray(ours["channels"][c]["taus_s"])
        scale = 3600.0 / 131.0 if c.startswith("gyro") else 9.80665 / 16384.0
        if len(taus) == len(theirs[r]["taus"]) and np.allclose(taus, theirs[r]["taus"], rtol=1e-9, atol=0):
            b = np.asarray(theirs[r]["adev"])
        else:  # under 2^19 rows the record is read whole and its τ grid is denser: allantools there, untimed
            import allantools

            denser = True
            if table is None:
                table = np.loadtxt(log, delimiter=",", skiprows=2)
            y = table[:, 1 + ("ax", "ay", "az", "gx", "gy", "gz").index(r)]
            b = allantools.oadev(y, rate=args.rate, data_type="freq", taus=taus)[1]
        agree.append(np.max(np.abs(a / (b * scale) - 1.0)))
    print("\nrest log, fresh processes (warm compile cache):")
    print(f"  gyrojax import csv           {w_imp[0]:6.1f} s wall, {w_imp[2]:6.1f} s CPU, peak {w_imp[1]:6.0f} MB")
    print(
        f"  gyrojax noise                {w_noise[0]:6.1f} s wall, {w_noise[2]:6.1f} s CPU, peak {w_noise[1]:6.0f} MB"
    )
    total = w_imp[0] + w_noise[0]
    print(f"  import + noise               {total:6.1f} s wall (target ≤ 60 s, ≤ 2 GB)")
    print(f"  pandas + allantools + fit    {ref[0]:6.1f} s wall, {ref[2]:6.1f} s CPU, peak {ref[1]:6.0f} MB")
    print(
        f"  ratio (import + noise) / reference: {total / ref[0]:.2f}× wall, {(w_imp[2] + w_noise[2]) / ref[2]:.2f}× CPU"
    )
    grid = "our denser τ grid (allantools again, untimed)" if denser else "the octave taus"
    print(f"  largest |ours/allantools − 1| over {grid} and 6 channels: {max(agree):.1e}")

    rec = sdf_record(folder / "sdf", args.n)
    rec4 = sdf_record(folder / "sdf4", 4 * args.n)
    noise1 = [*gj, "noise", rec, "--json"]
    measure(noise1, env)
    r1, r4 = measure(noise1, env), measure([*gj, "noise", rec4, "--json"], env)
    ref1 = measure([sys.executable, "-c", REFERENCE, rec, 1.0, "sdf"])
    print(f"\n{args.n}-sample record, fresh processes:")
    print(f"  gyrojax noise                {r1[0]:6.1f} s wall, {r1[2]:6.1f} s CPU, peak {r1[1]:6.0f} MB")
    print(f"  pandas + allantools + fit    {ref1[0]:6.1f} s wall, {ref1[2]:6.1f} s CPU, peak {ref1[1]:6.0f} MB")
    print(f"  ratio: {r1[0] / ref1[0]:.2f}× wall, {r1[2] / ref1[2]:.2f}× CPU (target ≤ 2)")
    print(f"  gyrojax noise of a record 4× longer: {r4[0]:.1f} s, peak {r4[1]:.0f} MB (memory flat in length)")


if __name__ == "__main__":
    main()
