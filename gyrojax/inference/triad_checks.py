"""What the triad fit checks at its boundary, so that it is never silent about an answer it cannot give well.

* **g-terms need the specific force.** A rest of unknown orientation or a rotation without an accelerometer (a
  gyro-only session, :mod:`gyrojax.data.gyroonly`) has no specific force to multiply the g-sensitivities by: the
  default model leaves them out (and says so), asked-for g-terms are refused naming the segments
  (:func:`terms_for_force`).
* **Plausible sizes.** The fitted scale factors and misalignment angles are compared with the MEMS limits of
  :data:`gyrojax.physics.plausibility.MEMS_PLAUSIBLE_MAX` (scale factor within 20 %, misalignment within 10°);
  beyond them the fit says so, and names the flag the evidence points to (:func:`plausibility_notes`): scale factors
  of all three channels off by one common ratio are a unit, a clock or a nominal scale (a triad's three scale errors
  are not equal), a scale-and-misalignment matrix close to a signed permutation is a column mapping.
* **A fit that diverges** names the flag too (:func:`divergence_hint`): the moves' gravity directions (or the
  rotations' known axes) are matched by the gyro's integrated angles under every signed permutation of the channels
  and a common scale; the best match, far better than the identity's, is a ``--map`` error, and its scale a unit,
  clock or nominal-scale error (:mod:`gyrojax.data.importclues` words both).
"""

from __future__ import annotations

import math

import numpy as np

from gyrojax import units
from gyrojax.data.importclues import MEMS_SCALE_BOUND, permutation_clue, ratio_clue, signed_permutations
from gyrojax.errors import ModelError
from gyrojax.optimize import minimize_scalar
from gyrojax.physics import so3
from gyrojax.physics import triad as tp
from gyrojax.physics.plausibility import limit

G_EFFECTS = ("D_I", "D_O", "D_S", "D_II", "D_OO", "D_SS", "D_IO", "D_IS", "D_OS")
"""The effects that multiply the specific force (they need it at every segment)."""
COMMON_RATIO_SPREAD = 0.05
"""Relative spread of the three channels' scale factors below which their error is one common ratio."""
PERMUTATION_WIN = 0.5
"""A signed permutation explains the data when its median misfit is below this fraction of the identity's."""
MOVE_MATCH_DEG = 10.0
"""Median angle left at the moves by the best signed permutation and scale for it to count as evidence."""


def unknown_force_segments(segments) -> list[str]:
    """The names of the segments whose specific force is unknown (``info["up"]`` None: no accelerometer, no Up)."""
    return [s.name for s in segments if "up" in s.info and s.info["up"] is None]


def terms_for_force(terms, segments, default: bool) -> tuple[tuple, list]:
    """``terms`` fitted where the segments have no specific force: the default model without its g-terms (with a
    note), or a :class:`~gyrojax.errors.ModelError` naming the asked-for g-terms and the segments without it."""
    blind = unknown_force_segments(segments)
    g = [t for t in terms if t in G_EFFECTS]
    if not blind or not g:
        return tuple(terms), []
    shown = ", ".join(blind[:4]) + (" …" if len(blind) > 4 else "")
    if default:
        note = (
            f"no specific force in {len(blind)} segment(s) ({shown}: no accelerometer and no 'up'): the g-terms "
            f"{', '.join(g)} are left out of the model (their effect on the bias is part of D_F)"
        )
        return tuple(t for t in terms if t not in G_EFFECTS), [note]
    raise ModelError(
        f"the g-sensitivities {', '.join(g)} need the specific force of every segment, and {len(blind)} have none "
        f"({shown}: no accelerometer columns and no 'up'); fit without them or record the accelerometer"
    )


def plausibility_notes(values: dict) -> list[str]:
    """Sentences for a scale factor or a misalignment beyond the MEMS limits (module doc), each naming the flag the
    evidence points to; ``values``: per-channel coefficients in report units (``E_SF[x]`` ppm, ``M_O[y]``
    arcsec …). The misalignments are compared as angles (:func:`gyrojax.physics.triad.misalignment_angles`), so a
    wrong nominal scale does not make them look large. (The bias limit is left to ``diagnose``: raw counts of an
    unsigned converter carry a mid-scale offset of tens of thousands of counts.)"""
    notes = []
    sf = [values.get(tp.channel_name("E_SF", c)) for c in tp.CHANNELS]
    sf_lim = limit("E_SF", kind="imu-triad")
    if all(x is not None for x in sf) and any(abs(x) > sf_lim for x in sf):
        r = 1.0 + np.array(sf) * units.PPM
        sf_text = ", ".join(f"E_SF[{c}] = {x * units.PPM * 100:+.3g} %" for c, x in zip(tp.CHANNELS, sf))
        bound = f"a MEMS gyro's scale factor is within ±{sf_lim * units.PPM * 100:g} % of nominal"
        head = f"implausible: {sf_text} ({bound})"
        if np.all(r > 0) and np.ptp(np.log(r)) < COMMON_RATIO_SPREAD:
            rr = float(np.exp(np.mean(np.log(r))))
            notes.append(f"{head}, one common ratio {rr:.4g} on every channel: {ratio_clue(rr)}")
        else:
            notes.append(f"{head}: check the nominal scale (--gyro-scale) and the gyro's unit (--gyro-unit)")
    if any(tp.channel_name("M_O", c) in values for c in tp.CHANNELS):
        m_lim = limit("M_O", kind="imu-triad")
        angles = tp.misalignment_angles(values)
        bad = {k: a["value"] for k, a in angles.items() if not k.startswith("psi") and abs(a["value"]) > m_lim}
        if bad:
            shown = ", ".join(f"{k} = {v / 3600:.3g}°" for k, v in bad.items())
            p = _nearest_permutation(tp.matrices(values)["S"])
            if p is not None and not np.allclose(p, np.eye(3)):
                notes.append(
                    f"implausible: misalignment angles {shown} (beyond {m_lim / 3600:g}°): {permutation_clue(p)}"
                )
            else:
                notes.append(
                    f"implausible: misalignment angles {shown} (a MEMS triad's axes are within {m_lim / 3600:g}° of "
                    "the body frame): check --map"
                )
    return notes


def _nearest_permutation(s: np.ndarray) -> np.ndarray | None:
    """The signed permutation nearest the rows of ``s`` normalised, when every row is within 30° of it."""
    rows = s / np.linalg.norm(s, axis=1, keepdims=True)
    best = max(signed_permutations(), key=lambda p: float(np.sum(rows * p)))
    cos = np.sum(rows * best, axis=1)
    return best if np.all(cos > math.cos(math.radians(30.0))) else None


def _carried_misfit(moves, bias, p, k) -> np.ndarray:
    """Angle (deg) of each move between the next Up and the previous Up carried by k·P·(gyro − bias), integrated
    sample by sample (each step's rotation vector exact)."""
    out = []
    for m in moves:
        steps = (m.g - bias) @ p.T * (k * m.dt * units.DEG_PER_H)
        rot = np.eye(3)
        for e in so3.exp(steps):
            rot = rot @ e
        pred = rot.T @ m.u_from
        out.append(math.degrees(math.acos(max(-1.0, min(1.0, float(pred @ m.u_to))))))
    return np.array(out)


def _best_scale(moves, bias, p, k0) -> tuple[float, float]:
    """(k, median misfit deg) minimising the moves' median misfit over log k within ±0.4 of log ``k0``."""
    sol = minimize_scalar(
        lambda x: float(np.median(_carried_misfit(moves, bias, p, math.exp(x)))),
        math.log(k0) - 0.4,
        math.log(k0) + 0.4,
        xatol=1e-4,
        what="the search for the gyro scale",
    )
    return math.exp(float(sol.x)), sol.value


def _move_evidence(moves, bias) -> tuple[np.ndarray, float, float, float] | None:
    """(P, k, median misfit of P at k, of the identity at its own best k) from the moves (module doc); the
    fixed-axis approximation (one rotation vector per move) ranks the 48 permutations on a grid of k, the two
    best are refined by integrating sample by sample."""
    if not moves:
        return None
    v = np.array([((m.g - bias) * m.dt).sum(axis=0) * units.DEG_PER_H for m in moves])  # rad
    uf = np.array([m.u_from for m in moves])
    ut = np.array([m.u_to for m in moves])
    ks = np.exp(np.linspace(math.log(1e-4), math.log(1e4), 161))
    ranked = []
    for p in signed_permutations():
        r = so3.exp(ks[:, None, None] * (v @ p.T)[None])
        pred = np.einsum("kmji,mj->kmi", r, uf)
        ang = np.degrees(np.arccos(np.clip((pred * ut).sum(-1), -1, 1)))
        med = np.median(ang, axis=1)
        i = int(np.argmin(med))
        ranked.append((float(med[i]), float(ks[i]), p))
    ranked.sort(key=lambda x: x[0])
    ident = next(x for x in ranked if np.allclose(x[2], np.eye(3)))
    k_best, m_best = _best_scale(moves, bias, ranked[0][2], ranked[0][1])
    if np.allclose(ranked[0][2], np.eye(3)):
        return ranked[0][2], k_best, m_best, m_best
    _, m_ident = _best_scale(moves, bias, np.eye(3), ident[1])
    return ranked[0][2], k_best, m_best, m_ident


def _rotation_evidence(rotations, bias) -> tuple[np.ndarray, float] | None:
    """(P, k) from rotations of known angle: P maps the integrated angle vectors onto the declared axes, k the
    declared angle over the integrated one (median)."""
    if not rotations:
        return None
    v = np.array([(s.y - bias) * s.info["duration_s"] / units.SECONDS_PER_HOUR for s in rotations])  # deg
    n = np.array([s.info["axis"] for s in rotations], dtype=float)
    ang = np.array([abs(s.info["angle_deg"]) for s in rotations])
    best = max(signed_permutations(), key=lambda p: float(np.sum(np.abs(np.sum((v @ p.T) * n, axis=1)))))
    along = np.abs(np.sum((v @ best.T) * n, axis=1))
    return best, float(np.median(ang / np.maximum(along, 1e-300)))


def divergence_hint(segments, moves) -> str:
    """The import flag the data point to when the fit diverges (module doc), or ``""`` when they point nowhere."""
    statics = [s for s in segments if s.kind == "static"]
    if not statics:
        return ""
    bias = np.median([s.y for s in statics], axis=0)
    clues = []
    ev = _move_evidence(moves, bias)
    if ev is not None:
        p, k, m_p, m_i = ev
        if m_p > MOVE_MATCH_DEG:
            return ""
        if not np.allclose(p, np.eye(3)) and m_p < PERMUTATION_WIN * m_i:
            clues.append(
                f"{permutation_clue(p)} (the moves match it within {m_p:.2g}° in the median, the axes as mapped "
                f"within {m_i:.2g}°)"
            )
        ratio = 1.0 / k
    else:
        rot = _rotation_evidence([s for s in segments if s.kind == "rotation"], bias)
        if rot is None:
            return ""
        p, k = rot
        if not np.allclose(p, np.eye(3)):
            clues.append(permutation_clue(p))
        ratio = 1.0 / k
    if abs(math.log(ratio)) > math.log(1.0 + MEMS_SCALE_BOUND):
        clues.append(ratio_clue(ratio))
    return "; ".join(clues)
