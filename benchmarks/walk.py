"""The walk of a call's records through the package: which modules the public ``gj.diagnose`` passes through, how often
it moves between them, and how often it climbs back up the layers (a lower layer calling into a higher one: a
callback handed down, the noise package calling the inference's code).

Every Python call inside ``gyrojax`` during the second ``gj.diagnose`` of a process (the first one traces and loads
compiled code; the second walks the logic alone) is followed by :func:`sys.setprofile`: the files it enters, the
distinct calls from one file into another, and those that *climb*, whose callee's layer (tests/test_layers.py's
``LAYERS``, read from that file) is above the caller's. A climb through ``optimize`` or ``runtime`` is a function
handed to a minimiser or a thread pool; any other is a lower layer that knows a higher one. Run it on two checkouts
to compare them:

    python -m benchmarks.walk [--root DIR]          # DIR: the checkout whose gyrojax is imported (default: this one)

The campaigns: a polar tumble with D_S left out (4 records), and a simulated hand session of Ferraris' protocol with
two hidden effects (triad; refused by ``gj.diagnose`` before the triad joined the core).
"""

from __future__ import annotations

import argparse
import ast
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, os, sys
from pathlib import Path

import gyrojax as gj

root = Path(gj.__file__).resolve().parent
prefix = str(root) + os.sep
case = sys.argv[1]
if case == "tumble":
    truth = {"coefficients": {"D_F": 0.5, "D_I": 0.3, "D_S": -0.2, "D_O": 0.1}, "noise": {"white": 0.005}}
    records = gj.simulate(gj.plans.tumble(revolutions=2, dt_s=10.0), truth, seed=1)
    call = lambda: gj.diagnose(records, ("D_F", "D_I", "D_O"))
else:
    from gyrojax.planning.triad_protocol import ferraris_steps
    from gyrojax.simulation.triad_session import simulate_session

    c0, steps = ferraris_steps(60.0)
    truth = {"D_F[x]": 20.0, "E_SF[y]": 300.0}
    records = [simulate_session(steps, truth, start_attitude=c0, rate_hz=50.0, seed=1)]
    call = lambda: gj.diagnose(records)
call()
events = []


def profile(frame, event, arg):
    if event in ("call", "return"):
        f = frame.f_code.co_filename
        if f.startswith(prefix):
            caller = frame.f_back.f_code.co_filename if frame.f_back is not None else ""
            events.append((event, f[len(prefix):], caller[len(prefix):] if caller.startswith(prefix) else None))


sys.setprofile(profile)
call()
sys.setprofile(None)
print(json.dumps(events))
"""


def layers(root: Path) -> dict:
    """Package unit → tier index, from ``LAYERS`` of ``tests/test_layers.py`` under ``root``."""
    tree = ast.parse((root / "tests" / "test_layers.py").read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "LAYERS" for t in node.targets):
            tiers = ast.literal_eval(node.value)
            return {unit: i for i, tier in enumerate(tiers) for unit in tier}
    raise SystemExit(f"{root}/tests/test_layers.py: no LAYERS")


def unit(path: str) -> str:
    """The package unit of a file path relative to the package (``inference/diagnose.py`` → ``inference``)."""
    parts = path.split(os.sep)
    if len(parts) > 1:
        return parts[0]
    return "" if parts[0] == "__init__.py" else parts[0].removesuffix(".py")


def walk(events, tiers: dict) -> dict:
    """Files, the distinct calls between files and those among them that climb (module doc) of one profiled call."""
    files, edges = set(), set()
    for event, f, caller in events:
        files.add(f)
        if event == "call" and caller is not None and caller != f:
            edges.add((caller, f))
    climbing = sorted(f"{a} -> {b}" for a, b in edges if tiers.get(unit(b), -1) > tiers.get(unit(a), -1) >= 0)
    return {"files": sorted(files), "edges": len(edges), "climbing_edges": climbing}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--root", type=Path, default=HERE, help="the checkout to walk (its gyrojax and tests/)")
    ap.add_argument("--files", action="store_true", help="list the files entered")
    args = ap.parse_args(argv)
    root = args.root.resolve()
    tiers = layers(root)
    env = {**os.environ, "PYTHONPATH": str(root)}
    for case in ("tumble", "triad"):
        out = subprocess.run([sys.executable, "-c", CHILD, case], env=env, cwd=root, capture_output=True, text=True)
        if out.returncode:
            print(f"{case}: failed\n{out.stderr[-2000:]}")
            continue
        w = walk(json.loads(out.stdout.strip().splitlines()[-1]), tiers)
        n = len(w["climbing_edges"])
        print(f"{case}: {len(w['files'])} files, {w['edges']} distinct calls between files, {n} climbing:")
        for e in w["climbing_edges"]:
            print(f"    {e}")
        if args.files:
            print("  files: " + " ".join(w["files"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
