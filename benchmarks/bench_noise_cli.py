"""`gyrojax noise` on a 10⁶-sample record beside allantools.oadev at the same taus, warm (issue 16).

**The same taus.** The averaging times `gyrojax noise` evaluates by default (no ``--taus``): τ = m·τ0 for
m = :func:`gyrojax.noise.allan.default_m_list` of the record's length (10 per decade, 1 ≤ m ≤ n/3; 53 taus for
n = 10⁶). allantools gets exactly these, ``oadev(y, rate=1/τ0, data_type="freq", taus=m·τ0)``, on exactly the
samples the command analyses (the record's indicated rate in deg/h as gyrojax loads it).

Printed, each the best (and median) of ``--reps`` warm repetitions, the measurements interleaved:

* ``allantools.oadev`` and gyrojax's :func:`~gyrojax.noise.allan.overlapping_adev` on those samples and taus, with
  their largest relative difference;
* the whole command in this process, ``gyrojax.cli.app.main(["noise", CSV, "--json"])`` (output captured): the
  first call (compilation or persistent-cache load included) and the warm calls; their difference is the
  compile time;
* the command's stages, each timed by calling the same functions in the same order (load and validate the CSV, the
  static segments, the Allan deviation with its EDF band and IEEE 952 read-off, the Haar wavelet variance at the
  dyadic scales, the GMWM model selection, the model's ADEV band / adequacy / derived figures / JSON), and the
  ``--plot`` figure, which the command makes only when asked;
* as fresh processes: ``python -m gyrojax noise CSV --json`` with an empty persistent compilation cache (cold) and
  then warm, beside a plain process that reads the same CSV with pandas and runs ``allantools.oadev`` at the
  same taus (``--no-processes`` skips this part).

Ratios: whole command / ``allantools.oadev`` (in-process, the issue's target ≤ 5) and process / process.

    python -m benchmarks.bench_noise_cli [--n 1000000] [--record CSV] [--reps 7] [--no-processes]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.timing import run_process

ALLANTOOLS_PROCESS = r"""
import json, math, sys
import numpy as np, pandas as pd, allantools
csv = sys.argv[1]
meta = json.load(open(csv[:-4] + ".json"))
df = pd.read_csv(csv)
y = meta["scale_factor_deg_per_h_per_mA"] * df["current_mA"].to_numpy()
t = df["time_s"].to_numpy()
tau0 = (t[-1] - t[0]) / (len(t) - 1)
m = np.asarray(json.loads(sys.argv[2]))
taus, adev, _, _ = allantools.oadev(y, rate=1.0 / tau0, data_type="freq", taus=m * tau0)
print(len(taus), float(adev[0]))
"""


def _record(n: int, folder: Path) -> Path:
    """A static rebalance record of n samples at 1 Hz: white + random-walk drift (deg/h), saved as CSV + JSON."""
    from gyrojax import save_record, simulate
    from gyrojax.data import plans

    truth = {"noise": {"white": 0.002, "random_walk": 0.01, "gauss_markov": (0.005, 300.0)}}
    rec = simulate(plans.fixed_position(hours=n / 3600.0), truth, seed=1)[0]
    return save_record(rec, folder).with_suffix(".csv")


def _stats(ts) -> str:
    return f"{1e3 * min(ts):7.1f} ms (median {1e3 * float(np.median(ts)):7.1f})"


def _process(cmd, env=None) -> float:
    """Wall seconds of ``cmd`` as a fresh process (:func:`benchmarks.timing.run_process`)."""
    return run_process(cmd, env)[0]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000, help="samples of the simulated record")
    ap.add_argument("--record", help="an existing static record (CSV) instead of a simulated one")
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--no-processes", action="store_true")
    args = ap.parse_args(argv)

    import allantools

    from gyrojax.cli.app import main as cli
    from gyrojax.data.records import load_records
    from gyrojax.data.static import static_rate_segments
    from gyrojax.noise import allan, gmwm, readoff
    from gyrojax.runtime.cache import use_persistent_cache

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        csv = Path(args.record) if args.record else _record(args.n, folder)
        recs = load_records([csv])
        segs, tau0 = static_rate_segments(recs)
        y = segs[0]
        m = allan.default_m_list(max(len(s) for s in segs))
        print(f"record {csv.name}: n = {sum(len(s) for s in segs)} samples, τ0 = {tau0:g} s; {len(m)} taus")

        def command(*extra):
            with contextlib.redirect_stdout(io.StringIO()) as buf:
                rc = cli(["noise", str(csv), "--json", *extra])
            if rc != 0:
                raise SystemExit(f"gyrojax noise exited {rc}")
            return buf.getvalue()

        def report_rest(res, ieee, nm):
            """The rest of gyrojax.noise.readoff.noise_report after the fits: the model's ADEV ± its standard error,
            the adequacy band, derived figures and the JSON text."""
            model_adev, model_std = nm.adev(res.taus_s), readoff.adev_std(nm, res.taus_s)
            low95, high95 = allan.confidence_interval(res.adev, res.edf, readoff.ADEQUACY_CI)
            adq = readoff.adequacy(res.taus_s, res.adev, low95, high95, model_adev)
            out = allan.noise_json(res, ieee)
            out.update(
                model=nm.to_json(), derived=readoff.derived(nm, float(res.taus_s.min()), float(res.taus_s.max()))
            )
            out.update(adequacy=adq, adev_model_deg_per_h=list(map(float, model_adev)), std=list(map(float, model_std)))
            return json.dumps(out)

        use_persistent_cache()  # as the command does
        t = time.perf_counter()
        first_out = command()
        t_first = time.perf_counter() - t
        state = {}
        steps = {
            "load + validate the CSV": lambda: state.update(recs=load_records([csv])),
            "static segments, τ0": lambda: state.update(seg=static_rate_segments(state["recs"], notes=[])),
            "ADEV + EDF band + IEEE 952": lambda: state.update(an=allan.analyze(*state["seg"])),
            "Haar WV (dyadic ADEV)": lambda: state.update(wv=gmwm.WaveletVariance.of(*state["seg"])),
            "GMWM model selection": lambda: state.update(nm=gmwm.select_model(state["wv"])),
            "model band, adequacy, JSON": lambda: report_rest(*state["an"], state["nm"]),
        }
        png = folder / "noise.png"
        timings = {k: [] for k in ("allantools.oadev", "gyrojax overlapping_adev", "gyrojax noise (whole)", *steps)}
        timings["gyrojax noise --plot"] = []
        ours = ref = None
        for _ in range(args.reps):
            t = time.perf_counter()
            ref = allantools.oadev(y, rate=1.0 / tau0, data_type="freq", taus=m * tau0)[1]
            timings["allantools.oadev"].append(time.perf_counter() - t)
            t = time.perf_counter()
            ours = np.asarray(allan.overlapping_adev(y, tau0, m))
            timings["gyrojax overlapping_adev"].append(time.perf_counter() - t)
            t = time.perf_counter()
            out = command()
            timings["gyrojax noise (whole)"].append(time.perf_counter() - t)
            for k, f in steps.items():
                t = time.perf_counter()
                f()
                timings[k].append(time.perf_counter() - t)
            t = time.perf_counter()
            command("--plot", str(png), "--force")
            timings["gyrojax noise --plot"].append(time.perf_counter() - t)
        assert json.loads(out) == json.loads(first_out), "the warm run must print what the first printed"
        adev_json = np.asarray(json.loads(out)["adev_deg_per_h"])
        t_ref = min(timings["allantools.oadev"])
        t_all = min(timings["gyrojax noise (whole)"])
        t_plot = min(timings["gyrojax noise --plot"])

        print(f"\nin this process, warm (best of {args.reps}):")
        print(f"  allantools.oadev           {_stats(timings['allantools.oadev'])}")
        print(
            f"  gyrojax overlapping_adev   {_stats(timings['gyrojax overlapping_adev'])}   "
            f"{min(timings['gyrojax overlapping_adev']) / t_ref:.2f}× allantools; "
            f"max |ours/allantools − 1| = {np.max(np.abs(ours / ref - 1)):.1e} "
            f"(the command's JSON: {np.max(np.abs(adev_json / ref - 1)):.1e})"
        )
        print(
            f"  gyrojax noise, whole       {_stats(timings['gyrojax noise (whole)'])}   "
            f"{t_all / t_ref:.2f}× allantools.oadev (target ≤ 5; median/median "
            f"{np.median(timings['gyrojax noise (whole)']) / np.median(timings['allantools.oadev']):.2f}×)"
        )
        print(f"    first call {1e3 * t_first:.0f} ms: compile / cache load {1e3 * (t_first - t_all):.0f} ms")
        for k in steps:
            print(f"    {k:28s} {_stats(timings[k])}")
        print(f"    sum of the stages            {1e3 * sum(min(timings[k]) for k in steps):7.1f} ms")
        plot = _stats(timings["gyrojax noise --plot"])
        print(f"  with --plot PNG            {plot}   (the figure {1e3 * (t_plot - t_all):.0f} ms, only when asked)")

        if args.no_processes:
            return
        env = dict(os.environ, GYROJAX_CACHE_DIR=str(folder / "jax-cache"))
        cmd = [sys.executable, "-m", "gyrojax", "noise", str(csv), "--json"]
        t_cold = _process(cmd, env)
        warm, base = [], []
        for _ in range(3):
            warm.append(_process(cmd, env))
            base.append(_process([sys.executable, "-c", ALLANTOOLS_PROCESS, str(csv), json.dumps(m.tolist())]))
        print("\nas fresh processes (best of 3):")
        print(f"  python + pandas.read_csv + allantools.oadev   {min(base):6.2f} s")
        print(
            f"  gyrojax noise, warm compile cache            {min(warm):6.2f} s   {min(warm) / min(base):.2f}× "
            f"(empty cache: {t_cold:.2f} s)"
        )


if __name__ == "__main__":
    main()
