"""The main loop at interactive speed: fit, diagnose and the demo's loop on the demo campaign, beside numpy.

The campaign is the demo's (gyrojax/report/demo.py): a polar tumble, normal and flipped mountings, CCW and CW,
2 revolutions at 2 s steps (4 records, 34,464 samples), with effects hidden from the starting model D_F, D_I, D_S.

Printed:

* in this process, cold (first call: compilation included) and warm (second call): ``fit`` and ``diagnose`` of the
  starting model, and the demo's loop (fit → diagnose → add the effect the data ask for, until adequate); the
  difference cold − warm is the compilation time;
* as fresh processes on the records written to disk: ``gyrojax diagnose`` with an empty persistent compilation cache
  and again with the cache warm, beside a plain numpy reference process on the same files: read the CSVs, the same
  regressors (saved by this benchmark), ordinary least squares by ``numpy.linalg.lstsq`` and the score statistic
  r̃ᵀX⊥(X⊥ᵀX⊥)⁺X⊥ᵀr̃/σ̂² of every candidate effect (the diagnosis' test without the noise model);

with the ratios gyrojax / numpy. Targets (issue 16): the warm-cache ``gyrojax diagnose`` process at most 10× the
numpy process; the demo's steps under 30 s.

    python -m benchmarks.bench_mainloop [--quick] [--no-processes]
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

REFERENCE = r"""
import json, sys, time
t0 = time.perf_counter()
import numpy as np
folder = sys.argv[1]
meta = json.load(open(folder + "/design.json"))
z = np.load(folder + "/design.npz")
ys = []
for name, sf in zip(meta["records"], meta["scale"]):
    cur = np.loadtxt(f"{folder}/records/{name}.csv", delimiter=",", skiprows=1, usecols=meta["current_col"])
    ys.append(cur * sf)
y = np.concatenate(ys) - z["offset"]
j = z["design"]
j0 = j[:, : meta["p0"]]
beta, *_ = np.linalg.lstsq(j0, y, rcond=None)
r = y - j0 @ beta
q, _ = np.linalg.qr(j0)
sigma2 = float(r @ r) / (len(r) - j0.shape[1])
out = {}
for name, (a, b) in meta["candidates"].items():
    x = j[:, a:b]
    xp = x - q @ (q.T @ x)
    u, s, _ = np.linalg.svd(xp, full_matrices=False)
    u = u[:, s > 1e-7 * s[0]] if s.size and s[0] > 0 else u[:, :0]
    proj = u.T @ r
    out[name] = float(proj @ proj) / sigma2
top = max(out, key=out.get)
print(json.dumps({"seconds": time.perf_counter() - t0, "top": top, "statistic": out[top]}))
"""


def _campaign(quick: bool):
    from gyrojax.data import plans
    from gyrojax.report.demo import TRUTH
    from gyrojax.simulation.simulator import simulate

    plan = plans.tumble(revolutions=1.0 if quick else 2.0, dt_s=10.0 if quick else 2.0)
    return simulate(plan, TRUTH, seed=7)


def _write(records, folder: Path, start_terms) -> None:
    """The records as CSV + JSON, and the regressors of the starting model and of every candidate at θ = 0."""
    from gyrojax.data.records import save_record
    from gyrojax.inference.campaign import Campaign, linearize
    from gyrojax.inference.diagnose import candidate_effects
    from gyrojax.physics.model import Model

    for r in records:
        save_record(r, folder / "records")
    camp = Campaign.of(records)
    model = Model(tuple(start_terms), camp.kind)
    cands = candidate_effects(model, camp)
    full = Model(model.terms + tuple(cands), camp.kind)
    lin = linearize(full, np.zeros(full.size), camp)
    design = np.concatenate([j for _, j, *_ in lin])
    r0 = np.concatenate([r for r, *_ in lin])
    header = (folder / "records" / f"{records[0].name}.csv").read_text().splitlines()[0].split(",")
    col = header.index("current_mA")
    scale = [
        float(json.loads((folder / "records" / f"{r.name}.json").read_text())["scale_factor_deg_per_h_per_mA"])
        for r in records
    ]
    y = np.concatenate(
        [
            np.loadtxt(folder / "records" / f"{r.name}.csv", delimiter=",", skiprows=1, usecols=col) * s
            for r, s in zip(records, scale)
        ]
    )
    np.savez(folder / "design.npz", design=design, offset=y - r0)
    sl = full.slices()
    meta = {
        "records": [r.name for r in records],
        "scale": scale,
        "current_col": col,
        "p0": model.size,
        "candidates": {c: [sl[c].start, sl[c].stop] for c in cands},
    }
    (folder / "design.json").write_text(json.dumps(meta))


def _process(cmd, env=None) -> tuple[float, str]:
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True, env=env)
    dt = time.perf_counter() - t0
    if out.returncode not in (0, 1):
        raise RuntimeError(f"{cmd[:4]} failed: {out.stderr[-2000:]}")
    return dt, out.stdout


def _loop(records, camp):
    """The demo's loop without the report: fit, diagnose, add the picked effect, until adequate. Returns
    (seconds per step, terms per step, verdicts)."""
    from gyrojax.inference.diagnose import diagnose
    from gyrojax.inference.identify import fit
    from gyrojax.report.demo import START_TERMS, _pick

    terms, times, steps, verdicts = START_TERMS, [], [], []
    for _ in range(8):
        t0 = time.perf_counter()
        res = fit(records, terms, campaign=camp)
        d = diagnose(records, terms, result=res, campaign=camp)
        times.append(time.perf_counter() - t0)
        steps.append(terms)
        verdicts.append(d.verdict)
        if d.verdict == "adequate":
            break
        terms = terms + (_pick(d)[0],)
    return times, steps, verdicts


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="1 revolution at 10 s steps (a smoke run)")
    ap.add_argument("--no-processes", action="store_true", help="skip the fresh-process comparison")
    args = ap.parse_args(argv)

    from gyrojax.inference.campaign import Campaign
    from gyrojax.inference.diagnose import diagnose
    from gyrojax.inference.identify import fit
    from gyrojax.report.demo import START_TERMS

    records = _campaign(args.quick)
    camp = Campaign.of(records)
    n = sum(r.n for r in records)
    print(f"demo campaign: {len(records)} records, {n} samples; starting model {', '.join(START_TERMS)}")

    def timed(f):
        t0 = time.perf_counter()
        out = f()
        return time.perf_counter() - t0, out

    t_fit_cold, res = timed(lambda: fit(records, START_TERMS, campaign=camp))
    t_fit_warm, res = timed(lambda: fit(records, START_TERMS, campaign=camp))
    t_diag_cold, d = timed(lambda: diagnose(records, START_TERMS, result=res, campaign=camp))
    t_diag_warm, d = timed(lambda: diagnose(records, START_TERMS, result=res, campaign=camp))
    compile_fit = t_fit_cold - t_fit_warm
    print(f"  fit       cold {t_fit_cold:7.2f} s  warm {t_fit_warm:7.2f} s  (compile ≈ {compile_fit:.2f} s)")
    print(
        f"  diagnose  cold {t_diag_cold:7.2f} s  warm {t_diag_warm:7.2f} s  (compile ≈ "
        f"{t_diag_cold - t_diag_warm:.2f} s); verdict {d.verdict}, top {d.candidates[0].name}"
    )
    loop_cold, steps, verdicts = _loop(records, camp)
    loop_warm, _, _ = _loop(records, camp)
    path = " → ".join("+" + s[-1] if i else ",".join(s) for i, s in enumerate(steps))
    print(
        f"  demo loop ({len(steps)} steps: {path};"
        f" {verdicts[-1]}): after the two calls above {sum(loop_cold):.2f} s, warm {sum(loop_warm):.2f} s "
        f"(per step {', '.join(f'{t:.1f}' for t in loop_warm)} s)"
    )

    if args.no_processes:
        return
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        _write(records, folder, START_TERMS)
        files = sorted(str(p) for p in (folder / "records").glob("*.csv"))
        t_ref, out = _process([sys.executable, "-c", REFERENCE, str(folder)])
        ref = json.loads(out.strip().splitlines()[-1])
        t_ref2, _ = _process([sys.executable, "-c", REFERENCE, str(folder)])
        t_ref = min(t_ref, t_ref2)
        env = dict(os.environ, GYROJAX_CACHE_DIR=str(folder / "jax-cache"))
        cmd = [sys.executable, "-m", "gyrojax", "diagnose", *files, "--terms", ",".join(START_TERMS), "--json"]
        t_cold, _ = _process(cmd, env)
        t_warm, out = _process(cmd, env)
        top = json.loads(out.strip().splitlines()[-1])["candidates"][0]["name"]
        print(
            f"  numpy OLS + score tests process: {t_ref:.2f} s (in-process work {ref['seconds']:.3f} s; "
            f"top {ref['top']}, S = {ref['statistic']:.0f})"
        )
        print(
            f"  gyrojax diagnose process: empty cache {t_cold:.2f} s ({t_cold / t_ref:.1f}× numpy), "
            f"warm cache {t_warm:.2f} s ({t_warm / t_ref:.1f}× numpy; target ≤ 10×); top {top}"
        )


if __name__ == "__main__":
    main()
