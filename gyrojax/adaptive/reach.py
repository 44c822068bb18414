"""What no test on the lab's table can reach, and what table would.

A requirement (:mod:`gyrojax.adaptive.requirements`) is out of reach when its coefficient lies on a null direction
of its sub-model's information even with every orientation the table can take added to the records: the records'
information plus the rows of ``samples`` random angle sets of the chain (within the angle limits) at every
mounting the lab allows, each part normalised to its largest entry. Random angles reach every direction a set of
orientations can (a direction that some orientation sees is seen by almost every random draw).

The message names the invisible combination in report units and what would reach it: the case turned on its faces
on the same table, when the lab keeps one mounting and turning it separates it; a two-axis table
(``plans.TWO_AXIS``: trunnion East, platform Up) with the case turned on its faces, when that table separates it;
else, for the acceleration terms of the drift model, a specific force other than 1 g (a_I² + a_O² + a_S² = 1 in
every orientation on the ground: only a centrifuge changes it); else an outside measurement (levelling or
surveying the base, calibrating the angle readout).
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.adaptive.information import rows
from gyrojax.adaptive.requirements import sigmas
from gyrojax.data import plans
from gyrojax.physics import effects as fx
from gyrojax.physics.kept_model import kept_jit

SAMPLES = 64
"""Random angle sets per mounting."""
G_TERMS = {"D_I", "D_O", "D_S", "D_II", "D_OO", "D_SS", "D_IO", "D_IS", "D_OS", "D_F"}


def reachable_information(uni, lab, samples: int = SAMPLES, seed: int = 0) -> np.ndarray:
    """Σ over the lab's mountings and ``samples`` random angle sets (deg, uniform within each axis' limits, else on
    [0, 360)) of the rows' outer products (unit weights), normalised to its largest entry (dimensionless)."""
    rng = np.random.default_rng(seed)
    k = len(lab.axes)
    ang = np.empty((samples, k))
    for i, lim in enumerate(lab.limited()):
        lo, hi = (0.0, 360.0) if lim is None else lim
        ang[:, i] = rng.uniform(lo, hi, samples)
    table = lab.table()
    h = np.asarray(mounting_rows(uni)(table.template, jnp.asarray(lab.mountings()), jnp.deg2rad(jnp.asarray(ang))))
    h = h.reshape(-1, uni.size)
    f = h.T @ h
    return f / max(np.abs(f).max(), 1e-300)


@lru_cache(maxsize=16)
def mounting_rows(uni):
    """Rows of every mounting at a set of angles, compiled once per universe (kept across processes,
    :func:`gyrojax.physics.kept_model.kept_jit`): f(template, triads, angles rad)."""
    from gyrojax.planning.fisher import Table

    def at(template, triads, ang):
        table = Table.of_template(template)
        times = jnp.zeros(ang.shape[0])
        return jax.vmap(lambda t: rows(uni, table, t, ang, times, jnp.zeros(uni.size)))(triads)

    return kept_jit("mounting_rows", uni, at)


def _normalised(f: np.ndarray) -> np.ndarray:
    return f / max(np.abs(f).max(), 1e-300)


def out_of_reach(uni, reqs, f_rec, lab) -> list:
    """[(requirement, reason)] of the requirements no test on ``lab``'s table reaches (module doc)."""
    f = _normalised(f_rec) + reachable_information(uni, lab)
    s = sigmas(f, reqs, uni)
    bad = [r for r, x in zip(reqs, s) if not math.isfinite(x)]
    if not bad:
        return []
    two = turned = None
    out = []
    for r in bad:
        combo = _null_combination(f, uni, r)
        if two is None:
            lab2 = replace(lab, axes=plans.TWO_AXIS, angle_limits_deg=(), turn_case=True)
            two = _normalised(f_rec) + reachable_information(uni, lab2)
            if not lab.turn_case:
                turned = _normalised(f_rec) + reachable_information(uni, replace(lab, turn_case=True))
        if turned is not None and math.isfinite(sigmas(turned, [r], uni)[0]):
            fix = "the case turned on its faces on this table (remounted between runs) separates it"
        elif math.isfinite(sigmas(two, [r], uni)[0]):
            fix = "a two-axis table (trunnion East, platform Up) with the case turned on its faces separates it"
        elif {fx.effect_of_coefficient(c) for c, _ in combo} <= G_TERMS:
            fix = (
                "no test in a 1 g field separates it (a_I² + a_O² + a_S² = 1 in every orientation on the ground): "
                "only a different specific force, on a centrifuge, would"
            )
        else:
            fix = "only an outside measurement (levelling or surveying the base, calibrating the angle readout) would"
        text = " + ".join(f"{v:.3g}·{c}" for c, v in combo)
        out.append(
            (
                r,
                f"no orientation of this table separates {r.coefficient}: {text} is invisible to every test on it "
                f"(the records and {SAMPLES} random angle sets at each of {len(lab.mountings())} mountings); {fix}",
            )
        )
    return out


def _null_combination(f, uni, req) -> list:
    """The null direction of ``req``'s sub-model through its coefficient, in report units scaled to a largest
    entry of 1: [(coefficient, value)]."""
    names = uni.coefficient_names
    keep = [i for i, c in enumerate(names) if fx.effect_of_coefficient(c) in req.effects]
    sub = f[np.ix_(keep, keep)]
    d = np.sqrt(np.maximum(np.diag(sub), 1e-300))
    ev, vec = np.linalg.eigh(sub / np.outer(d, d))
    j = keep.index(names.index(req.coefficient))
    null = np.flatnonzero(ev < 1e-10 * ev[-1])
    if not null.size:
        return [(req.coefficient, 1.0)]
    v = vec[:, null[np.argmax(np.abs(vec[j, null]))]] / d
    v = v / np.abs(v).max()
    return [(names[i], float(x)) for i, x in zip(keep, v) if abs(x) > 1e-3]
