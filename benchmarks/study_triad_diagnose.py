"""The triad diagnosis' level on null hand sessions: how often is a session with only noise planted ``adequate``?

Each draw is a 20-pose hand session (tests/test_triad_diagnose.py's ``session``: latitude known, MEMS-sized linear
errors) with Gauss–Markov drift (30 deg/h, τ 20 s) on every channel, bias steps of 20 deg/h at each move and a
0.1° angle error per move — the noise of the Xsens kind, no deterministic effect. Prints the fraction of draws whose
verdict is ``adequate`` (issue 24 asks ≥ 95 % of 40 seeds at α = 0.01), the draws with a proposal, and the names
of what was found significant in the others.

``xsens`` instead of a number diagnoses imu_tk's vendored Xsens recording (tests/data/imutk, imported with imu_tk's
starting values) and prints the text of docs/mems_imu.md's finding.

Run: python -m benchmarks.study_triad_diagnose [draws | xsens]
"""

from __future__ import annotations

import sys
import time
import warnings

from gyrojax.inference.diagnose import diagnose
from gyrojax.report.text import diagnosis_text
from tests.test_triad_diagnose import session


def main(draws: int = 40) -> None:
    t0 = time.time()
    adequate, proposals, found = 0, 0, []
    for seed in range(draws):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            d = diagnose(session(100 + seed, gm=(30.0, 20.0), move_deg=0.1, step_dph=20.0), vet=False)
        adequate += d.verdict == "adequate"
        proposals += d.proposal is not None
        if d.verdict != "adequate":
            sig = [c.name for c in d.candidates if c.df > 0 and c.p_adjusted < d.alpha]
            found.append((100 + seed, sig + [s.name for s in d.unexplained]))
        print(f"seed {100 + seed}: {d.verdict}", flush=True)
    print(f"adequate in {adequate} of {draws} null sessions ({adequate / draws:.3f}); proposals: {proposals}")
    for seed, names in found:
        print(f"  seed {seed}: {', '.join(names)}")
    print(f"{time.time() - t0:.0f} s")


def xsens() -> None:
    """The diagnosis of the Xsens recording (docs/mems_imu.md)."""
    import math
    import tempfile
    from pathlib import Path

    from gyrojax.cli.app import main as cli
    from gyrojax.data.records import load_records

    data = Path(__file__).resolve().parent.parent / "tests" / "data" / "imutk"
    out = tempfile.mkdtemp()
    args = ["import", "imutk", str(data / "xsens_acc.mat.gz"), str(data / "xsens_gyro.mat.gz")]
    cli(args + ["--gyro-scale", str(6258.0 * math.pi / 180.0), "--gravity", "9.81744", "--out", out])
    (rec,) = load_records(out)
    t0 = time.time()
    print(diagnosis_text(diagnose(rec)))
    print(f"{time.time() - t0:.0f} s")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "xsens":
        xsens()
    else:
        main(int(sys.argv[1]) if len(sys.argv) > 1 else 40)
