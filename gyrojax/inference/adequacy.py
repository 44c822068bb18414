"""Model adequacy beyond the named library: residual structure that no named effect explains.

The score tests of :mod:`gyrojax.inference.diagnose` can only name effects the library holds. Here the whitened
residual is tested against **shapes in every input the records carry**, whatever the library says:

* each moving table angle θ: harmonics cos kθ, sin kθ, k = 1 … :data:`HARMONICS` (2 df each);
* each specific-force input a_I, a_O, a_S (TDF: a_X, a_Y, a_Z; accelerometer: a_I, a_P, a_O): powers 1 … 4;
* the input-axis rate ω_I (TDF: ω_X, ω_Y) and the rate of each turning table axis: ω, |ω|, ω², ω³, sign ω;
* time (campaign clock): linear, quadratic, cubic; temperature (when recorded and varying): the same;
* the position index: one offset per (record, position) — an omnibus for anything that depends on where the
  table stands.

For a shape with regressors X (whitened with the noise model W of the fit, as the named tests whiten theirs),

    X⊥ = X − P X,    S = r̃ᵀ X⊥(X⊥ᵀX⊥)⁺X⊥ᵀ r̃ / σ̃²  ~  χ²(rank X⊥)  when the residual holds no such structure,

where P projects on the model's regressors **and every named candidate's** (so what is left is structure that no
named effect explains; a shape they span is not tested) and σ̃² is the residual variance after all of them and all
shapes (a deterministic signal cannot inflate it). p-values join those of the named candidates in one Holm
step-down family (:func:`gyrojax.inference.scoring.holm_log10`), so the family-wise error of the whole diagnosis
stays at α.

The same whitened system answers which candidates are **statistically indistinguishable** (:func:`near_aliases`):
two candidates c, d whose joint fit is not significantly better than either alone (each one's conditional score
test given the other below its χ² critical value at α) explain the data within the test's critical difference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.inference.drift_rows import rows_of, servo_state
from gyrojax.inference.scoring import collinear, score
from gyrojax.inference.solver import stack_whitened
from gyrojax.inference.subspace import UNSEEN, WhitenedSystem, basis, perp
from gyrojax.inference.verdict import POWERS, Structure
from gyrojax.physics import effects as fx
from gyrojax.physics.kept_model import over_rows
from gyrojax.physics.model import instrument_inputs
from gyrojax.runtime.kept import Kept
from gyrojax.tails import chi2_isf

HARMONICS = 6
"""Highest harmonic of a table angle tested (cycles per revolution)."""
SAME = 0.9
"""Canonical correlation above which two unexplained shapes are the same structure seen through two inputs."""
MIN_RATE_DEG_PER_H = 1.0
"""A rate input is tested only when it varies by more than this (deg/h): a still table has nothing to show."""

_ACCEL_INPUTS = {fx.TDF: ("a_X", "a_Y", "a_Z"), fx.ACCEL: ("a_I", "a_P", "a_O")}
_RATE_INPUTS = {fx.TDF: ("w_X", "w_Y"), fx.ACCEL: ()}


# ---- the shapes -------------------------------------------------------------------------------------------------


def _harmonic(p: dict, axis: str, k: int) -> np.ndarray:
    th = p["angle"].get(axis, np.zeros_like(p["ones"]))
    return np.column_stack([np.cos(k * th), np.sin(k * th)])


@partial(Kept, "inputs_without_setup")  # kept across processes (gyrojax.runtime.kept)
@jax.jit
def _inputs_without_setup(d):
    return instrument_inputs(d, {"delta": jnp.zeros(3), "encoder": jnp.zeros(4)})


def inputs_without_setup(d) -> dict:
    """:func:`gyrojax.physics.model.instrument_inputs` of a rebalance record with no set-up error, per sample (one
    compiled function, not a few hundred dispatched operations per record; one executable per chunk size, whatever
    the length, :func:`gyrojax.physics.kept_model.over_rows`)."""
    return over_rows(_inputs_without_setup, d)


def shapes(campaign, result=None) -> list[tuple]:
    """Every shape the records can show: ``(versus, shape, expression, unit, blocks)`` with ``blocks[i]`` the
    regressors (measurement rows of record i kept by its labels, q columns) in raw input units.

    Each shape is a drift term (output unit per unit of the shape): on a rebalance record it is the regressor
    itself; on a servo record, the interval mean of its effect on the table rate
    (:func:`gyrojax.inference.drift_rows.servo_state`), with the inputs at the table rate the fitted model ``result``
    predicts (none from the recorded rate)."""
    kind = campaign.kind
    out_unit = "g" if kind == fx.ACCEL else "deg/h"
    per_rec = []
    for rec, d, lab in zip(campaign.records, campaign.data, campaign.labels):
        ok = lab >= 0
        n = rec.n
        if d.mode == "servo":
            x, gain, tr = servo_state(d, result)
            rate = {a: tr[:, i] for i, a in enumerate(rec.axis_names)}
        else:
            x = inputs_without_setup(d)
            gain = None
            rate = {a: rec.rates_dps[:, i] * 3600.0 for i, a in enumerate(rec.axis_names)}
        rows = rows_of(d, ok, gain)
        v = {k: np.asarray(x[k])[:n] for k in x if not k.startswith("channel_is")}
        ang = {a: np.deg2rad(rec.angles_deg[:, i]) for i, a in enumerate(rec.axis_names)}
        temp = None if rec.temperature_C is None else np.asarray(rec.temperature_C, dtype=float)
        seg_samples = rec.segment_id.astype(float)
        if d.mode == "servo":
            seg = (0.5 * (seg_samples[1:] + seg_samples[:-1]))[ok].round().astype(int)
        elif d.kind == fx.TDF:
            seg = np.concatenate([seg_samples, seg_samples])[ok].round().astype(int)
        else:
            seg = seg_samples[ok].round().astype(int)
        p = {"x": v, "angle": ang, "rate": rate, "temp": temp, "seg": seg, "rows": rows, "m": len(seg)}
        per_rec.append({**p, "ones": np.ones(n)})

    def stacked(get):
        return np.concatenate([np.asarray(get(p), dtype=float) for p in per_rec]) if per_rec else np.zeros(0)

    def blocks(fn):  # per-sample values of a drift shape -> its regressors in each record's measurement rows
        return [p["rows"](np.asarray(fn(p), dtype=float)).reshape(p["m"], -1) for p in per_rec]

    out = []

    def add(versus, shape, expr, unit, fn):  # one shape: its regressors in every record's rows
        out.append((versus, shape, expr, unit, blocks(fn)))

    def per(unit, k):  # the unit of a k-th power's coefficient
        return unit + (f"^{k}" if k > 1 else "")

    # table angles: harmonics
    axes = sorted({a for p in per_rec for a in p["angle"]})
    for a in axes:
        allv = np.concatenate([p["angle"].get(a, np.zeros(0)) for p in per_rec])
        if allv.size and np.ptp(allv) >= np.deg2rad(1.0):
            for k in range(1, HARMONICS + 1):
                add(f"table angle {a}", f"{k}θ harmonic", None, None, lambda p, k=k, a=a: _harmonic(p, a, k))
    # specific force: powers
    for key in _ACCEL_INPUTS.get(kind, ("a_I", "a_O", "a_S")):
        allv = stacked(lambda p, key=key: p["x"][key])
        if allv.size and np.ptp(allv) >= 1e-3:
            for k, name in POWERS.items():
                ex = key if k == 1 else f"{key}**{k}"
                add(key, name, ex, per(f"{out_unit}/g", k), lambda p, key=key, k=k: p["x"][key] ** k)
    # rates: the instrument's input-axis rate, and each turning table axis
    rate_shapes = (
        ("linear", lambda w: w, "{}", f"{out_unit} per deg/h"),
        ("|ω|", np.abs, "abs({})", f"{out_unit} per deg/h"),
        ("quadratic", lambda w: w * w, "{}**2", f"{out_unit} per (deg/h)^2"),
        ("cubic", lambda w: w**3, "{}**3", f"{out_unit} per (deg/h)^3"),
        ("sign", np.sign, "sign({})", out_unit),
    )
    for key in _RATE_INPUTS.get(kind, ("w_I",)):
        allv = stacked(lambda p, key=key: p["x"][key])
        if allv.size and np.ptp(allv) >= MIN_RATE_DEG_PER_H:
            for name, f, ex, unit in rate_shapes:
                add(key, name, ex.format(key), unit, lambda p, key=key, f=f: f(p["x"][key]))
    for a in axes:
        allv = np.concatenate([p["rate"].get(a, np.zeros(0)) for p in per_rec])
        if allv.size and np.ptp(allv) >= MIN_RATE_DEG_PER_H:
            scale = float(np.max(np.abs(allv))) or 1.0
            for name, f, _, _ in rate_shapes:
                fn = lambda p, a=a, f=f, s=scale: f(p["rate"].get(a, np.zeros_like(p["ones"])) / s)  # noqa: E731
                add(f"table rate {a}", name, None, None, fn)
    # time on the campaign clock
    t_all = stacked(lambda p: p["x"]["t_h"])
    if t_all.size and np.ptp(t_all) > 0:
        mid = round(0.5 * (t_all.max() + t_all.min()), 3)
        for k in (1, 2, 3):
            ex = "t_h" if k == 1 else f"(t_h-{mid:g})**{k}"
            add("time", POWERS[k], ex, per(f"{out_unit}/h", k), lambda p, k=k: (p["x"]["t_h"] - mid) ** k)
    # temperature
    if all(p["temp"] is not None for p in per_rec):
        tc = stacked(lambda p: p["temp"])
        if tc.size and np.ptp(tc) > 1e-6:
            for k in (1, 2, 3):
                ex = "(temperature_C-20)" + (f"**{k}" if k > 1 else "")
                add("temperature_C", POWERS[k], ex, per(f"{out_unit}/°C", k), lambda p, k=k: (p["temp"] - 20.0) ** k)
    # position index: one offset per (record, position)
    keys = sorted({(i, s) for i, p in enumerate(per_rec) for s in np.unique(p["seg"])})
    if len(keys) > 1:
        col = {k: j for j, k in enumerate(keys)}
        bl = []
        for i, p in enumerate(per_rec):
            m = np.zeros((len(p["seg"]), len(keys)))
            for s in np.unique(p["seg"]):
                m[p["seg"] == s, col[(i, s)]] = 1.0
            bl.append(m)
        multi = any(len(np.unique(p["seg"])) > 1 for p in per_rec)
        out.append(("position", "offset per position" if multi else "offset per record", None, None, bl))
    return out


def whitened_system(lin, noises, blocks_per_shape, p0: int) -> WhitenedSystem:
    """The records' residual, regressors and shape blocks (``blocks_per_shape[k][i]``: shape k's regressors in record
    i's rows) whitened together by each record's noise model (:func:`gyrojax.inference.solver.stack_whitened`) and
    held as a :class:`~gyrojax.inference.subspace.WhitenedSystem`."""
    widths = [b[0].shape[1] for b in blocks_per_shape]
    p = lin[0].jacobian.shape[1] if lin else 0
    aug = [
        rec._replace(jacobian=np.column_stack([rec.jacobian] + [b[i] for b in blocks_per_shape]))
        for i, rec in enumerate(lin)
    ]
    rw, jall = stack_whitened(aug, noises)
    edges = p + np.cumsum([0] + widths)
    cols = [np.arange(a, b) - p for a, b in zip(edges[:-1], edges[1:])]
    return WhitenedSystem.of(rw, jall[:, :p], jall[:, p:], cols, p0)


@dataclass
class ShapeSystem:
    """The shapes of :func:`shapes` and the system whitened with them, the model's basis and residual beside it: what
    every call of :func:`residual_structure` on one fit shares (the diagnosis' vetting rounds differ only in the
    candidate columns)."""

    lib: list
    ws: WhitenedSystem
    u0: np.ndarray
    r0: np.ndarray

    @classmethod
    def build(cls, campaign, lin, noises, p0: int, result=None) -> "ShapeSystem":
        """As the arguments of :func:`residual_structure`."""
        lib = shapes(campaign, result)
        ws = whitened_system(lin, noises, [s[4] for s in lib], p0)
        u0 = basis(ws.j[:, :p0])
        return cls(lib, ws, u0, perp(u0, ws.r))


def residual_structure(
    campaign, lin, noises, p0: int, candidate_cols=None, result=None, system: ShapeSystem | None = None
) -> list[Structure]:
    """Test the whitened residual against every shape of :func:`shapes` (module doc); p-values not yet adjusted.

    Args:
      campaign: the :class:`gyrojax.inference.campaign.Campaign` of the records.
      lin: per record (r, J, labels, times) as :func:`gyrojax.inference.campaign.linearize` gives them for the model
        extended by the candidates, at the fitted θ (residual in the output unit, deg/h or g).
      noises: one noise model per record (the fit's), used to whiten residual, regressors and shapes alike.
      p0: number of the model's own columns in J (the rest are the named candidates').
      candidate_cols: columns of J to project out besides the model's (default: all of them).
      result: the fit (:class:`gyrojax.inference.identify.FitResult`) whose predicted table rate gives a servo
        record's inputs (:func:`shapes`); without it, the rate of a drift-free instrument.
      system: the :class:`ShapeSystem` of these arguments, if already built (one per fit).

    Returns: one :class:`Structure` per shape that the model and the candidates do not span, strongest first.
    """
    sy = system or ShapeSystem.build(campaign, lin, noises, p0, result)
    if not sy.lib:
        return []
    lib, ws, u0, r0 = sy.lib, sy.ws, sy.u0, sy.r0
    cols = np.arange(ws.j.shape[1]) if candidate_cols is None else np.union1d(np.arange(p0), candidate_cols)
    u_named = basis(ws.j[:, cols.astype(int)])
    # σ̃²: after the model, the named candidates and every shape (no deterministic structure can inflate it)
    u_all = basis(np.column_stack([ws.j[:, cols.astype(int)], ws.x]))
    n = ws.n
    dof = n - u_all.shape[1]
    if dof >= max(10, n // 10):
        e = perp(u_all, ws.r)
    else:
        e, dof = perp(u_named, ws.r), max(n - u_named.shape[1], 1)
    sigma2 = float(e @ e) / dof
    if not sigma2 > 0:
        return []
    out, perps = [], []
    for (versus, shape, expr, unit, _), c in zip(lib, ws.shape_cols):
        x = ws.x[:, c]
        if float(np.sqrt((x * x).sum())) == 0.0:
            continue
        sc = score(u_named, r0, x, sigma2, tol=UNSEEN)  # σ̃² from beyond every shape: the χ² law
        if sc is None:
            continue
        fitted = {}
        if expr is not None and x.shape[1] == 1:
            x0 = perp(u0, x[:, 0])
            nn = float(x0 @ x0)
            if nn > 0:
                fitted = {"estimate": float(x0 @ r0) / nn, "std": math.sqrt(sigma2 / nn), "unit": unit}
        name = f"{versus}: {shape}"
        out.append(
            Structure(name, versus, shape, sc.statistic, sc.df, sc.p_value, sc.log10_p, expression=expr, **fitted)
        )
        perps.append(sc.basis)
    order = np.argsort([s.log10_p for s in out], kind="stable")
    out = [out[i] for i in order]
    perps = [perps[i] for i in order]
    same: list = [[] for _ in out]
    for i, a in enumerate(out):
        for j in range(i):
            if collinear(perps[i], perps[j], SAME):
                same[i].append(out[j].versus)
                same[j].append(a.versus)
    return [replace(s, same_as=list(dict.fromkeys(v for v in sm if v != s.versus))) for s, sm in zip(out, same)]


# ---- near-aliases -----------------------------------------------------------------------------------------------


def near_aliases(lin, noises, p0: int, slices: dict, names, alpha: float, system=None) -> dict:
    """Candidates each of ``names`` cannot be told from at level ``alpha`` (module doc): name -> [other names].

    ``slices``: candidate name -> slice of J's columns; J's first ``p0`` columns are the model's. Two candidates
    are indistinguishable when each one's conditional score statistic given the other, S(c | d) = S(c ∪ d) − S(d),
    is below the χ²(rank added) critical value at ``alpha`` — so both best fits leave likelihoods within that
    critical difference of the joint one. Exact aliases (nothing added either way) are left to ``aliases``.
    ``system``: the :class:`WhitenedSystem` of ``lin`` whitened by ``noises``, if already built (the diagnosis'
    score tests build it).
    """
    ws = system or whitened_system(lin, noises, [], p0)
    u0 = basis(ws.j[:, :p0])
    r0 = perp(u0, ws.r)
    sigma2 = float(r0 @ r0) / max(ws.n - u0.shape[1], 1)
    if not sigma2 > 0:
        return {}
    perps = {}
    for c, sl in slices.items():
        xp = perp(u0, ws.j[:, sl])
        if xp.size and float(np.abs(xp).max()) > 0:
            uc = basis(xp)
            if uc.shape[1]:
                perps[c] = uc

    def statistic(u):
        pr = u.T @ r0
        return float(pr @ pr) / sigma2

    single = {c: statistic(u) for c, u in perps.items()}
    out = {}
    for c in names:
        if c not in perps or single[c] < chi2_isf(alpha, perps[c].shape[1]):
            continue  # (a slow candidate judged by its likelihood ratio, not by this score)
        found = []
        for d, ud in perps.items():
            if d == c:
                continue
            uj = basis(np.column_stack([perps[c], ud]))
            s_joint = statistic(uj)
            add_c, add_d = uj.shape[1] - ud.shape[1], uj.shape[1] - perps[c].shape[1]
            if add_c == 0 and add_d == 0:
                continue  # an exact alias
            ok = True
            for added, s_cond in ((add_c, s_joint - single[d]), (add_d, s_joint - single[c])):
                if added and s_cond >= chi2_isf(alpha, added):
                    ok = False
            if ok:
                found.append(d)
        out[c] = found
    return out
