"""Gyro-only calibration sessions: rotations of a known angle about known body axes, and rests, no accelerometer.

A fixture turned by hand, a rate table, or a Ferraris session whose accelerometer is not used: the gyro's own record
(three channels and a clock) and the list of the rotations it made, in order — ``x:360,y:360,z:360`` on the command
line (``AXIS:ANGLE[:STD]``; an unsigned angle takes its sign from the data, ``+360``/``-360`` declare it) or a small
file (JSON ``{"rotations": [{"axis": "x", "angle_deg": 360, "angle_std_deg": 0.5, "direction": "from-data"}, …]}``,
or CSV with those columns).

The rests are found from the gyro alone (:func:`gyrojax.data.segments.detect_rests` without an accelerometer): they
give the bias (static segments). Between two rests the hand may turn the box more than once, pausing between turns
with the box in its hand — quiet within :data:`PAUSE_THRESHOLD` times the rest noise variance, not still: each such
pause splits the motion at its middle (a pause next to a rest is the turn's settling and stays with the turn), and
the angle a pause turned, which could belong to either side, enters the two rotations' angle covariance
(:func:`split_covariance`). Each motion is integrated at the nominal scale, the rests' mean as bias, and matched in
order to the listed rotations: a motion whose integrated angle points within :data:`MATCH_DEG` of the next listed
axis is that rotation, any other is a move that is not fitted (reported). A listed rotation left unmatched is an
error naming it and the motions found. The integrated angles of the matched motions are compared with the listed
ones: off by a common factor beyond any gyro's scale error, the
import is refused with the flag the factor points to (:func:`gyrojax.data.importclues.ratio_clue`).

The record (an ``imu-triad`` record without ``acc_<c>_g`` columns, conventions §9.3) has static segments of unknown
orientation — their Earth rate a nuisance of unknown direction, no g-sensitivity — and rotation segments; the triad
fit gives scale factor, misalignment and bias with σ (:func:`gyrojax.inference.triad.fit_triad`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from gyrojax.data.importclues import MEMS_SCALE_BOUND, ratio_clue
from gyrojax.data.restlog import rest_segments
from gyrojax.data.triad import DIRECTIONS, axis_vector
from gyrojax.errors import RecordError
from gyrojax.protocol import is_finite_number

PAUSE_THRESHOLD = 100.0
"""A hand's pause between two turns: quiet within this many times the rest noise variance (rms ten times the noise),
not still enough for a rest (the rest threshold: :func:`gyrojax.data.segments.detect_rests`)."""
MATCH_DEG = 30.0
"""Largest angle between a motion's integrated rate vector and the listed axis for the motion to be that rotation."""
REFUSE_RATIO = 2.0
"""A common ratio of integrated to listed angles beyond this factor (either way) is refused: no gyro's scale."""
ROTATION_KEYS = ("axis", "angle_deg", "angle_std_deg", "direction")


def _rotation(d: dict, where: str) -> dict:
    unknown = sorted(set(d) - set(ROTATION_KEYS))
    if unknown:
        raise RecordError(f"{where}: unknown key {unknown[0]!r}; a rotation has {', '.join(ROTATION_KEYS)}")
    if "axis" not in d or "angle_deg" not in d:
        raise RecordError(f"{where}: a rotation needs 'axis' and 'angle_deg'")
    axis_vector(d["axis"], f"{where}: key 'axis'")
    ang = d["angle_deg"]
    if not is_finite_number(ang) or float(ang) <= 0:
        raise RecordError(f"{where}: key 'angle_deg' must be a positive number (deg), got {ang!r}")
    sd = d.get("angle_std_deg", 0.0)
    if not is_finite_number(sd) or float(sd) < 0:
        raise RecordError(f"{where}: key 'angle_std_deg' must be a number >= 0 (deg), got {sd!r}")
    direction = d.get("direction", "from-data")
    if direction not in DIRECTIONS:
        raise RecordError(f"{where}: key 'direction' is {direction!r}; valid: {', '.join(DIRECTIONS)}")
    return {"axis": d["axis"], "angle_deg": float(ang), "angle_std_deg": float(sd), "direction": direction}


def _rotation_text(item: str, where: str) -> dict:
    parts = item.strip().split(":")
    if len(parts) not in (2, 3) or not parts[0]:
        raise RecordError(f"{where}: {item!r}: give AXIS:ANGLE or AXIS:ANGLE:STD, e.g. x:360 or -z:+90:0.5")
    try:
        nums = [float(x) for x in parts[1:]]
    except ValueError:
        raise RecordError(f"{where}: {item!r}: the angle (and its 1-sigma error) must be numbers, deg") from None
    sign = parts[1].strip()[:1]
    direction = {"+": "positive", "-": "negative"}.get(sign, "from-data")
    d = {"axis": parts[0].strip(), "angle_deg": abs(nums[0]), "direction": direction}
    if len(nums) == 2:
        d["angle_std_deg"] = nums[1]
    return _rotation(d, f"{where}: {item!r}")


def read_rotations(spec) -> list[dict]:
    """The listed rotations from ``AXIS:ANGLE[:STD],…`` (angles in deg; module doc), a file (JSON or CSV) or a list
    of dicts."""
    if isinstance(spec, (list, tuple)):
        rots = [_rotation(d, f"rotations[{i}]") for i, d in enumerate(spec)]
    elif isinstance(spec, (str, Path)) and Path(spec).suffix.lower() in (".json", ".csv"):
        p = Path(spec)
        try:
            text = p.read_text(encoding="utf-8-sig")
        except (OSError, UnicodeDecodeError) as e:
            raise RecordError(f"{p}: cannot read the rotations ({e})") from None
        if p.suffix.lower() == ".json":
            try:
                d = json.loads(text)
            except json.JSONDecodeError as e:
                raise RecordError(f"{p}: not valid JSON ({e})") from None
            items = d.get("rotations") if isinstance(d, dict) else d
            if not isinstance(items, list) or not all(isinstance(x, dict) for x in items):
                raise RecordError(f'{p}: a rotation list is {{"rotations": [{{"axis": "x", "angle_deg": 360}}, …]}}')
            rots = [_rotation(x, f"{p}: rotations[{i}]") for i, x in enumerate(items)]
        else:
            import csv
            import io

            rows = list(csv.DictReader(io.StringIO(text)))
            rots = []
            for i, r in enumerate(rows):
                d = {k.strip(): v.strip() for k, v in r.items() if k is not None and v is not None and v.strip()}
                for k in ("angle_deg", "angle_std_deg"):
                    if k in d:
                        try:
                            d[k] = float(d[k])
                        except ValueError:
                            raise RecordError(f"{p}: row {i + 2}, column {k!r} holds {d[k]!r}, not a number") from None
                rots.append(_rotation(d, f"{p}: row {i + 2}"))
    elif isinstance(spec, str):
        rots = [_rotation_text(x, "--rotations") for x in spec.split(",")]
    else:
        raise RecordError(f"rotations: give 'x:360,y:360,z:360', a JSON or CSV file, or a list; got {spec!r}")
    if not rots:
        raise RecordError("rotations: the list is empty; a gyro-only session needs rotations of known angle")
    return rots


def _motions(n: int, rests: list, pauses: list, moving: np.ndarray) -> list[tuple[int, int, list]]:
    """The motions between rests: the spans between consecutive rests (and before the first, after the last), each
    split at the middle of every pause inside it; a pause that touches a rest is the motion's settling and stays in
    it. Spans with no moving sample are dropped. Each motion comes with the pauses it was split at, (start, end)."""
    edges = [0] + [x for r in rests for x in r] + [n]
    out = []
    for z0, z1 in zip(edges[::2], edges[1::2]):
        inner = [(s, e) for s, e in pauses if z0 < s and e < z1]
        cuts = [(s + e) // 2 for s, e in inner]
        for k, (a, b) in enumerate(zip([z0] + cuts, cuts + [z1])):
            if b > a and moving[a:b].any():
                out.append((a, b, inner[max(k - 1, 0) : k + 1] if inner else []))
    return out


def split_covariance(dps: np.ndarray, bias: np.ndarray, pauses: list, dt: float) -> np.ndarray:
    """Covariance (3, 3) deg² of a rotation's angle vector from where its span was cut in the pauses ``pauses``
    (sample ranges; ``dps`` deg/s, ``bias`` deg/s, ``dt`` s)
    beside it: the hand's mark lies anywhere in a pause, so a cut at its middle misplaces up to half of the angle Δ
    the pause turned; uniform over the pause, Δ Δᵀ / 12 each."""
    cov = np.zeros((3, 3))
    for s, e in pauses:
        d = (dps[s:e] - bias).sum(axis=0) * dt
        cov += np.outer(d, d) / 12.0
    return cov


def _angle_to(v: np.ndarray, axis: np.ndarray, direction: str) -> float:
    """Angle (deg) between an integrated angle vector and a listed axis (either sign unless declared)."""
    c = float(v @ axis) / max(float(np.linalg.norm(v)), 1e-300)
    c = {"positive": c, "negative": -c}.get(direction, abs(c))
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def gyro_only_segments(
    t,
    dps,
    rotations,
    *,
    min_rest_s: float | None = None,
    static_threshold: float | None = None,
    source: str = "arrays",
    notes: list | None = None,
) -> tuple[np.ndarray, list, dict]:
    """The segments of a gyro-only session (module doc): times ``t`` (s) and the gyro at its nominal scale ``dps``
    (n, 3) deg/s, the listed ``rotations`` (:func:`read_rotations`). Returns the segment labels (n,), the segment
    list of the triad record (:mod:`gyrojax.data.triad`) and the import report (rests found, rotations matched,
    moves not fitted, notes)."""
    from gyrojax.data.segments import MIN_REST_S, detect_rests

    rots = read_rotations(rotations)
    t = np.asarray(t, dtype=float)
    notes = list(notes or [])
    dt = (t[-1] - t[0]) / (len(t) - 1)
    min_rest = MIN_REST_S if min_rest_s is None else min_rest_s
    try:
        det = detect_rests(None, 1.0 / dt, gyro=dps, threshold=static_threshold, min_rest_s=min_rest)
        pause_thr = max(PAUSE_THRESHOLD, det.threshold["gyro"])
        loose = detect_rests(None, 1.0 / dt, gyro=dps, threshold=pause_thr, min_rest_s=min_rest)
    except RecordError as e:
        raise RecordError(f"{source}: {e}") from None
    rests = det.intervals
    if not rests:
        raise RecordError(f"{source}: found no rest; a gyro-only session needs rests for the bias ({det.summary()})")
    rest_mask = np.zeros(len(t), dtype=bool)
    for s, e in rests:
        rest_mask[s:e] = True
    quiet = np.zeros(len(t), dtype=bool)
    for s, e in loose.intervals:
        quiet[s:e] = True
    pauses = [(s, e) for s, e in loose.intervals if not rest_mask[s:e].any()]
    motions = _motions(len(t), rests, pauses, ~quiet)
    bias = np.concatenate([dps[s:e] for s, e in rests]).mean(axis=0)
    vectors = [(s, e, (dps[s:e] - bias).sum(axis=0) * dt) for s, e, _ in motions]
    cuts = [split_covariance(dps, bias, p, dt) for _, _, p in motions]
    matched, free, j = [], [], 0
    for (s, e, v), cov in zip(vectors, cuts):
        if j < len(rots) and _angle_to(v, axis_vector(rots[j]["axis"]), rots[j]["direction"]) <= MATCH_DEG:
            rot = dict(rots[j])
            if np.any(cov):
                rot["angle_cov_deg2"] = cov.tolist()
            matched.append((s, e, v, rot))
            j += 1
        else:
            free.append((s, e, v))

    def span(s, e):
        return {"start_s": float(t[s] - t[0]), "end_s": float(t[e - 1] - t[0])}

    if j < len(rots):
        found = "; ".join(
            f"{span(s, e)['start_s']:.2f}–{span(s, e)['end_s']:.2f} s ({', '.join(f'{x:.4g}' for x in v)}) deg"
            for s, e, v in vectors
        )
        missing = ", ".join(f"{r['axis']}:{r['angle_deg']:g}" for r in rots[j:])
        turned = sum(float(np.linalg.norm(v)) for _, _, v in vectors) / sum(r["angle_deg"] for r in rots)
        clue = f"; in all they turned {turned:.3g}× the listed angles: {ratio_clue(turned)}" if turned < 0.5 else ""
        raise RecordError(
            f"{source}: the listed rotations {missing} match no motion between rests (in order, within {MATCH_DEG:g} "
            f"deg of the axis; check the order of --rotations and the gyro columns' --map); the motions found, "
            f"integrated at the nominal scale: {found or 'none'}{clue}"
        )
    r = float(np.median([abs(float(v @ axis_vector(rot["axis"]))) / rot["angle_deg"] for _, _, v, rot in matched]))
    if not 1.0 / REFUSE_RATIO <= r <= REFUSE_RATIO:
        raise RecordError(f"{source}: the rotations integrate to {r:.4g}× their listed angles: {ratio_clue(r)}")
    if abs(r - 1.0) > MEMS_SCALE_BOUND:
        notes.append(f"the rotations integrate to {r:.4g}× their listed angles at the nominal scale: {ratio_clue(r)}")
    if pauses:
        notes.append(
            f"{len(pauses)} pause(s) of the hand (quiet within {pause_thr:.3g}× the rest noise variance, not still "
            "enough for a rest) split the motions between rests at their middle; where a pause turned, the angle "
            "it turned is part of the rotations' angle covariance (angle_cov_deg2)"
        )
    if free:
        notes.append(f"{len(free)} motion(s) match no listed rotation: moves that are not fitted")
    labels, segs = rest_segments(rests, len(t))
    for k, (s, e, _v, rot) in enumerate(matched):
        labels[s:e] = len(rests) + k
        segs.append({"label": len(rests) + k, "type": "rotation", "name": f"turn-{k}-{rot['axis']}", **rot})
    report = {
        "source": source,
        **det.to_json(),
        "pauses": [span(s, e) for s, e in pauses],
        "rotations": [{**span(s, e), "integrated_deg": v.tolist(), **rot} for s, e, v, rot in matched],
        "moves_not_fitted": [{**span(s, e), "integrated_deg": v.tolist()} for s, e, v in free],
        "notes": notes,
    }
    return labels, segs, report
