"""Classical test plans as baselines: their Fisher information at equal measured time, beside designed plans, in
one comparison table (the criteria of :mod:`gyrojax.planning.criteria`).
"""

from __future__ import annotations

import numpy as np

from gyrojax.data import plans
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model
from gyrojax.planning.criteria import criterion_values
from gyrojax.planning.fisher import DEFAULT_NOISE, record_fisher


def measured_seconds(plan: plans.Plan) -> float:
    """Total measured time of a plan in s: the sum of its segments' durations (gaps excluded)."""
    return sum(s.duration_s for r in plan.runs for s in r.segments)


def baseline_plans(hours: float = 4.0) -> dict:
    """Classical plans of about ``hours`` of measurement (Fisher information is then normalised to ``hours``)."""
    out = {}
    for n in sorted(plans.MULTIPOSITION_SETS):
        out[f"multiposition-{n}"] = plans.multiposition(n, minutes=hours * 60.0 / n)
    out["eight-position (Hu, fixture)"] = plans.eight_position(minutes=hours * 60.0 / 8)
    out["tumble (flip, CW/CCW)"] = plans.with_dt(plans.tumble(revolutions=1.0), 20.0)
    out["servo polar"] = plans.with_dt(plans.servo("polar", hours=24.0), 60.0)
    return out


def compare(
    terms, hours: float = 4.0, noise: NoiseSpec | None = None, designed: dict | None = None, kind: str = fx.SDF
) -> list[dict]:
    """Criterion values and Cramér–Rao stds of classical plans (and designed ones), all at ``hours`` of data.

    White noise: F scales with measured time, so every plan's F is scaled by hours/(its measured hours).
    """
    from gyrojax.simulation.simulator import simulate

    model = Model.of(terms, kind)
    noise = DEFAULT_NOISE if noise is None else noise
    rows = []
    for name, plan in baseline_plans(hours).items():
        f = record_fisher(model, simulate(plan, {"coefficients": {}}), noise)
        f = f * hours * 3600.0 / measured_seconds(plan)
        rows.append({"plan": name, **criterion_values(f, model)})
    for name, res in (designed or {}).items():
        rows.append({"plan": name, **criterion_values(res.fisher * hours * 3600.0 / res.dwell_s.sum(), model)})
    return rows


def table_text(rows: list[dict]) -> str:
    """Side-by-side text table: D, A and the Cramér–Rao std of every coefficient."""
    names = list(rows[0]["std"])
    head = f"{'plan':32s} {'D=logdet':>10s} {'A=tr':>10s} " + " ".join(f"{c:>9s}" for c in names)
    lines = [head, "-" * len(head)]
    for r in rows:
        stds = " ".join(f"{v:9.2e}" if np.isfinite(v) else f"{'inf':>9s}" for v in r["std"].values())
        lines.append(f"{r['plan'][:32]:32s} {r['D']:10.3f} {r['A']:10.3e} {stds}")
    return "\n".join(lines)
