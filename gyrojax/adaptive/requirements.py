"""What stands between the data and the goal, as σ ratios of sub-models of one Fisher information.

Each requirement asks that one coefficient be known to its target σ in one sub-model K of the universe U
(:mod:`gyrojax.adaptive.information`):

=============  ==============================================================================================
``sigma``      a coefficient of the current model M, read in M (the fit the campaign will state)
``detect``     a watched candidate c outside M, read in M ∪ {c}: were c added, its σ would be σ_c, so the score
               test at level α detects it with power P once |c| ≥ √λ*·σ_c (:mod:`gyrojax.adaptive.goal`); its
               target is the size that matters (by default the plausible size) over √λ*
``separate``   the watched (or explicitly targeted) members of an alias group G that the diagnosis found
               significant but cannot name (the records cannot tell them apart), read in M ∪ G: known to S in one
               fit with the whole group tells which it is; the other members (a test-set effect, D_OO) are in the
               sub-model but carry no target of their own
=============  ==============================================================================================

The ratio of a requirement is q = σ²/(m·S)² with σ² = [F_K⁻¹]_ii and m the design margin; a requirement is met
at q ≤ 1 (the goal check takes m = 1). σ² in a sub-model is read from the full matrix through a mask: F_K =
D(F ∘ kkᵀ + diag(1 − k))D in coordinates normalised by D = diag(F)^{-½}, so every shape is fixed and the
search compiles once for a campaign. A coefficient the information does not reach (F_ii = 0, or a null
direction of F_K) has σ = ∞.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model

NULL_RTOL = 1e-10
"""Eigenvalue of a normalised sub-model information, relative to its largest, below which a direction is unseen."""


@dataclass(frozen=True)
class Requirement:
    """One coefficient to know to ``target`` (its report unit) in the sub-model ``effects`` (module doc)."""

    kind: str  # "sigma", "detect" or "separate"
    coefficient: str
    effects: tuple
    target: float
    unit: str
    against: tuple = ()  # ``separate``: the other members of the alias group

    @property
    def effect(self) -> str:
        """The effect that carries :attr:`coefficient`."""
        return fx.effect_of_coefficient(self.coefficient)

    def to_json(self) -> dict:
        """JSON: kind, coefficient, sub-model, target σ and unit."""
        return {
            "kind": self.kind,
            "coefficient": self.coefficient,
            "sub_model": list(self.effects),
            "target": self.target,
            "unit": self.unit,
        }


def build(terms, goal, kind: str, alpha: float, alias_group=()) -> list[Requirement]:
    """The requirements of ``goal`` for the model ``terms``: σ of its coefficients, detection of the watched
    candidates at the size that matters at level ``alpha`` (:meth:`gyrojax.adaptive.goal.Goal.detect_sigma`), and
    separation of ``alias_group`` (effect names, none in ``terms``)."""
    terms = tuple(terms)
    out = []
    model = Model(terms, kind)
    for c, u in zip(model.coefficient_names, model.coefficient_units):
        s = goal.target(c)
        if s is not None:
            out.append(Requirement("sigma", c, terms, s, u))
    group = tuple(g for g in alias_group if g not in terms)
    for e in goal.watched(kind):
        if e in terms or e in group:
            continue
        eff = fx.get(e)
        for c, u in zip(eff.coefficients, eff.units):
            s = goal.detect_sigma(c, alpha, kind)
            if s is not None:
                out.append(Requirement("detect", c, terms + (e,), s, u))
    watched = set(goal.watched(kind))
    for e in group:
        eff = fx.get(e)
        for c, u in zip(eff.coefficients, eff.units):
            s = goal.target(c)
            if s is not None and (e in watched or c in goal.targets):
                out.append(Requirement("separate", c, terms + group, s, u, tuple(g for g in group if g != e)))
    return out


def universe(terms, goal, kind: str, alias_group=()) -> Model:
    """The model every requirement reads from: ``terms``, then the alias group, then the watched candidates."""
    names = list(terms)
    for e in tuple(alias_group) + goal.watched(kind):
        if e not in names:
            names.append(e)
    return Model(tuple(names), kind)


def arrays(reqs, uni: Model):
    """(masks (R, p) 0/1, index (R,) int, target (R,)) of ``reqs`` over the universe's coefficients."""
    names = uni.coefficient_names
    sl = uni.slices()
    masks = np.zeros((len(reqs), uni.size))
    for i, r in enumerate(reqs):
        for e in r.effects:
            masks[i, sl[e]] = 1.0
    index = np.array([names.index(r.coefficient) for r in reqs], dtype=int)
    target = np.array([r.target for r in reqs], dtype=float)
    return masks, index, target


def variances(f, masks, index):
    """σ² (R,) of coefficient ``index[r]`` in the sub-model ``masks[r]`` of the information ``f`` (module doc);
    traceable (a search differentiates through it). Unseen directions give a very large σ² (∞ to the goal)."""
    f = jnp.asarray(f)
    d = jnp.sqrt(jnp.maximum(jnp.diag(f), 0.0))
    scale = jnp.where(d > 0, 1.0 / jnp.maximum(d, 1e-300), 0.0)
    fn = f * jnp.outer(scale, scale)
    p = f.shape[0]

    def one(m, i):
        fk = fn * jnp.outer(m, m) + jnp.diag(1.0 - m) + 1e-12 * jnp.eye(p)
        e = jnp.zeros(p).at[i].set(1.0)
        v = jnp.linalg.solve(fk, e)[i]
        return jnp.where(d[i] > 0, v * scale[i] ** 2, jnp.inf)

    return jax.vmap(one)(jnp.asarray(masks), jnp.asarray(index))


def sigmas(f, reqs, uni: Model) -> np.ndarray:
    """σ of every requirement's coefficient in its sub-model of ``f`` (report units; ∞ where unseen), exactly: a
    sub-model whose normalised information has a null direction through the coefficient gives ∞."""
    f = np.asarray(f, dtype=float)
    masks, index, _ = arrays(reqs, uni)
    out = np.empty(len(reqs))
    for r, (m, i) in enumerate(zip(masks, index)):
        k = np.flatnonzero(m)
        sub = f[np.ix_(k, k)]
        d = np.sqrt(np.maximum(np.diag(sub), 0.0))
        j = int(np.flatnonzero(k == i)[0])
        if d[j] == 0:
            out[r] = math.inf
            continue
        seen = d > 0
        sn = sub[np.ix_(seen, seen)] / np.outer(d[seen], d[seen])
        jj = int(np.flatnonzero(np.flatnonzero(seen) == j)[0])
        ev, vec = np.linalg.eigh(sn)
        null = ev < NULL_RTOL * max(ev[-1], 1e-300)
        if null.any() and np.abs(vec[jj, null]).max() > 1e-6:
            out[r] = math.inf
            continue
        inv = (vec[:, ~null] / ev[~null]) @ vec[:, ~null].T
        out[r] = math.sqrt(max(inv[jj, jj], 0.0)) / d[j]
    return out


def describe(req: Requirement, sigma: float, alpha: float, goal) -> str:
    """One line on a requirement at ``sigma`` (its report unit) and level ``alpha``: what it asks and where it
    stands."""
    now = "∞ (not seen by the records)" if not math.isfinite(sigma) else f"{sigma:.3g}"
    if req.kind == "sigma":
        return f"σ of {req.coefficient} is {now} {req.unit}, target {req.target:g}"
    if req.kind == "detect":
        size = goal.detect_size(req.coefficient)
        return (
            f"{req.effect} could hide at |{req.coefficient}| up to {size:.3g} {req.unit}: σ were it added {now}, "
            f"{req.target:.3g} detects that size with power {goal.power:g} at α = {alpha:.2g}"
        )
    return (
        f"{req.effect} is aliased with {', '.join(req.against)} in the records (the diagnosis finds the group "
        f"significant but cannot tell its members apart): σ in one fit with them {now} {req.unit}, target "
        f"{req.target:g}"
    )
