"""The hand protocol as text (:mod:`gyrojax.planning.triad_protocol`): the table a person follows and the predicted σ
beside Ferraris' and imu_tk's, with the criterion's ratio."""

from __future__ import annotations

import math


def advantage(crit, base_loss: float, design_loss: float, p: int) -> float:
    """How much better the design is than a baseline on the criterion (> 1: better): for D the ratio of the
    geometric mean σ, exp((loss_base − loss_design) / 2p); for A and c the ratio of the σ's, √(loss_base /
    loss_design)."""
    if crit.kind == "D":
        return math.exp((base_loss - design_loss) / (2.0 * p))
    return math.sqrt(base_loss / design_loss)


def table_text(table: list[dict]) -> str:
    """The protocol as a table a person follows: each rest, then its motions one a line."""
    lines = [
        f"{'step':>4}  {'face up (Up in the body frame)':<32} {'rest s':>7}  {'then':<11} {'turn about':<22}"
        f" {'angle':>7}  {'in s':>5}"
    ]
    for r in table:
        head = f"{r['step']:>4}  {r['up']:<32} {r['rest_s']:7.1f}  "
        if not r.get("motions"):
            lines.append(head + "(end)")
        for i, m in enumerate(r.get("motions", [])):
            lead = head if i == 0 else " " * len(head)
            lines.append(f"{lead}{m['kind']:<11} {m['turn_axis']:<22} {m['angle_deg']:6.1f}°  {m['turn_s']:5.1f}")
    lines.append(
        "known-angle: turn by exactly this angle about the body axis, back to a mark; free: turn roughly to the "
        "next rest (the accelerometer measures where it ends); not fitted: a reorientation the fit does not use"
    )
    return "\n".join(lines)


def comparison_text(rows: list[dict], crit, name: str | None = None) -> str:
    """Predicted σ of every coefficient, the design beside the baselines, and the criterion's ratio (``name``: the
    criterion as given, default its label)."""
    names = list(rows[0]["sigma"])
    p = len(names)
    heads = ["designed", "Ferraris", "imu_tk"][: len(rows)]
    lines = [f"{'coefficient':<12}" + "".join(f"{h:>12}" for h in heads)]
    for n in names:
        lines.append(f"{n:<12}" + "".join(f"{r['sigma'][n]:12.4g}" for r in rows))
    lines.append(f"{'criterion ' + (name or crit.label()):<12}" + "".join(f"{r['criterion']:12.5g}" for r in rows))
    ratio = [advantage(crit, r["criterion"], rows[0]["criterion"], p) for r in rows]
    what = "geometric-mean sigma" if crit.kind == "D" else "sigma"
    lines.append(f"{'ratio':<12}" + "".join(f"{x:12.3f}" for x in ratio) + f"   (baseline / designed {what})")
    lines.append("units: D_F deg/h; D_I, D_O, D_S deg/h/g; E_SF ppm; M_O, M_S arcsec; imu_tk: mean over draws")
    return "\n".join(lines)
