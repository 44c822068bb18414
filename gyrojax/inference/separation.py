"""Which built-in test plan would separate effects that a campaign cannot tell apart: the plans in which their
regressors (with D_F) are not collinear (the ``separated_by`` of :class:`gyrojax.inference.diagnose.Candidate`);
and, for a pair on an SDF campaign, the predicted power of a follow-up test on the campaign's own table
(:func:`designed_entry`, the cheap bound of what ``gyrojax design --separate`` designs by gradients,
:mod:`gyrojax.planning.separate`)."""

from __future__ import annotations

import dataclasses
import math
from functools import lru_cache

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import tails
from gyrojax.data.arrays import record_data
from gyrojax.data.importclues import signed_permutations
from gyrojax.inference.identifiability import ALIAS_TOL
from gyrojax.inference.lstsq import lstsq_normal
from gyrojax.inference.scoring import ALPHA
from gyrojax.physics import effects as fx
from gyrojax.physics import registry
from gyrojax.physics.kept_model import kept_selected
from gyrojax.physics.model import Model, jacobian, measurement_rows
from gyrojax.runtime.kept import kept_arrays


@lru_cache(maxsize=4)
def _plan_jacobians(kind: str):
    """Regressors of every named effect in a few short built-in plans (computed once per process; with built-in
    effects only, kept on disk across processes: :func:`gyrojax.runtime.kept.kept_arrays`)."""
    model = Model(tuple(n for n in fx.names(kind) if n not in fx.TEMPERATURE_EFFECTS), kind)  # no plan varies it
    if not set(model.terms) <= registry.BUILTIN:
        return model, _compute_plan_jacobians(model)
    names, *arrays = kept_arrays("plan_jacobians", (kind, model.terms), lambda: _flat(_compute_plan_jacobians(model)))
    return model, dict(zip(names.tolist(), arrays))


def _flat(jacs: dict) -> list:
    return [np.array(list(jacs)), *jacs.values()]


def _compute_plan_jacobians(model: Model) -> dict:
    from gyrojax.data import plans
    from gyrojax.simulation.simulator import plan_records

    options = {
        "multiposition-24": lambda: plans.multiposition(24, minutes=1.0, dt_s=6.0),
        "tumble (flipped, CW/CCW)": lambda: plans.tumble(revolutions=1.0, dt_s=60.0),
        "two-axis-tumble 5:1": lambda: plans.two_axis_tumble(5, 1, revolutions=1.0, dt_s=60.0),
        "rate-ladder": lambda: plans.rate_ladder(seconds=5.0, dt_s=1.0),
        "eight-position": lambda: plans.eight_position(minutes=1.0, dt_s=6.0),
    }
    runs, owner = [], []
    for name, build in options.items():
        for rec in plan_records(build()):
            runs.append(rec)
            owner.append(name)
    # one compile for all: every run padded to two table axes (a still dummy axis outermost) and one length
    n_max = max(r.n for r in runs)
    padded, lengths = [], []
    for rec in runs:
        d = record_data(rec)
        n = rec.n
        pad = lambda a: np.concatenate([a, np.repeat(a[-1:], n_max - n, axis=0)], axis=0)  # noqa: E731
        angles, rates, axes = np.asarray(d.angles), np.asarray(d.rates), np.asarray(d.axes)
        if axes.shape[0] == 1:
            angles = np.column_stack([np.zeros(n), angles])
            rates = np.column_stack([np.zeros(n), rates])
            axes = np.vstack([[0.0, 0.0, 1.0], axes])
        padded.append(
            dataclasses.replace(
                d,
                axes=axes,
                angles=pad(angles),
                rates=pad(rates),
                time_s=pad(np.asarray(d.time_s)),
                temperature=pad(np.asarray(d.temperature)),
                y=pad(np.asarray(d.y)),
                weight=pad(np.asarray(d.weight)),
                command=pad(np.asarray(d.command)),
                dt=np.zeros(n_max - 1),
                triad=np.asarray(d.triad),
                latitude=np.asarray(d.latitude),
                gravity=np.asarray(d.gravity),
                encoder_axis=1,
            )
        )
        lengths.append(n)
    batch = jax.tree_util.tree_map(lambda *xs: np.stack(xs), *padded)
    jac = jax.jit(jax.vmap(lambda d: jacobian(model, jnp.zeros(model.size), d)))(batch)
    out: dict = {}
    for name, n, j in zip(owner, lengths, np.asarray(jac)):
        out.setdefault(name, []).append(j[:n])
    return {k: np.concatenate(v, axis=0) for k, v in out.items()}


SETUP_MEASUREMENTS = {
    "table_tilt": "level the table base with a precision level or inclinometer (fixes table_tilt)",
    "table_azimuth": "survey the table's azimuth with a theodolite or north-finder (fixes table_azimuth)",
    "encoder_harmonic": "calibrate the angle readout against a polygon and autocollimator (fixes encoder_harmonic)",
}
"""Measurements outside any rate test that pin a set-up effect down: a tilt about North and an azimuth error turn
the Earth rate the same way in every table test (both move only its East component in the base), and only the
g-sensitivity times the tilted gravity — far below the noise of any practical test — tells them apart."""


def setup_measurements(group) -> list[str]:
    """Independent measurements that would separate the set-up effects (arcsec-size table errors) of ``group`` when
    no rate test can."""
    return [SETUP_MEASUREMENTS[g] for g in group if g in SETUP_MEASUREMENTS]


def separating_plans(kind: str, effects: tuple, context=None) -> list:
    """Built-in plans in which the regressors of ``effects`` (with D_F) are not collinear: the extra test to run;
    with ``context`` (campaign, linearisation, full model, fit, candidates of a diagnosis) the designed test on the
    campaign's table first (:func:`designed_entry`)."""
    if kind != fx.SDF:
        return []
    first = [] if context is None else [e for e in [designed_entry(effects[0], effects[1], *context)] if e]
    return first + _built_in(kind, effects)


def _built_in(kind: str, effects: tuple) -> list:
    model, jacs = _plan_jacobians(kind)
    sl = model.slices()
    names = tuple(dict.fromkeys(("D_F",) + tuple(effects)))
    if any(n not in sl for n in names):
        return []
    cols = np.concatenate([np.arange(model.size)[sl[n]] for n in names])
    out = []
    for plan, j in jacs.items():
        sub = j[:, cols]
        norms = np.sqrt((sub * sub).sum(axis=0))
        if np.any(norms == 0):
            continue
        s = np.linalg.svd(sub / norms, compute_uv=False)
        if s[-1] > 1e-3 * s[0]:
            out.append(plan)
    return out


# ---- a follow-up test on the campaign's own table ---------------------------------------------------------------

ENTRY_HOURS = 1.0  # dwell of the cheap follow-up test whose power diagnose quotes
ENTRY_POSITIONS = 48  # random chain angles per mounting in that test
ENTRY_MIN_POWER = 0.5  # below it the entry is left out


def case_turns() -> np.ndarray:
    """The 24 proper rotations by multiples of 90° (signed permutation matrices, det +1), identity first: the
    mountings reachable by turning an instrument's case on its faces (rows act on the instrument axes)."""
    return np.array([p for p in signed_permutations() if np.linalg.det(p) > 0])


def static_rows(model: Model, data, triad, angles_rad):
    """Regressor rows (n, p) at θ = 0 of static positions ``angles_rad`` (n, k) of ``data``'s table at mounting
    ``triad`` (instrument axes as rows, platform coordinates); traceable (``jit``, ``vmap``, ``grad``)."""
    n, k = angles_rad.shape
    d = dataclasses.replace(
        data,
        triad=triad,
        time_s=jnp.zeros(n),
        angles=angles_rad,
        rates=jnp.zeros((n, k)),
        temperature=jnp.full(n, 20.0),
        y=jnp.zeros(n),
        weight=jnp.ones(n),
        command=jnp.zeros(n),
        dt=jnp.ones(max(n - 1, 0)),
        mode="rebalance",
        servo_axis=None,
    )
    return jacobian(model, jnp.zeros(model.size), d).reshape(n, model.size)


def _mounted_rows(model: Model, data, triads, angles_rad):
    """:func:`static_rows` at each of the mountings ``triads`` (m, 3, 3)."""
    return jax.vmap(lambda t: static_rows(model, data, t, angles_rad))(triads)


_mounted_rows_jit = jax.jit(_mounted_rows, static_argnums=0)


def schur_noncentrality(f: np.ndarray, test: np.ndarray, rest: np.ndarray, delta: np.ndarray) -> float:
    """δᵀ (F_tt − F_tr F_rr⁻¹ F_rt) δ: the score-test noncentrality of the coefficients ``test`` beside ``rest``."""
    ftr = f[np.ix_(test, rest)]
    s = f[np.ix_(test, test)] - ftr @ lstsq_normal(f[np.ix_(rest, rest)], ftr.T, rank_tol=ALIAS_TOL)[0]
    return float(delta @ s @ delta)


def designed_entry(a: str, b: str, campaign, lin, full: Model, result, candidates) -> str:
    """``separated_by`` text for the pair (a, b) of an SDF campaign: the power at 1 % of the weaker score test (a
    with b in the model, and b with a) of the joint fit of the campaign and a test of :data:`ENTRY_HOURS` h on the
    campaign's table, its dwell shared by :data:`ENTRY_POSITIONS` random chain angles at the best of the 24 case
    mountings, at the sizes of the current estimates ("" when the pair is not in ``full``, not estimated, or the
    power is below :data:`ENTRY_MIN_POWER`). A bound from below on what ``gyrojax design --separate`` designs."""
    sl = full.slices()
    model = result.model
    if a not in sl or b not in sl or not campaign.data:
        return ""
    sizes = {}
    for name in (a, b):
        if name in model.terms:
            sizes[name] = np.asarray(result.theta[model.slices()[name]], float)
        else:
            c = next((c for c in candidates if c.name == name and c.estimate), None)
            if c is None:
                return ""
            sizes[name] = np.array([c.estimate[k]["value"] for k in fx.get(name).coefficients], float)
    cols = np.arange(full.size)
    base = np.setdiff1d(cols[: model.size], np.concatenate([cols[sl[a]], cols[sl[b]]]))
    ia = np.arange(len(base), len(base) + len(cols[sl[a]]))
    ib = np.arange(ia[-1] + 1, ia[-1] + 1 + len(cols[sl[b]]))
    keep = np.concatenate([base, cols[sl[a]], cols[sl[b]]])
    sub = Model(tuple(t for t in model.terms if t not in (a, b)) + (a, b), full.kind)
    white = [float(nz.white) for nz in result.noise]
    if not all(w > 0 and math.isfinite(w) for w in white):
        return ""
    f_rec = np.zeros((keep.size, keep.size))
    for (_r, j, _lab, _t), d, w in zip(lin, campaign.data, white):  # σ² = (60 N)²/Δt per measurement
        dt = np.asarray(d.dt)
        jj = j[:, keep]
        f_rec += jj.T @ jj * (float(np.median(dt)) if dt.size else 1.0) / (60.0 * w) ** 2
    table = measurement_rows(campaign.data[0], 0, 1)  # the table and mounting (static_rows sets the samples)
    k = int(table.angles.shape[1])
    ang = np.random.default_rng(0).uniform(0.0, 2.0 * math.pi, (ENTRY_POSITIONS, k))
    triads = np.einsum("mij,jk->mik", case_turns(), np.asarray(table.triad))
    rows = np.asarray(kept_selected("static_rows", _mounted_rows, _mounted_rows_jit, sub, table, triads, ang))
    rows = rows[..., : sub.size]
    per_sample = ENTRY_HOURS * 3600.0 / ENTRY_POSITIONS / (60.0 * float(np.sqrt(np.mean(np.square(white))))) ** 2
    best, bi = 0.0, np.arange(len(base))
    for r in rows:
        f = f_rec + per_sample * r.T @ r
        lam_a = schur_noncentrality(f, ia, np.concatenate([bi, ib]), sizes[a])
        best = max(best, min(lam_a, schur_noncentrality(f, ib, np.concatenate([bi, ia]), sizes[b])))
    q = max(sizes[a].size, sizes[b].size)
    pw = tails.score_power(max(best, 1e-300), q, ALPHA)
    if pw < ENTRY_MIN_POWER:  # not worth naming: the set-up measurements or built-in plans speak instead
        return ""
    return (
        f"design --separate {a},{b}: a follow-up test on this table (case remounted) has power {pw:.2f} "
        f"in {ENTRY_HOURS:g} h, or more as designed"
    )
