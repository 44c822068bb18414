"""``python -m benchmarks``: run every benchmark script in turn (each prints its own table of ratios)."""

import pkgutil
import runpy
import sys
from pathlib import Path

if __name__ == "__main__":
    names = sorted(m.name for m in pkgutil.iter_modules([str(Path(__file__).parent)]) if m.name.startswith("bench_"))
    only = sys.argv[1:]
    for name in names:
        if only and name not in only:
            continue
        print(f"\n=== benchmarks.{name} ===", flush=True)
        runpy.run_module(f"benchmarks.{name}", run_name="__main__")
