"""Calibration protocols for hand-held IMUs: the rests and the turns between them that minimise the predicted σ of
chosen triad coefficients, designed by gradients (``gyrojax design --instrument imu-triad``).

**Parameterisation.** N rests joined by N − 1 gravity-to-gravity moves (imu_tk's kind: the accelerometer measures
both ends, so the hand's placement error does not enter). The first rest's attitude is a rotation vector x₀; move
k turns the box by the body-frame rotation vector v_k (axis v/|v|, angle |v|), so rest k + 1's attitude is
C_k R(v_k) and its Up in the body frame C_{k+1}ᵀ e_U. A move of Φ degrees takes :data:`MIN_TURN_S` +
Φ / :data:`HAND_RATE_DPS` seconds (a person's pace); the rests share what is left of the total time by a
softmax, each at least a quarter of the equal share. The loss is a criterion (:mod:`gyrojax.planning.criteria`:
``D``, ``A``, ``E`` or ``c:NAME=w,…`` of per-channel coefficients, ``c:E_SF[x]``) of the triad's Fisher
information (:mod:`gyrojax.planning.triad_fisher`), minimised from several random starts by Adam
(:func:`gyrojax.planning.search.adam_scan`), the best start of each structure then refined by L-BFGS until its
loss settles (:func:`gyrojax.planning.search.lbfgs_while`); the best is kept. The loss is ill-conditioned (the rest
times and nearly parallel moves barely change it), so a capped search can stop short: it then says so.

**Known-angle turns** (Ferraris'): a few discrete structures are searched (:data:`TURN_PAIRS`): m pairs of 360°
turns, one each way, about each body axis e_j, made on rest j (j = 0, 1, 2) with the box on face +e_j (the turn
about the vertical, the table holding the tilt; rests 0–2 are those faces), each followed by a reorientation (not
fitted, as Ferraris' flips: a move is fitted from the rests on either side, and a rest split around the turns would
repeat a pose). A turn's angle is known to √2 σ_placement about its axis; with σ_placement → 0 the search can hold
Ferraris' turns and moves besides. Every structure and every start is one lane of one compiled, ``vmap``-ed search:
the structure's turns and fitted moves are weights of the lane's parts.

**Baselines** at the same total time and pace: imucal's Ferraris protocol (6 faces, one turn of 360° each way about
each axis on its face, the angle known to √2 σ_placement, flips between faces not fitted) and imu_tk's random
poses (N uniformly random attitudes, the mean of :data:`RANDOM_DRAWS` draws).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from functools import lru_cache, partial

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import protocol
from gyrojax.errors import ConvergenceWarning, ModelError
from gyrojax.physics import effects as fx
from gyrojax.physics import so3
from gyrojax.physics import triad as tp
from gyrojax.planning import search
from gyrojax.planning.criteria import Criterion
from gyrojax.planning.triad_fisher import (
    Parts,
    TriadNoise,
    pad_parts,
    protocol_information,
    rows_basis,
    steps_parts,
)
from gyrojax.runtime.kept import Kept
from gyrojax.runtime.threads import in_background
from gyrojax.simulation.triad import face_attitude, random_attitude, relative_turn

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
FACE_ATTITUDES = np.array([face_attitude(i, 1.0, 0.0) for i in range(3)])
"""The rests of the known-angle turns: the box on the faces +x, +y, +z at heading 0 (body → ENU)."""
_FACES_X0 = so3.log(FACE_ATTITUDES[0])
_FACES_MOVES = np.array([so3.log(a.T @ b) for a, b in zip(FACE_ATTITUDES, FACE_ATTITUDES[1:])])


def turn_seconds(angle_deg) -> float:
    """Duration (s) of a hand turn by ``angle_deg`` (deg) at the pace of :data:`HAND_RATE_DPS`."""
    return MIN_TURN_S + abs(angle_deg) / HAND_RATE_DPS


def session_seconds(steps) -> float:
    """Length (s) of a hand session's steps: its rests and its moves, one after another."""
    return sum(float(s.get("rest_s", s.get("duration_s", 0.0))) for s in steps)


def triad_model(terms):
    """The channel model of ``terms``, refused with one line when a term is unknown, not of an ``imu-triad``
    instrument, or outside what moves integrate (the linear model)."""
    terms = list(terms)
    known = fx.names()
    bad = [t for t in terms if t not in known]
    if bad:
        raise ModelError(
            f"unknown effect {bad[0]!r}; the imu-triad protocol designs for {', '.join(tp.DEFAULT_ROTATION_TERMS)}"
        )
    try:
        model = tp.channel_model(terms)
    except ModelError as e:
        raise ModelError(f"{e} (not an effect of an imu-triad's channels)") from None
    other = [t for t in model.terms if t not in tp.DEFAULT_ROTATION_TERMS]
    if other:
        raise ModelError(
            f"effect {other[0]!r} is not fitted from hand moves of an imu-triad; the protocol designs for "
            f"{', '.join(tp.DEFAULT_ROTATION_TERMS)}"
        )
    return model


def parse_criterion(text: str, model) -> Criterion:
    """The criterion ``text`` over the triad's coefficients (:func:`gyrojax.physics.triad.channel_names`)."""
    return Criterion.parse(text, model, list(tp.channel_names(model)))


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


# ---- the design's parameters → its parts ----------------------------------------------------------------------


def _chain(x0, v):
    """Attitudes (N, 3, 3) body → ENU of the rests from the start rotation vector and the moves' vectors."""

    def step(c, vk):
        c2 = so3.compose(c, so3.exp(vk))
        return c2, c2

    c0 = so3.exp(x0)
    _, rest = jax.lax.scan(step, c0, v)
    return jnp.concatenate([c0[None], rest])


def _rest_seconds(z, total_s, motions_s):
    """Rests (N,) s sharing what the motions leave of ``total_s`` by a softmax of ``z``, each ≥ ¼ of the equal share."""
    n = z.shape[0]
    m = 0.25 / n
    return jnp.maximum(total_s - motions_s, 1.0) * (m + (1.0 - n * m) * jax.nn.softmax(z))


def design_parts(params, pairs, total_s, max_pairs: int):
    """(attitudes (N, 3, 3), :class:`~gyrojax.planning.triad_fisher.Parts`) of the design parameters (x₀, v, z)
    with ``pairs`` (traceable, ≤ ``max_pairs``) pairs of known-angle turns about each body axis (module doc): turn
    slots beyond ``pairs`` and the moves replaced by reorientations weigh 0; rotation vectors and angles in rad,
    ``total_s`` and the parts' times in s. Traceable."""
    x0, v, z = params
    turned = pairs > 0
    n_moves = v.shape[0]
    x0 = jnp.where(turned, _FACES_X0, x0)
    v = jnp.where(turned & (np.arange(n_moves) < 2)[:, None], np.resize(_FACES_MOVES, v.shape), v)
    att = _chain(x0, v)
    up = att[:, 2, :]  # C_kᵀ e_U
    ang = jnp.sqrt(jnp.sum(v * v, axis=1) + 1e-30)
    axes = v / ang[:, None]
    dur = MIN_TURN_S + jnp.degrees(ang) / HAND_RATE_DPS
    rest = _rest_seconds(z, total_s, jnp.sum(dur) + 6 * pairs * turn_seconds(TURN_DEG))
    slots = 6 * max_pairs  # for each pair q: about +e_j then −e_j (j = 0, 1, 2) on rest j
    turn_axis = np.tile(np.concatenate([np.eye(3), -np.eye(3)]), (max_pairs, 1))
    turn_w = (np.repeat(np.arange(max_pairs), 6) < pairs).astype(float)
    move_w = jnp.where(turned & (np.arange(n_moves) < 3), 0.0, 1.0)  # after the turns, a reorientation
    parts = Parts(
        up,
        rest,
        jnp.ones_like(rest),
        up[np.tile(np.arange(3), 2 * max_pairs)],
        turn_axis,
        jnp.full(slots, 2.0 * math.pi),
        jnp.full(slots, turn_seconds(TURN_DEG)),
        turn_w,
        up[:-1],
        axes,
        ang,
        dur,
        rest[:-1],
        rest[1:],
        move_w,
    )
    return att, parts


# ---- the search --------------------------------------------------------------------------------------------------


@lru_cache(maxsize=16)
def _kept_search(crit: Criterion, max_pairs: int, adam_steps: int, lbfgs_steps: int) -> tuple[Kept, Kept]:
    """The compiled search of one criterion and configuration in its two stages, :func:`_adam` and :func:`_refine`,
    each kept across processes (:class:`gyrojax.runtime.kept.Kept`: a fresh ``gyrojax design`` neither traces nor
    lowers them again). Two executables, not one: the second is read from its file while the first runs."""
    statics = {"crit": crit, "max_pairs": max_pairs, "adam_steps": adam_steps}
    adam = Kept.of("triad_adam", partial(_adam, **statics), *sorted(statics.items()))
    statics["lbfgs_steps"] = lbfgs_steps
    return adam, Kept.of("triad_refine", partial(_refine, **statics), *sorted(statics.items()))


def _loss(crit, max_pairs, total_s, basis, noise, prior, weights):
    """The search's loss of (parameters, structure): the criterion of the information the protocol adds to
    ``prior`` (3p × 3p); ``weights`` (3p,) the criterion's (:meth:`~gyrojax.planning.criteria.Criterion.loss`)."""
    p_total = basis[0].shape[-1]

    def loss(p, k):
        f = prior + protocol_information(basis, design_parts(p, k, total_s, max_pairs)[1], noise)
        return crit.loss(f, p_total, weights)

    return loss


def _adam(params, pairs, total_s, basis, noise, learning_rate, prior, weights, *, crit, max_pairs, adam_steps):
    """Every lane (a structure's ``pairs`` and a start) searched at once by Adam, each keeping its iterate of least
    loss (:func:`gyrojax.planning.search.adam_scan`). Returns the lanes' parameters, loss histories and final
    losses. The model and the session are arguments, not constants: one compiled search serves every noise, site and
    duration of the same shapes."""
    loss = _loss(crit, max_pairs, total_s, basis, noise, prior, weights)

    def adam(p0, k):
        return search.adam_scan(jax.value_and_grad(loss), p0, adam_steps, learning_rate, k, keep_best=True)

    return jax.vmap(adam)(params, pairs)


def _refine(p, hist, final, pairs, total_s, basis, noise, prior, weights, *, crit, max_pairs, adam_steps, lbfgs_steps):
    """The best lane of each structure after :func:`_adam` refined by L-BFGS until its loss settles
    (:func:`gyrojax.planning.search.lbfgs_while`, at most ``lbfgs_steps``), kept where it lowered the loss. Returns
    the lanes' loss histories (NaN where a lane was not iterated), final losses, and their attitudes and parts at the
    end."""
    if lbfgs_steps:
        loss = _loss(crit, max_pairs, total_s, basis, noise, prior, weights)
        hist = jnp.concatenate([hist, jnp.full((hist.shape[0], lbfgs_steps), jnp.nan)], axis=1)
        best = jnp.stack([jnp.argmin(jnp.where(pairs == k, final, jnp.inf)) for k in range(max_pairs + 1)])

        def refine(i):
            pi = jax.tree_util.tree_map(lambda a: a[i], p)
            p2, h2 = search.lbfgs_while(lambda q: loss(q, pairs[i]), pi, lbfgs_steps)
            return p2, h2, loss(p2, pairs[i])

        p2, h2, v2 = jax.vmap(refine)(best)
        for r in range(max_pairs + 1):  # in turn: two absent structures may name the same lane
            i = best[r]
            good = jnp.isfinite(v2[r]) & (v2[r] < final[i])
            p = jax.tree_util.tree_map(lambda a, b: a.at[i].set(jnp.where(good, b[r], a[i])), p, p2)
            final = final.at[i].set(jnp.where(good, v2[r], final[i]))
            hist = hist.at[i, adam_steps:].set(jnp.where(good, h2[r], hist[i, adam_steps:]))
    att, parts = jax.vmap(lambda q, k: design_parts(q, k, total_s, max_pairs))(p, pairs)
    return hist, final, (att, tuple(parts))  # plain tuples out: a kept trace's output tree


@dataclass
class TriadProtocol:
    """A designed protocol: the start attitude (body → ENU at heading 0), the steps, the search's report."""

    terms: tuple
    criterion: Criterion
    noise: TriadNoise
    total_s: float
    start_attitude: np.ndarray
    steps: list
    loss: float
    start_losses: np.ndarray
    history: np.ndarray
    turn_pairs: int = 0
    structure_losses: dict = field(default_factory=dict)
    criterion_text: str = ""

    @property
    def criterion_name(self) -> str:
        """The criterion as given (``c:E_SF[x]=1``), else its label."""
        return self.criterion_text or self.criterion.label()

    @property
    def convergence_note(self) -> str:
        """Why the search is not taken as converged ("" when it is; :mod:`gyrojax.planning.search`)."""
        return search.convergence_note(self.history, self.loss, "raise --lbfgs-steps (the L-BFGS refinement)")

    @property
    def converged(self) -> bool:
        """Whether the chosen structure's search settled (see :attr:`convergence_note`)."""
        return not self.convergence_note

    def fisher(self) -> np.ndarray:
        """The protocol's Fisher information (:func:`steps_fisher`), θ order."""
        return steps_fisher(triad_model(self.terms), self.start_attitude, self.steps, self.noise)

    def table(self) -> list[dict]:
        """The protocol a person follows: one row per rest, with the motions that follow it (``motions``: kind
        ``known-angle`` — by exactly this angle, back to a mark —, ``free`` — to the next rest, roughly: the
        accelerometer measures where it ends — or ``not fitted``); ``turn_axis``/``angle_deg``/``turn_s`` the last."""
        rows = []
        for s, c in zip(self.steps, _step_attitudes(self.start_attitude, self.steps)):
            if s["type"] == "rest":
                up = c.T @ UP
                rows.append(
                    {"step": len(rows) + 1, "up": face_up(up), "up_body": up.tolist(), "rest_s": float(s["rest_s"])}
                )
                continue
            motion = {
                "turn_axis": axis_text(s["axis"]),
                "angle_deg": float(s["angle_deg"]),
                "turn_s": float(s["duration_s"]),
                "peak_rate_dps": math.pi / 2 * float(s["angle_deg"]) / float(s["duration_s"]),
            }
            rows[-1].setdefault("motions", []).append({"kind": MOTION_KINDS[s["type"]], **motion})
            rows[-1].update(motion)
        return rows

    def attitudes(self) -> list[np.ndarray]:
        """Body → ENU attitude of every rest, in order."""
        atts = _step_attitudes(self.start_attitude, self.steps)
        return [c for s, c in zip(self.steps, atts) if s["type"] == "rest"]


def _step_attitudes(start_attitude, steps) -> list[np.ndarray]:
    """The attitude (body → ENU) at the start of every step."""
    out, c = [], np.asarray(start_attitude, dtype=float)
    for s in steps:
        out.append(c)
        if s["type"] != "rest":
            ax = np.asarray(s["axis"], dtype=float)
            c = c @ so3.rotation(ax / np.linalg.norm(ax), math.radians(float(s["angle_deg"])))
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


def _motion(kind, axis, angle_deg):
    return {
        "type": kind,
        "axis": [float(x) for x in axis],
        "angle_deg": float(angle_deg),
        "duration_s": turn_seconds(angle_deg),
    }


def design_protocol(
    terms,
    n_poses: int,
    minutes: float,
    criterion: str = "D",
    noise: TriadNoise | None = None,
    *,
    starts: int = 8,
    steps: int = 150,
    lbfgs_steps: int = 400,
    learning_rate: float = 0.05,
    seed: int = 0,
    turn_pairs=TURN_PAIRS,
    prior=None,
    weights=None,
) -> TriadProtocol:
    """Design an ``n_poses`` protocol of ``minutes`` in total (rests and turns) minimising the criterion (module
    doc) of the information it adds to ``prior`` (3p × 3p, report units, θ order of
    :func:`~gyrojax.physics.triad.channel_names`: what the sessions so far know; default none), the criterion
    ``ratio`` with its ``weights`` (3p,) (:mod:`gyrojax.planning.criteria`): every structure of ``turn_pairs``
    (pairs of known-angle turns about each body axis) searched from the same ``starts`` by ``steps`` Adam
    iterations (each start keeps its iterate of least loss), the best start of each structure then by at most
    ``lbfgs_steps`` L-BFGS ones until its loss settles (two compiled stages), the best kept; refuses terms
    the protocol cannot fit, too few poses, or too little time."""
    model = triad_model(terms)
    noise = noise or TriadNoise()
    crit = criterion if isinstance(criterion, Criterion) else parse_criterion(criterion, model)
    if crit.kind == "detect":
        raise ModelError("criterion detect: the imu-triad design takes D, A, E or c:COEF=w,...")
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
    structures = [k for k in turn_pairs if total > moves_s + 6 * k * turn_seconds(TURN_DEG) + (n_poses + 3) * 1.0]
    if not structures:
        raise ModelError(f"{minutes:g} min leave no time for the rests of {n_poses} poses with known-angle turns")
    rng = np.random.default_rng(seed)
    x0 = rng.standard_normal((starts, 3)) * 2.0
    v0 = rng.standard_normal((starts, n_poses - 1, 3)) * 1.2
    lanes = len(structures) * starts
    params = (np.tile(x0, (len(structures), 1)), np.tile(v0, (len(structures), 1, 1)), np.zeros((lanes, n_poses)))
    pairs = np.repeat(np.array(structures), starts)
    basis = rows_basis(model)
    size = basis[0].shape[-1]
    prior = np.zeros((size, size)) if prior is None else np.asarray(prior, dtype=float)
    weights = np.ones(size) if weights is None else np.asarray(weights, dtype=float)
    if prior.shape != (size, size) or weights.shape != (size,):
        raise ModelError(
            f"prior information {prior.shape} and weights {weights.shape}: the model has {size} coefficients"
        )
    if crit.kind == "ratio" and not (np.all(weights >= 0) and np.any(weights > 0)):
        raise ModelError("criterion ratio: the weights are 1/target² >= 0, at least one > 0")
    adam, refine = _kept_search(crit, max(structures), steps, lbfgs_steps)
    session = (total, basis, noise.numbers())
    # Adam's executable first (one is read at a time); the refinement's, three times the size, is read on a worker
    # thread at the shapes of Adam's outputs while Adam runs
    searched = adam.prepare(params, pairs, *session, learning_rate, prior, weights)
    loading = searched and in_background(refine.prepare, *searched, pairs, *session, prior, weights)
    p, hist, final = adam(params, pairs, *session, learning_rate, prior, weights)
    if loading:
        loading.result()
    out = refine(p, hist, final, pairs, *session, prior, weights)
    hist, final, (att, parts) = jax.tree_util.tree_map(np.asarray, out)  # indexed below: on the host, not by JAX ops
    parts = Parts(*parts)
    final = np.where(np.isfinite(final), final, np.inf)
    by_structure = {k: final[i * starts : (i + 1) * starts] for i, k in enumerate(structures)}
    b = search.best_start(final, "the protocol design")
    best_pairs = int(pairs[b])
    res = TriadProtocol(
        tuple(model.terms),
        crit,
        noise,
        total,
        att[b, 0],
        _design_steps(jax.tree_util.tree_map(lambda a: a[b], parts), best_pairs),
        float(final[b]),
        by_structure[best_pairs],
        _iterated(hist[b]),
        best_pairs,
        {k: float(v.min()) for k, v in by_structure.items()},
        criterion if isinstance(criterion, str) else "",
    )
    if not res.converged:
        warnings.warn(f"the protocol design did not converge: {res.convergence_note}", ConvergenceWarning, stacklevel=2)
    return res


def _iterated(history) -> np.ndarray:
    """A lane's loss history without the slots its search did not reach (NaN)."""
    h = np.asarray(history, dtype=float)
    return h[: h.size - int(np.argmax(~np.isnan(h[::-1])))] if np.isfinite(h).any() else h


def _design_steps(parts: Parts, pairs: int) -> list[dict]:
    """The steps of a designed protocol's parts (numpy): each rest, then on rests 0–2 ``pairs`` known-angle turns
    each way about the body axis of the face, then the move (or, after turns, the reorientation) to the next."""
    out = []
    n = parts.rest_s.shape[0]
    for k in range(n):
        out.append({"type": "rest", "rest_s": float(parts.rest_s[k])})
        if pairs and k < 3:
            e = np.eye(3)[k]
            out += [_motion("turn", sign * e, TURN_DEG) for _ in range(pairs) for sign in (1.0, -1.0)]
        if k < n - 1:
            kind = "reorient" if pairs and k < 3 else "move"
            move = {"type": kind, "axis": parts.move_axis[k].tolist(), "angle_deg": math.degrees(parts.move_angle[k])}
            out.append({**move, "duration_s": float(parts.move_s[k])})
    return out


# ---- any protocol given as steps; the baselines ---------------------------------------------------------------


def _evaluate(parts, basis, noise, *, crit):
    """F and the criterion's loss of every protocol of the stacked ``parts``."""

    def one(pt):
        f = protocol_information(basis, pt, noise)
        return f, (0.0 if crit is None else crit.loss(f, f.shape[0]))

    return jax.vmap(one)(parts)


@lru_cache(maxsize=16)
def _kept_evaluate(crit: Criterion | None) -> Kept:
    """:func:`_evaluate` of one criterion compiled, kept across processes as the search is."""
    return Kept.of("triad_evaluate", partial(_evaluate, crit=crit), crit)


def evaluate(model, protocols, noise: TriadNoise, crit: Criterion | None = None):
    """(F (P, 3p, 3p), criterion losses (P,)) of ``protocols``, each (start attitude, steps), in one compiled call."""
    parts = pad_parts([steps_parts(c0, st) for c0, st in protocols])
    f, loss = _kept_evaluate(crit)(parts, rows_basis(model), noise.numbers())
    return np.asarray(f), np.asarray(loss)


def steps_fisher(model, start_attitude, steps, noise: TriadNoise) -> np.ndarray:
    """F of any protocol given as steps (:mod:`gyrojax.simulation.triad_session`), from ``start_attitude``."""
    return evaluate(model, [(start_attitude, steps)], noise)[0][0]


def sigma(f, model) -> dict:
    """Predicted σ of every coefficient (report units; inf where F is singular)."""
    f = np.asarray(f)
    s = np.sqrt(np.maximum(np.diag(f), 1e-300))
    fs = f / np.outer(s, s)
    ev = np.linalg.eigvalsh(fs)
    names = tp.channel_names(model)
    if ev[0] < 1e-12 * ev[-1]:
        return {n: math.inf for n in names}
    cov = np.linalg.inv(fs) / np.outer(s, s)
    return dict(zip(names, np.sqrt(np.diag(cov)).tolist()))


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
            axis, angle = relative_turn(faces[i], faces[i + 1])
            block.append(_motion("reorient", axis, math.degrees(angle)))
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
    moves = []
    for k in range(n_poses - 1):
        axis, angle = relative_turn(att[k], att[k + 1])
        moves.append(_motion("move", axis, math.degrees(angle)))
    rest = (total_s - sum(m["duration_s"] for m in moves)) / n_poses
    if rest <= 0:
        raise ModelError(f"{total_s / 60:g} min do not hold {n_poses - 1} hand moves")
    steps = [{"type": "rest", "rest_s": rest}]
    for m in moves:
        steps += [m, {"type": "rest", "rest_s": rest}]
    return att[0], steps


BASELINES = ("imucal Ferraris (6 faces, 3 turns each way)", "imu_tk random ({n} poses, mean of {draws})")


def comparison(proto: TriadProtocol) -> list[dict]:
    """Rows (plan, criterion value, σ of every coefficient) of the design beside Ferraris' protocol and imu_tk's
    random poses at the same total time (s); for imu_tk the criterion and σ (report units) are means over
    :data:`RANDOM_DRAWS` draws.
    The Fisher information of all of them in one compiled call."""
    model = triad_model(proto.terms)
    n = sum(s["type"] == "rest" for s in proto.steps)
    protocols = [(proto.start_attitude, proto.steps), ferraris_steps(proto.total_s)]
    protocols += [random_steps(n, proto.total_s, seed) for seed in range(RANDOM_DRAWS)]
    f, loss = evaluate(model, protocols, proto.noise, proto.criterion)
    groups = [
        (f"designed ({n} poses, {proto.criterion_name})", [0]),
        (BASELINES[0], [1]),
        (BASELINES[1].format(n=n, draws=RANDOM_DRAWS), list(range(2, 2 + RANDOM_DRAWS))),
    ]
    rows = []
    for name, idx in groups:
        sig = [sigma(f[i], model) for i in idx]
        rows.append(
            {
                "plan": name,
                "criterion": float(np.mean(loss[idx])),
                "sigma": {k: float(np.mean([s[k] for s in sig])) for k in sig[0]},
            }
        )
    return rows


# ---- the protocol file ------------------------------------------------------------------------------------------


def protocol_payload(proto: TriadProtocol, rows: list[dict]) -> dict:
    """The protocol file's content (format :data:`PROTOCOL_FORMAT`): the table, the session plan (start attitude
    and steps, what :func:`gyrojax.simulation.triad_session.simulate_session` runs), the noise assumed and the
    predicted σ beside the baselines."""
    n = proto.noise
    return {
        "instrument": "imu-triad",
        "terms": list(proto.terms),
        "criterion": proto.criterion_name,
        "total_s": proto.total_s,
        "noise": {
            "arw_deg_per_sqrt_h": n.arw,
            "acc_noise_g": n.acc_noise_g,
            "rate_hz": n.rate_hz,
            "latitude_deg": n.latitude_deg,
            "earth_rate": n.earth_rate,
            "placement_deg": n.placement_deg,
            "gravity_g": n.g,
            "pose_bias_scatter_indicated_deg_per_h": n.pose_scatter_dph,
            "move_angle_noise_deg": n.move_angle_deg,
        },
        "pace": {"hand_rate_dps": HAND_RATE_DPS, "min_turn_s": MIN_TURN_S},
        "table": proto.table(),
        "session": {"start_attitude": np.asarray(proto.start_attitude).tolist(), "steps": proto.steps},
        "search": {
            "loss": proto.loss,
            "start_losses": proto.start_losses.tolist(),
            "iterations": len(proto.history),
            "turn_pairs": proto.turn_pairs,
            "structure_losses": {str(k): v for k, v in proto.structure_losses.items()},
            "converged": proto.converged,
            **({"reason": proto.convergence_note} if not proto.converged else {}),
        },
        "comparison": rows,
    }


def save_protocol(path, payload: dict, force: bool = False):
    """Write a protocol file through :mod:`gyrojax.protocol` (atomic, strict JSON, tagged)."""
    return protocol.save(path, payload, PROTOCOL_FORMAT, PROTOCOL_VERSION, force=force)


def load_protocol(path) -> dict:
    """Read a protocol file back (its session plan under ``session``); :class:`FormatError` naming file and key."""
    doc = protocol.load(path, PROTOCOL_FORMAT, PROTOCOL_VERSION)
    protocol.require(doc, ("session", "terms", "noise"), str(path))
    protocol.require(doc["session"], ("start_attitude", "steps"), f"{path}: session")
    return doc
