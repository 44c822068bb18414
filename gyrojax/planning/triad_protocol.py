"""Calibration protocols for hand-held IMUs: the rests and the turns between them that minimise the predicted σ of
chosen triad coefficients, designed by gradients (``gyrojax design --instrument imu-triad``; issue 27).

**Parameterisation.** N rests joined by N − 1 gravity-to-gravity moves (imu_tk's kind: the accelerometer measures
both ends, so the hand's placement error does not enter). The first rest's attitude is a rotation vector x₀; move
k turns the box by the body-frame rotation vector v_k (axis v/|v|, angle |v|), so rest k + 1's attitude is
C_k R(v_k) and its Up in the body frame C_{k+1}ᵀ e_U. A move of Φ degrees takes :data:`MIN_TURN_S` +
Φ / :data:`HAND_RATE_DPS` seconds (a person's pace); the rests share what is left of the total time by a
softmax, each at least a quarter of the equal share. The loss is the criterion of the Fisher information of
:mod:`gyrojax.planning.triad_fisher` (exact JAX derivatives through the fit's own measurement model), minimised by
Adam (optax) from several random starts (``vmap``); the best start is kept.

**Known-angle turns** (Ferraris'): a few discrete structures are searched, each by the same Adam loop from the
same starts, the lowest loss kept (:data:`TURN_PAIRS`): m pairs of 360° turns, one each way, about each body axis
e_j, made on rest j (j = 0, 1, 2) with the box on face +e_j (the turn about the vertical, the table holding the
tilt; rests 0–2 are those faces), each followed by a reorientation (not fitted, as Ferraris' flips: a move is
fitted from the rests on either side, and a rest split around the turns would repeat a pose). A turn's angle is
known to √2 σ_placement about its axis; with σ_placement → 0 the search can hold Ferraris' turns and moves besides.

**Criteria.** ``D`` −log det F; ``A`` Σ Var θ_i (report units: ppm and arcsec weigh more than deg/h);
``c:NAME=w,…`` Var(Σ w θ) of per-channel coefficients (``c:E_SF[x]``).

**Baselines** at the same total time and pace: imucal's Ferraris protocol (6 faces, one turn of 360° each way about
each axis on its face, the angle known to √2 σ_placement, flips between faces not fitted) and imu_tk's random
poses (N uniformly random attitudes, the mean of :data:`RANDOM_DRAWS` draws).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np
from scipy.spatial.transform import Rotation

from gyrojax.errors import ConvergenceWarning, ModelError
from gyrojax.inference.triad import DEFAULT_ROTATION_TERMS as LINEAR_TERMS  # bias, g-terms, scale, misalignment
from gyrojax.physics import effects as fx
from gyrojax.physics import triad as tp
from gyrojax.planning import search
from gyrojax.planning.triad_fisher import (
    TriadNoise,
    coefficient_names,
    covariance,
    move_fisher,
    rest_fisher,
    rot,
    scaled,
    turn_fisher,
    turn_pairs_fisher,
)
from gyrojax.simulation.triad import face_attitude, random_attitude

HAND_RATE_DPS = 90.0
"""Mean rate of a hand turn, deg/s (a 180° move takes 1 + 2 s)."""
MIN_TURN_S = 1.0
"""Shortest hand turn, s."""
RANDOM_DRAWS = 8
"""Draws of imu_tk's random poses averaged for its baseline."""
PROTOCOL_FORMAT = "gyrojax-triad-protocol"
PROTOCOL_VERSION = 1
UP = np.array([0.0, 0.0, 1.0])
TURN_DEG = 360.0
"""A designed known-angle turn: once round a body axis, back to a mark (Ferraris' turn)."""
MOTION_KINDS = {"turn": "known-angle", "move": "free", "reorient": "not fitted"}
TURN_PAIRS = (0, 1, 2)
"""The structures searched: this many pairs of known-angle turns (one each way) about each body axis."""


def turn_seconds(angle_deg) -> float:
    """Duration (s) of a hand turn by ``angle_deg`` (deg) at the pace of :data:`HAND_RATE_DPS`."""
    return MIN_TURN_S + abs(angle_deg) / HAND_RATE_DPS


def triad_model(terms):
    """The channel model of ``terms``, refused with one line when a term is unknown, not of an ``imu-triad``
    instrument, or outside what moves integrate (the linear model)."""
    terms = list(terms)
    known = fx.names()
    bad = [t for t in terms if t not in known]
    if bad:
        raise ModelError(f"unknown effect {bad[0]!r}; the imu-triad protocol designs for {', '.join(LINEAR_TERMS)}")
    try:
        model = tp.channel_model(terms)
    except ModelError as e:
        raise ModelError(f"{e} (not an effect of an imu-triad's channels)") from None
    other = [t for t in model.terms if t not in LINEAR_TERMS]
    if other:
        raise ModelError(
            f"effect {other[0]!r} is not fitted from hand moves of an imu-triad; the protocol designs for "
            f"{', '.join(LINEAR_TERMS)}"
        )
    return model


def min_poses(model) -> int:
    """Fewest rests that can identify the model: the rests give 3 rows each, the moves 2 each; each channel's
    bias and g-terms need as many rests as they have coefficients (D_F, D_I, D_O, D_S: 4), and the scale and
    misalignment (9 for the triad) are seen by the moves alone (2 rows each): 6 rests for the six linear terms."""
    static = sum(1 for c in model.coefficient_names if c.startswith("D_"))
    scale = 3 * sum(1 for c in model.coefficient_names if not c.startswith("D_"))  # seen by the moves only
    n = max(static, 2)
    while 3 * n + 2 * (n - 1) < 3 * model.size or 2 * (n - 1) < scale:
        n += 1
    return n


@dataclass(frozen=True)
class TriadCriterion:
    """``D``, ``A`` or ``c`` with the weight vector over :func:`coefficient_names` (module doc)."""

    kind: str
    vector: tuple | None = None
    text: str = "D"

    @classmethod
    def parse(cls, text: str, model) -> "TriadCriterion":
        """``D``, ``A`` or ``c:COEF=w,...`` (per-channel names, e.g. ``c:E_SF[x]``) for ``model``."""
        names = coefficient_names(model)
        head, _, rest = text.partition(":")
        if head in ("D", "A") and not rest:
            return cls(head, None, head)
        if head == "c" and rest:
            w = {}
            for item in rest.split(","):
                k, _, v = item.partition("=")
                k = k.strip()
                if k not in names:
                    raise ModelError(f"criterion {text!r}: {k!r} is not a coefficient of the model (e.g. {names[0]})")
                try:
                    w[k] = float(v) if v else 1.0
                except ValueError:
                    raise ModelError(f"criterion {text!r}: weight {v!r} of {k} is not a number") from None
            return cls("c", tuple(w.get(n, 0.0) for n in names), text)
        raise ModelError(f"unknown criterion {text!r} for imu-triad; valid: D, A, c:COEF[=w],... (e.g. c:{names[0]})")

    def loss(self, f):
        """The loss of a Fisher information (module doc)."""
        if self.kind == "D":
            fs, ls = scaled(f)
            return -(jnp.linalg.slogdet(fs)[1] + 2.0 * jnp.sum(ls))
        cov = covariance(f)
        if self.kind == "A":
            return jnp.trace(cov)
        c = jnp.asarray(self.vector)
        return c @ cov @ c


def _expm(v):
    th = jnp.sqrt(v @ v + 1e-30)
    return rot(v / th, th)


def _chain(x0, v):
    """Attitudes (N, 3, 3) body → ENU of the rests from the start rotation vector and the moves' vectors."""

    def step(c, vk):
        c2 = c @ _expm(vk)
        return c2, c2

    c0 = _expm(x0)
    _, rest = jax.lax.scan(step, c0, v)
    return jnp.concatenate([c0[None], rest])


def _rests(z, total_s, turn_total):
    n = z.shape[0]
    m = 0.25 / n
    return jnp.maximum(total_s - turn_total, 1.0) * (m + (1.0 - n * m) * jax.nn.softmax(z))


_FACE_ATT = [face_attitude(i, 1.0, 0.0) for i in range(3)]
_FACES_X0 = Rotation.from_matrix(_FACE_ATT[0]).as_rotvec()
_FACES_MOVES = np.array([Rotation.from_matrix(a.T @ b).as_rotvec() for a, b in zip(_FACE_ATT, _FACE_ATT[1:])])


def design_parts(params, total_s, pairs: int = 0):
    """(attitudes, Ups, rest s, move axes, angles rad, durations s) of the design parameters with ``pairs`` pairs of
    known-angle turns about each body axis (module doc); a host rest's time is the sum of its two halves."""
    x0, v, z = params
    if pairs:  # the turns' rests on the faces +x, +y, +z (a turn about the vertical, the box on the table)
        x0, v = jnp.asarray(_FACES_X0), v.at[:2].set(jnp.asarray(_FACES_MOVES))
    att = _chain(x0, v)
    up = jnp.einsum("kji,j->ki", att, jnp.asarray(UP))  # C_kᵀ e_U
    ang = jnp.sqrt(jnp.sum(v * v, axis=1) + 1e-30)
    axes = v / ang[:, None]
    dur = MIN_TURN_S + jnp.degrees(ang) / HAND_RATE_DPS
    rest = _rests(z, total_s, jnp.sum(dur) + 6 * pairs * turn_seconds(TURN_DEG))
    return att, up, rest, axes, ang, dur


def design_fisher(model, params, total_s, noise: TriadNoise, pairs: int = 0):
    """F of the designed protocol's parameters (differentiable): rests, moves and, with ``pairs``, the known-angle
    turns about e_j at rest j (j < 3) on face +e_j, followed by a reorientation to the next rest instead of a move
    (a move is fitted from the rests on either side; a rest split around the turns would repeat a pose).
    ``total_s`` s; the turns are 360° (one each way); F in the units of the fit's coefficients."""
    _, up, rest, axes, ang, dur = design_parts(params, total_s, pairs)
    f = rest_fisher(model, up, rest, noise)
    k = 3 if pairs else 0  # after the turns, a reorientation (not fitted) takes the box on
    if pairs:
        f = f + turn_pairs_fisher(model, up, pairs, turn_seconds(TURN_DEG), noise)
    return f + move_fisher(model, up[k:-1], axes[k:], ang[k:], dur[k:], rest[k:-1], rest[k + 1 :], noise)


_rest_jit = jax.jit(rest_fisher, static_argnums=(0, 3))
_move_jit = jax.jit(move_fisher, static_argnums=(0, 7))
_turn_jit = jax.jit(turn_fisher, static_argnums=(0, 5))


def steps_fisher(model, start_attitude, steps, noise: TriadNoise):
    """F of any protocol given as steps (:mod:`gyrojax.simulation.triad_session`), from ``start_attitude``."""
    c = np.asarray(start_attitude, dtype=float)
    ups, rests, mv, tr = [], [], [], []
    for i, s in enumerate(steps):
        if s["type"] == "rest":
            ups.append(c.T @ UP)
            rests.append(float(s["rest_s"]))
            continue
        ax = np.asarray(s["axis"], dtype=float)
        ax = ax / np.linalg.norm(ax)
        phi = math.radians(float(s["angle_deg"]))
        if s["type"] == "move":
            mv.append(
                (
                    c.T @ UP,
                    ax,
                    phi,
                    float(s["duration_s"]),
                    float(steps[i - 1]["rest_s"]),
                    float(steps[i + 1]["rest_s"]),
                )
            )
        elif s["type"] == "turn":
            tr.append((c.T @ UP, ax, phi, float(s["duration_s"])))
        c = c @ Rotation.from_rotvec(ax * phi).as_matrix()
    f = _rest_jit(model, jnp.asarray(np.array(ups)), jnp.asarray(rests), noise)
    if mv:
        f = f + _move_jit(model, *(jnp.asarray(np.array(x)) for x in zip(*mv)), noise)
    if tr:
        f = f + _turn_jit(model, *(jnp.asarray(np.array(x)) for x in zip(*tr)), noise)
    return np.asarray(f)


def sigma(f, model) -> dict:
    """Predicted σ of every coefficient (report units; inf where F is singular)."""
    f = np.asarray(f)
    s = np.sqrt(np.maximum(np.diag(f), 1e-300))
    fs = f / np.outer(s, s)
    ev = np.linalg.eigvalsh(fs)
    names = coefficient_names(model)
    if ev[0] < 1e-12 * ev[-1]:
        return {n: math.inf for n in names}
    cov = np.linalg.inv(fs) / np.outer(s, s)
    return dict(zip(names, np.sqrt(np.diag(cov)).tolist()))


def _relative(c0, c1):
    """Body-frame rotation (axis, angle deg) taking attitude ``c0`` to ``c1`` (the shorter way)."""
    v = Rotation.from_matrix(c0.T @ c1).as_rotvec()
    a = float(np.linalg.norm(v))
    return (v / a if a > 0 else np.array([0.0, 0.0, 1.0])), math.degrees(a)


def _motion(kind, axis, angle_deg):
    return {
        "type": kind,
        "axis": [float(x) for x in axis],
        "angle_deg": float(angle_deg),
        "duration_s": turn_seconds(angle_deg),
    }


def ferraris_steps(total_s: float) -> tuple[np.ndarray, list]:
    """imucal's Ferraris protocol at ``total_s`` s (module doc): (start attitude, steps)."""
    faces = [face_attitude(axis, sign, 0.0) for axis, sign in ((0, 1), (0, -1), (1, 1), (1, -1), (2, 1), (2, -1))]
    motions = []
    for i in range(6):
        block = []
        if i % 2 == 0:  # on face +e_i: a turn of 360° each way about e_i (vertical)
            e = np.eye(3)[i // 2]
            block += [_motion("turn", e, 360.0), _motion("turn", -e, 360.0)]
        if i < 5:
            block.append(_motion("reorient", *_relative(faces[i], faces[i + 1])))
        motions.append(block)
    rest = (total_s - sum(m["duration_s"] for b in motions for m in b)) / 6.0
    if rest <= 0:
        raise ModelError(f"{total_s / 60:g} min do not hold Ferraris' turns and flips")
    steps = []
    for block in motions:
        steps.append({"type": "rest", "rest_s": rest})
        steps += block
    return faces[0], steps


def random_steps(n_poses: int, total_s: float, seed: int = 0) -> tuple[np.ndarray, list]:
    """imu_tk's random poses: ``n_poses`` uniformly random attitudes joined by moves, equal rests."""
    rng = np.random.default_rng(seed)
    att = [random_attitude(rng) for _ in range(n_poses)]
    moves = [_motion("move", *_relative(att[k], att[k + 1])) for k in range(n_poses - 1)]
    rest = (total_s - sum(m["duration_s"] for m in moves)) / n_poses
    if rest <= 0:
        raise ModelError(f"{total_s / 60:g} min do not hold {n_poses - 1} hand moves")
    steps = [{"type": "rest", "rest_s": rest}]
    for m in moves:
        steps += [m, {"type": "rest", "rest_s": rest}]
    return att[0], steps


@dataclass
class TriadProtocol:
    """A designed protocol: the start attitude (body → ENU at heading 0), the steps, the search's report."""

    terms: tuple
    criterion: TriadCriterion
    noise: TriadNoise
    total_s: float
    start_attitude: np.ndarray
    steps: list
    loss: float
    start_losses: np.ndarray
    history: np.ndarray
    turn_pairs: int = 0
    structure_losses: dict = field(default_factory=dict)

    @property
    def convergence_note(self) -> str:
        """Why the search is not taken as converged ("" when it is; :mod:`gyrojax.planning.search`)."""
        return search.convergence_note(self.history, self.loss, "raise --adam-steps")

    @property
    def converged(self) -> bool:
        """Whether the chosen structure's search settled (see :attr:`convergence_note`)."""
        return not self.convergence_note

    def fisher(self) -> np.ndarray:
        """The protocol's Fisher information (:func:`gyrojax.planning.triad_fisher.steps_fisher`), θ order."""
        return steps_fisher(triad_model(self.terms), self.start_attitude, self.steps, self.noise)

    def table(self) -> list[dict]:
        """The protocol a person follows: one row per rest, with the motions that follow it (``motions``: kind
        ``known-angle`` — by exactly this angle, back to a mark —, ``free`` — to the next rest, roughly: the
        accelerometer measures where it ends — or ``not fitted``); ``turn_axis``/``angle_deg``/``turn_s`` the last."""
        rows, c = [], np.asarray(self.start_attitude, dtype=float)
        for s in self.steps:
            if s["type"] == "rest":
                rows.append(
                    {
                        "step": len(rows) + 1,
                        "up": face_up(c.T @ UP),
                        "up_body": (c.T @ UP).tolist(),
                        "rest_s": float(s["rest_s"]),
                    }
                )
                continue
            ax = np.asarray(s["axis"], dtype=float)
            motion = {
                "turn_axis": axis_text(ax),
                "angle_deg": float(s["angle_deg"]),
                "turn_s": float(s["duration_s"]),
                "peak_rate_dps": math.pi / 2 * float(s["angle_deg"]) / float(s["duration_s"]),
            }
            rows[-1].setdefault("motions", []).append({"kind": MOTION_KINDS[s["type"]], **motion})
            rows[-1].update(motion)
            c = c @ Rotation.from_rotvec(ax * math.radians(float(s["angle_deg"]))).as_matrix()
        return rows

    def attitudes(self) -> list[np.ndarray]:
        """Body → ENU attitude of every rest, in order."""
        out, c = [], np.asarray(self.start_attitude, dtype=float)
        for s in self.steps:
            if s["type"] == "rest":
                out.append(c)
            else:
                ax = np.asarray(s["axis"], dtype=float)
                c = c @ Rotation.from_rotvec(ax * math.radians(float(s["angle_deg"]))).as_matrix()
        return out


def face_up(up_body) -> str:
    """The box face nearest Up (``+z``, ``-x`` …) and how far Up is from it: ``+z`` or ``+z, 35° toward -y``."""
    u = np.asarray(up_body, dtype=float)
    i = int(np.argmax(np.abs(u)))
    face = ("+" if u[i] > 0 else "-") + "xyz"[i]
    tilt = math.degrees(math.acos(min(1.0, abs(float(u[i])))))
    if tilt < 1.0:
        return face
    rest = u.copy()
    rest[i] = 0.0
    j = int(np.argmax(np.abs(rest)))
    return f"{face}, {tilt:.0f}° toward {'+' if rest[j] > 0 else '-'}{'xyz'[j]}"


def axis_text(ax) -> str:
    """A body axis as text: ``+x`` when along one, else its unit vector to 2 decimals."""
    ax = np.asarray(ax, dtype=float)
    i = int(np.argmax(np.abs(ax)))
    if abs(ax[i]) > 0.9998:
        return ("+" if ax[i] > 0 else "-") + "xyz"[i]
    return "(" + ", ".join(f"{x:+.2f}" for x in ax) + ")"


def design_protocol(
    terms,
    n_poses: int,
    minutes: float,
    criterion: str = "D",
    noise: TriadNoise | None = None,
    *,
    starts: int = 6,
    steps: int = 400,
    learning_rate: float = 0.05,
    seed: int = 0,
    turn_pairs=TURN_PAIRS,
) -> TriadProtocol:
    """Design an ``n_poses`` protocol of ``minutes`` in total (rests and turns) minimising the criterion (module
    doc): each structure of ``turn_pairs`` (pairs of known-angle turns about each body axis) searched by Adam from
    the same starts, the best kept; refuses terms the protocol cannot fit, too few poses, or too little time."""
    model = triad_model(terms)
    noise = noise or TriadNoise()
    crit = TriadCriterion.parse(criterion, model)
    need = min_poses(model)
    if n_poses < need:
        raise ModelError(
            f"{n_poses} poses cannot identify {', '.join(model.terms)} on three channels: at least {need} are needed"
        )
    total = minutes * 60.0
    moves_s = (n_poses - 1) * turn_seconds(180.0)
    if total <= moves_s + n_poses * 1.0:
        raise ModelError(
            f"{minutes:g} min is too short for {n_poses} poses: the moves alone take about "
            f"{moves_s / 60:.1f} min at a hand's pace; give more --minutes"
        )
    key = jax.random.PRNGKey(seed)
    k1, k2 = jax.random.split(key)
    x0 = jax.random.normal(k1, (starts, 3)) * 2.0
    v0 = jax.random.normal(k2, (starts, n_poses - 1, 3)) * 1.2
    z0 = jnp.zeros((starts, n_poses))
    found = {}
    for pairs in turn_pairs:
        if total <= moves_s + 6 * pairs * turn_seconds(TURN_DEG) + (n_poses + 3) * 1.0:
            continue  # no time left for the rests

        def loss(p, pairs=pairs):
            return crit.loss(design_fisher(model, p, total, noise, pairs))

        vg = jax.value_and_grad(loss)

        def run(p0, loss=loss, vg=vg):
            p, hist = search.adam_scan(vg, p0, steps, learning_rate)
            return p, hist, loss(p)

        p, hist, final = jax.jit(jax.vmap(run))((x0, v0, z0))
        final = np.where(np.isfinite(np.asarray(final)), np.asarray(final), np.inf)
        b = int(np.argmin(final))
        found[pairs] = (float(final[b]), final, jax.tree_util.tree_map(lambda a, b=b: a[b], p), np.asarray(hist[b]))
    best_pairs = min(found, key=lambda k: found[k][0]) if found else None
    if best_pairs is None or not np.isfinite(found[best_pairs][0]):
        raise ModelError(f"no start of the search found a protocol of {n_poses} poses that identifies the terms")
    value, final, best, hist = found[best_pairs]
    att, up, rest, axes, ang, dur = (np.asarray(x) for x in design_parts(best, total, best_pairs))
    # heading is not designed (the fit marginalises it): start at heading 0 with the first rest's Up
    steps_out = []
    for k in range(n_poses):
        steps_out.append({"type": "rest", "rest_s": float(rest[k])})
        if best_pairs and k < 3:  # the turns about e_k back to the mark, then a reorientation
            e = np.eye(3)[k]
            steps_out += [_motion("turn", sign * e, TURN_DEG) for _ in range(best_pairs) for sign in (1.0, -1.0)]
        if k < n_poses - 1:
            kind = "reorient" if best_pairs and k < 3 else "move"
            move = {"type": kind, "axis": axes[k].tolist(), "angle_deg": float(np.degrees(ang[k]))}
            steps_out.append({**move, "duration_s": float(dur[k])})
    res = TriadProtocol(
        tuple(model.terms),
        crit,
        noise,
        total,
        att[0],
        steps_out,
        value,
        final,
        hist,
        best_pairs,
        {k: v[0] for k, v in found.items()},
    )
    if not res.converged:
        warnings.warn(f"the protocol design did not converge: {res.convergence_note}", ConvergenceWarning, stacklevel=2)
    return res


def baselines(model, n_poses: int, total_s: float, noise: TriadNoise) -> dict:
    """{name: (F, σ dict)} of Ferraris' protocol and imu_tk's random poses (mean F of :data:`RANDOM_DRAWS`)."""
    out = {}
    c0, st = ferraris_steps(total_s)
    f = steps_fisher(model, c0, st, noise)
    out["imucal Ferraris (6 faces, 3 turns each way)"] = f
    fr = [steps_fisher(model, *random_steps(n_poses, total_s, seed), noise) for seed in range(RANDOM_DRAWS)]
    out[f"imu_tk random ({n_poses} poses, mean of {RANDOM_DRAWS})"] = fr
    return out


def criterion_value(crit: TriadCriterion, f) -> float:
    """The criterion's loss of one F (numpy)."""
    return float(crit.loss(jnp.asarray(f)))


def comparison(proto: TriadProtocol) -> list[dict]:
    """Rows (plan, criterion value, σ of every coefficient) of the design beside the baselines; for imu_tk the
    criterion and σ are means over the draws."""
    model = triad_model(proto.terms)
    n = sum(s["type"] == "rest" for s in proto.steps)
    f = proto.fisher()
    rows = [
        {
            "plan": f"designed ({n} poses, {proto.criterion.text})",
            "criterion": criterion_value(proto.criterion, f),
            "sigma": sigma(f, model),
        }
    ]
    for name, fb in baselines(model, n, proto.total_s, proto.noise).items():
        fs = fb if isinstance(fb, list) else [fb]
        sig = [sigma(x, model) for x in fs]
        rows.append(
            {
                "plan": name,
                "criterion": float(np.mean([criterion_value(proto.criterion, x) for x in fs])),
                "sigma": {k: float(np.mean([s[k] for s in sig])) for k in sig[0]},
            }
        )
    return rows


def protocol_payload(proto: TriadProtocol, rows: list[dict]) -> dict:
    """The protocol file's content (format :data:`PROTOCOL_FORMAT`): the table, the session plan (start attitude
    and steps, what :func:`gyrojax.simulation.triad_session.simulate_session` runs), the noise assumed and the
    predicted σ beside the baselines."""
    n = proto.noise
    return {
        "instrument": "imu-triad",
        "terms": list(proto.terms),
        "criterion": proto.criterion.text,
        "total_s": proto.total_s,
        "noise": {
            "arw_deg_per_sqrt_h": n.arw,
            "acc_noise_g": n.acc_noise_g,
            "rate_hz": n.rate_hz,
            "latitude_deg": n.latitude_deg,
            "earth_rate": n.earth_rate,
            "placement_deg": n.placement_deg,
        },
        "pace": {"hand_rate_dps": HAND_RATE_DPS, "min_turn_s": MIN_TURN_S},
        "table": proto.table(),
        "session": {"start_attitude": np.asarray(proto.start_attitude).tolist(), "steps": proto.steps},
        "search": {
            "loss": proto.loss,
            "start_losses": proto.start_losses.tolist(),
            "iterations": len(proto.history),
            "converged": proto.converged,
            **({"reason": proto.convergence_note} if not proto.converged else {}),
        },
        "comparison": rows,
    }


def save_protocol(path, payload: dict, force: bool = False):
    """Write a protocol file through :mod:`gyrojax.protocol` (atomic, strict JSON, tagged)."""
    from gyrojax.protocol import save

    return save(path, payload, PROTOCOL_FORMAT, PROTOCOL_VERSION, force=force)


def load_protocol(path) -> dict:
    """Read a protocol file back (its session plan under ``session``); :class:`FormatError` naming file and key."""
    from gyrojax.protocol import load, require

    doc = load(path, PROTOCOL_FORMAT, PROTOCOL_VERSION)
    require(doc, ("session", "terms", "noise"), str(path))
    require(doc["session"], ("start_attitude", "steps"), f"{path}: session")
    return doc
