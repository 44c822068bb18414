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

**Criteria.** ``D`` −log det F; ``A`` Σ Var θ_i (report units: ppm and arcsec weigh more than deg/h);
``c:NAME=w,…`` Var(Σ w θ) of per-channel coefficients (``c:E_SF[x]``).

**Baselines** at the same total time and pace: imucal's Ferraris protocol (6 faces, one turn of 360° each way about
each axis on its face, the angle known to √2 σ_placement, flips between faces not fitted) and imu_tk's random
poses (N uniformly random attitudes, the mean of :data:`RANDOM_DRAWS` draws).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np
import optax
from scipy.spatial.transform import Rotation

from gyrojax.errors import ModelError
from gyrojax.inference.triad import DEFAULT_ROTATION_TERMS as LINEAR_TERMS  # bias, g-terms, scale, misalignment
from gyrojax.physics import effects as fx
from gyrojax.physics import triad as tp
from gyrojax.planning.triad_fisher import (
    TriadNoise,
    coefficient_names,
    covariance,
    move_fisher,
    rest_fisher,
    rot,
    scaled,
    turn_fisher,
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


def design_parts(params, total_s):
    """(attitudes, Ups, rest s, move axes, angles rad, durations s) of the design parameters (module doc)."""
    x0, v, z = params
    att = _chain(x0, v)
    up = jnp.einsum("kji,j->ki", att, jnp.asarray(UP))  # C_kᵀ e_U
    ang = jnp.sqrt(jnp.sum(v * v, axis=1) + 1e-30)
    axes = v / ang[:, None]
    dur = MIN_TURN_S + jnp.degrees(ang) / HAND_RATE_DPS
    rest = _rests(z, total_s, jnp.sum(dur))
    return att, up, rest, axes, ang, dur


def design_fisher(model, params, total_s, noise: TriadNoise):
    """F of the designed protocol's parameters (differentiable)."""
    _, up, rest, axes, ang, dur = design_parts(params, total_s)
    return rest_fisher(model, up, rest, noise) + move_fisher(model, up[:-1], axes, ang, dur, rest[:-1], rest[1:], noise)


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

    def fisher(self) -> np.ndarray:
        """The protocol's Fisher information (:func:`gyrojax.planning.triad_fisher.steps_fisher`), θ order."""
        return steps_fisher(triad_model(self.terms), self.start_attitude, self.steps, self.noise)

    def table(self) -> list[dict]:
        """The protocol a person follows: one row per rest, with the turn that follows it."""
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
            rows[-1].update(
                {
                    "turn_axis": axis_text(ax),
                    "angle_deg": float(s["angle_deg"]),
                    "turn_s": float(s["duration_s"]),
                    "peak_rate_dps": math.pi / 2 * float(s["angle_deg"]) / float(s["duration_s"]),
                }
            )
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
) -> TriadProtocol:
    """Design an ``n_poses`` protocol of ``minutes`` in total (rests and turns) minimising the criterion (module
    doc); refuses terms the protocol cannot fit, too few poses, or too little time for the turns."""
    model = triad_model(terms)
    noise = noise or TriadNoise()
    crit = TriadCriterion.parse(criterion, model)
    need = min_poses(model)
    if n_poses < need:
        raise ModelError(
            f"{n_poses} poses cannot identify {', '.join(model.terms)} on three channels: at least {need} are needed"
        )
    total = minutes * 60.0
    if total <= (n_poses - 1) * turn_seconds(180.0) + n_poses * 1.0:
        raise ModelError(
            f"{minutes:g} min is too short for {n_poses} poses: the moves alone take about "
            f"{(n_poses - 1) * turn_seconds(180.0) / 60:.1f} min at a hand's pace; give more --minutes"
        )
    key = jax.random.PRNGKey(seed)
    k1, k2 = jax.random.split(key)
    x0 = jax.random.normal(k1, (starts, 3)) * 2.0
    v0 = jax.random.normal(k2, (starts, n_poses - 1, 3)) * 1.2
    z0 = jnp.zeros((starts, n_poses))

    def loss(p):
        return crit.loss(design_fisher(model, p, total, noise))

    opt = optax.adam(learning_rate)
    vg = jax.value_and_grad(loss)

    def run(p0):
        def step(carry, _):
            p, s = carry
            val, g = vg(p)
            upd, s = opt.update(g, s, p)
            return (optax.apply_updates(p, upd), s), val

        (p, _), hist = jax.lax.scan(step, (p0, opt.init(p0)), None, length=steps)
        return p, hist, loss(p)

    p, hist, final = jax.jit(jax.vmap(run))((x0, v0, z0))
    final = np.where(np.isfinite(np.asarray(final)), np.asarray(final), np.inf)
    b = int(np.argmin(final))
    best = jax.tree_util.tree_map(lambda a: a[b], p)
    if not np.isfinite(final[b]):
        raise ModelError(f"no start of the search found a protocol of {n_poses} poses that identifies the terms")
    att, up, rest, axes, ang, dur = (np.asarray(x) for x in design_parts(best, total))
    # heading is not designed (the fit marginalises it): start at heading 0 with the first rest's Up
    steps_out = [{"type": "rest", "rest_s": float(rest[0])}]
    for k in range(n_poses - 1):
        steps_out += [
            {
                "type": "move",
                "axis": axes[k].tolist(),
                "angle_deg": float(np.degrees(ang[k])),
                "duration_s": float(dur[k]),
            },
            {"type": "rest", "rest_s": float(rest[k + 1])},
        ]
    return TriadProtocol(
        tuple(model.terms), crit, noise, total, att[0], steps_out, float(final[b]), final, np.asarray(hist[b])
    )


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
        "search": {"loss": proto.loss, "start_losses": proto.start_losses.tolist(), "iterations": len(proto.history)},
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


def advantage(crit: TriadCriterion, base_loss: float, design_loss: float, p: int) -> float:
    """How much better the design is than a baseline on the criterion (> 1: better): for D the ratio of the
    geometric mean σ, exp((loss_base − loss_design) / 2p); for A and c the ratio of the σ's, √(loss_base /
    loss_design)."""
    if crit.kind == "D":
        return math.exp((base_loss - design_loss) / (2.0 * p))
    return math.sqrt(base_loss / design_loss)


def table_text(table: list[dict]) -> str:
    """The protocol as a table a person follows."""
    lines = [
        f"{'step':>4}  {'face up (Up in the body frame)':<32} {'rest s':>7}  {'then turn about':<22} {'angle':>7}"
        f"  {'in s':>5}"
    ]
    for r in table:
        turn = f"{r['turn_axis']:<22} {r['angle_deg']:6.1f}°  {r['turn_s']:5.1f}" if "turn_axis" in r else "(end)"
        lines.append(f"{r['step']:>4}  {r['up']:<32} {r['rest_s']:7.1f}  {turn}")
    return "\n".join(lines)


def comparison_text(rows: list[dict], crit: TriadCriterion) -> str:
    """Predicted σ of every coefficient, the design beside the baselines, and the criterion's ratio."""
    names = list(rows[0]["sigma"])
    p = len(names)
    heads = ["designed", "Ferraris", "imu_tk"][: len(rows)]
    lines = [f"{'coefficient':<12}" + "".join(f"{h:>12}" for h in heads)]
    for n in names:
        lines.append(f"{n:<12}" + "".join(f"{r['sigma'][n]:12.4g}" for r in rows))
    lines.append(f"{'criterion ' + crit.text:<12}" + "".join(f"{r['criterion']:12.5g}" for r in rows))
    ratio = [advantage(crit, r["criterion"], rows[0]["criterion"], p) for r in rows]
    what = "geometric-mean sigma" if crit.kind == "D" else "sigma"
    lines.append(f"{'ratio':<12}" + "".join(f"{x:12.3f}" for x in ratio) + f"   (baseline / designed {what})")
    lines.append("units: D_F deg/h; D_I, D_O, D_S deg/h/g; E_SF ppm; M_O, M_S arcsec; imu_tk: mean over draws")
    return "\n".join(lines)
