"""Where users wait: the diagnoses of the speed issue's table as processes and the first call of a notebook, this
checkout beside another (the previous commit) run alternately in the same run.

Rows, each a fresh process (wall and CPU seconds of the child; the CPU reading is the one a loaded machine disturbs
least), this checkout (``new``) and the one in ``--baseline-dir`` (``old``), each with its own ``.venv`` when it has
one (the versions of its lock; :func:`benchmarks.timing.python_of`):

* ``gyrojax diagnose --json`` of imu_tk's Xsens hand session (tests/data/imutk, 51 175 samples, imported here with
  imu_tk's scale and gravity), the persistent compilation cache warm (filled by a run before);
* ``gyrojax diagnose --json`` of a two-axis TDF campaign: the 24-position set of ``multiposition`` with a TDF gyro
  (X East-ish, Y, spin Z; two channels), 10 min per position at 1 s, simulated here; cache warm;
* ``gyrojax next --json`` after the first test of the campaign study's truth 13 (:mod:`benchmarks.study_campaign`:
  its polar tumble, 30 s samples, D_SS and D_IO hidden), on the study's two-axis table: a step whose test takes all
  the hours a test may; cache empty (the compiling apart: cold − warm) and warm;
* the first ``gj.diagnose`` of a script that imports gyrojax, on the demo's campaign (a polar tumble, 4 records,
  34 464 samples), against the second call in the same process: gyrojax's cache (``GYROJAX_CACHE_DIR``, a fresh
  folder) filled by a diagnosis of a campaign of another shape (the same tumble at 1 revolution, 10 s steps) and
  nothing else, so that this campaign's shapes are new to it; then again, the shapes seen by the run before (a
  notebook's second kernel); and with the cache empty.

Each diagnosis' JSON of ``new`` is compared with ``old``'s: the verdicts, the candidates' order and every number,
the largest relative change printed.

    python -m benchmarks.bench_waits --baseline-dir DIR [--repeat N] [--rows xsens,tdf,next,notebook]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import tempfile
from pathlib import Path

from benchmarks.timing import python_of, run_process

HERE = Path(__file__).resolve().parents[1]
XSENS_SCALE = 6258.0 * math.pi / 180.0  # imu_tk's nominal Xsens gyro scale, counts per deg/s
TDF_TRUTH = {
    "coefficients": {"DX_F": 0.3, "DY_F": -0.2, "DX_X": 0.1, "DY_Y": 0.05, "DX_XZ": 0.02},
    "noise": {"white": 0.001},
}

JAX_CACHE_VARIABLES = ("JAX_COMPILATION_CACHE_DIR", "JAX_PERSISTENT_CACHE_")
"""Environment variables of JAX's persistent compilation cache (prefixes)."""

NOTEBOOK = r"""
import json, sys, time
from pathlib import Path
import gyrojax as gj
recs = gj.load_records(sorted(Path(sys.argv[1]).glob("*.json")))
terms = ("D_F", "D_I", "D_S")
t = time.perf_counter(); c = time.process_time()
d = gj.diagnose(recs, terms)
first = (time.perf_counter() - t, time.process_time() - c)
t = time.perf_counter(); c = time.process_time()
gj.diagnose(recs, terms)
warm = (time.perf_counter() - t, time.process_time() - c)
print(json.dumps({"first": first, "warm": warm, "verdict": d.verdict}))
"""


def env_of(root: Path, cache: Path | None) -> dict:
    """The environment of a child process of the checkout ``root``: compilation cache off (``cache`` None) or in
    ``cache``. JAX's cache variables are dropped: this process' ``import gyrojax`` set them to the user's default
    cache folder, which a child's ``import gyrojax`` would then keep (a notebook's chosen cache), so that a
    "first call" would read every shape any earlier run compiled."""
    drop = ("GYROJAX_NO_CACHE", "GYROJAX_CACHE_DIR", "PYTHONPATH")
    env = {k: v for k, v in os.environ.items() if k not in drop and not k.startswith(JAX_CACHE_VARIABLES)}
    env["PYTHONPATH"] = str(root)
    if cache is None:
        env["GYROJAX_NO_CACHE"] = "1"
    else:
        env["GYROJAX_CACHE_DIR"] = str(cache)
    return env


def gyrojax(root: Path, args, cache: Path | None, cwd: Path) -> tuple[float, float, str]:
    """(wall s, CPU s, stdout) of ``gyrojax ARGS`` of the checkout ``root`` (exit 1, an inadequate model, is an
    answer)."""
    return run_process([python_of(root), "-m", "gyrojax", *map(str, args)], env=env_of(root, cache), ok=(0, 1), cwd=cwd)


def inputs(tmp: Path, rows) -> dict:
    """The records of ``rows``, written by this checkout: Xsens imported, the TDF campaign, the campaign study's
    first test and two tumbles simulated."""
    from gyrojax.data import plans
    from gyrojax.data.planfile import save_plan

    out = {}
    if "xsens" in rows:
        data = HERE / "tests" / "data" / "imutk"
        xs = tmp / "xsens"
        args = ["import", "imutk", data / "xsens_acc.mat.gz", data / "xsens_gyro.mat.gz", "--gyro-scale", XSENS_SCALE]
        gyrojax(HERE, [*args, "--gravity", "9.81744", "--out", xs], None, tmp)
        out["xsens"] = sorted(xs.glob("*.json"))
    if "tdf" in rows:
        mount = plans.tdf_mount((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
        save_plan(plans.multiposition(24, minutes=10.0, dt_s=1.0, mount=mount), tmp / "tdf24-plan.json", force=True)
        (tmp / "tdf-truth.json").write_text(json.dumps(TDF_TRUTH))
        tdf = tmp / "tdf"
        gyrojax(HERE, ["simulate", tmp / "tdf24-plan.json", "--truth", tmp / "tdf-truth.json", "--out", tdf], None, tmp)
        out["tdf"] = sorted(tdf.glob("*.json"))
    if "next" in rows:
        out["study"] = study(tmp)
    if "notebook" in rows:
        from gyrojax.report.demo import TRUTH

        (tmp / "tumble-truth.json").write_text(json.dumps(TRUTH))
        for name, opts in (("tumble", ("revolutions=2", "dt_s=2")), ("tumble-other", ("revolutions=1", "dt_s=10"))):
            o = [x for v in opts for x in ("-o", v)]
            args = ["simulate", "tumble", *o, "--truth", tmp / "tumble-truth.json", "--out", tmp / name]
            gyrojax(HERE, args, None, tmp)
            out[name] = tmp / name
    return out


def study(tmp: Path, truth: int = 13) -> Path:
    """The first test of the campaign study's ``truth`` as its campaign simulates it (noise key of test 0)."""
    import jax
    import numpy as np

    from benchmarks import study_campaign
    from gyrojax.data.records import save_record
    from gyrojax.simulation.simulator import simulate

    t = study_campaign.draw_truth(np.random.default_rng([0, truth]))
    key = jax.random.fold_in(jax.random.PRNGKey(truth), 0)
    out = tmp / "study"
    for r in simulate(study_campaign.first_test(), t, key=key):
        save_record(r, out)
    return out


def numbers(doc, path=""):
    """Every number of a JSON document with its path; strings and booleans as they are."""
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from numbers(v, f"{path}.{k}")
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from numbers(v, f"{path}[{i}]")
    else:
        yield path, doc


def largest_change(new: dict, old: dict) -> tuple[float, str, list]:
    """(largest relative change of a number, its path, paths whose strings, types or presence differ)."""
    a, b = dict(numbers(new)), dict(numbers(old))
    worst, where, differ = 0.0, "", sorted(set(a) ^ set(b))
    for k in set(a) & set(b):
        x, y = a[k], b[k]
        if isinstance(x, bool) or isinstance(y, bool) or not isinstance(x, (int, float)):
            if x != y:
                differ.append(k)
            continue
        if not isinstance(y, (int, float)):
            differ.append(k)
            continue
        if x == y or (math.isnan(x) and math.isnan(y)):
            continue
        rel = abs(x - y) / max(abs(x), abs(y), 1e-300)
        if rel > worst:
            worst, where = rel, k
    return worst, where, differ


def process_row(name: str, roots: dict, args, tmp: Path, repeat: int) -> None:
    """A diagnosis as a process, cache warm, ``repeat`` times alternately; best by CPU; the JSONs compared."""
    best, docs, warm_cpu = {}, {}, {}
    for i in range(repeat):
        for who, root in roots.items():
            cache = tmp / f"cache-{name}-{who}-{i}"
            cold = gyrojax(root, args, cache, tmp)
            warm = gyrojax(root, args, cache, tmp)
            docs[who] = json.loads(warm[2])
            warm_cpu.setdefault(who, []).append(warm[1])
            prev = best.get(who)
            if prev is None or warm[1] < prev[1][1]:
                best[who] = (cold[:2], warm[:2])
    for who, (cold, warm) in best.items():
        runs = warm_cpu[who]
        print(
            f"  {who}: warm {warm[0]:5.2f} s wall {warm[1]:5.2f} s CPU; first (cache empty) {cold[0]:5.2f} s wall "
            f"{cold[1]:5.2f} s CPU (best of {repeat} by CPU); warm CPU median {statistics.median(runs):5.2f} s "
            f"({' '.join(f'{x:.2f}' for x in runs)})"
        )
    if "old" in best:
        n, o = best["new"][1], best["old"][1]
        print(f"  new / old, warm: wall {n[0] / o[0]:.3f}, CPU {n[1] / o[1]:.3f}")
        worst, where, differ = largest_change(docs["new"], docs["old"])
        print(f"  JSON new vs old: largest relative change {worst:.2e} ({where or '-'}); differing entries {differ}")


SAID = {"unseen": "filled by another shape", "seen": "filled by this campaign", "empty": "empty"}


def notebook_row(roots: dict, rec: dict, tmp: Path, repeat: int) -> None:
    """The first ``gj.diagnose`` of a script on a shape new to the cache, and with the cache empty."""
    script = tmp / "notebook.py"
    script.write_text(NOTEBOOK)
    res = {w: {"unseen": [], "empty": [], "seen": []} for w in roots}
    for i in range(repeat):
        for who, root in roots.items():
            cache = tmp / f"cache-nb-{who}-{i}"
            run_process([python_of(root), script, rec["tumble-other"]], env=env_of(root, cache), cwd=tmp)
            # the same campaign's shapes new to the cache, then seen by the run before, then no cache at all
            for mode, c in (("unseen", cache), ("seen", cache), ("empty", tmp / f"cache-nb-empty-{who}-{i}")):
                out = run_process([python_of(root), script, rec["tumble"]], env=env_of(root, c), cwd=tmp)[2]
                res[who][mode].append(json.loads(out))
    for who, modes in res.items():
        for mode, runs in modes.items():
            b = min(runs, key=lambda d: d["first"][1] / d["warm"][1])
            f, w = b["first"], b["warm"]
            print(
                f"  {who}, cache {SAID[mode]}: first {f[0]:5.2f} s "
                f"wall {f[1]:5.2f} s CPU, warm {w[0]:5.2f} s wall {w[1]:5.2f} s CPU: first / warm {f[0] / w[0]:.2f} "
                f"wall, {f[1] / w[1]:.2f} CPU (best of {repeat}); verdict {b['verdict']}"
            )


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline-dir", type=Path, help="another checkout to run beside this one")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--rows", default="xsens,tdf,next,notebook")
    args = ap.parse_args(argv)
    roots = {"new": HERE} | ({"old": args.baseline_dir.resolve()} if args.baseline_dir else {})
    rows = args.rows.split(",")
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        rec = inputs(tmp, rows)
        print(f"load average {' '.join(f'{x:.1f}' for x in os.getloadavg())} (1, 5, 15 min) on {os.cpu_count()} cores")
        if "xsens" in rows:
            print("== gyrojax diagnose --json of imu_tk's Xsens session (51 175 samples), as a process ==")
            process_row("xsens", roots, ["diagnose", *rec["xsens"], "--json"], tmp, args.repeat)
        if "tdf" in rows:
            print("== gyrojax diagnose --json of a 24-position two-axis TDF campaign (two channels), as a process ==")
            process_row("tdf", roots, ["diagnose", *rec["tdf"], "--json"], tmp, args.repeat)
        if "next" in rows:
            print("== gyrojax next --json after the campaign study's first test (truth 13: a capped step) ==")
            cmd = ["next", rec["study"], "--terms", "D_F,D_I,D_S", "--target-sigma", "0.003", "--table", "two-axis"]
            cmd += ["--no-turn", "--mountings", "1", "--seed", "14", "--json", "--out", tmp / "next.json", "--force"]
            process_row("next", roots, cmd, tmp, args.repeat)
        if "notebook" in rows:
            print("== first gj.diagnose of a script on the demo campaign (4 records, 34 464 samples) / warm call ==")
            notebook_row(roots, rec, tmp, args.repeat)
        print(f"load average {' '.join(f'{x:.1f}' for x in os.getloadavg())} at the end")


if __name__ == "__main__":
    sys.exit(main())
