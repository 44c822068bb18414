"""The next test by gradients: static positions on the lab's table that meet the requirements in the fewest hours.

**What is designed.** A test of one or more *runs* (at most ``lab.mountings_per_test``), each at one mounting of the
instrument (one of the case turns the lab allows, :meth:`gyrojax.adaptive.lab.Lab.mountings`) with N positions of
the lab's gimbal chain (free axes in rad, limited axes as low + (high − low)·sigmoid(u)); the dwell fractions of all
positions p = m + (1 − M m)·softmax(z) (M positions in all, m = 0.25/M) share a total dwell H. On a single-axis
table one mounting cannot see every term: with an instrument axis along the table axis its a is constant, so its
squared term aliases D_F and its products alias the first-order terms (a_I² + a_S² = const for OA along the axis);
a test may need two or three mountings. Adam (optax) runs one-run designs from ``starts`` random angle sets at every
mounting at once (one ``vmap``); then, run by run, designs with one run more whose earlier runs start from the
previous best and whose new run tries every mounting. Each configuration compiles once per universe and position
count.

**Loss.** With F = F_rec + E_θ[F_new(θ)], the requirements' ratios q_j = σ_j²/(m·S_j)²
(:mod:`gyrojax.adaptive.requirements`) and the loss τ·log Σ_j exp(log q_j / τ), a smooth maximum whose temperature
τ falls over the iterations (:data:`TEMPERATURES`): the design lowers the worst ratio, whichever kind of requirement
it is. E_θ is the mean over posterior draws of θ (the current fit's estimate and covariance) when the universe has
nonlinear effects (set-up terms), so the design is for what the data say, not for one point estimate; for linear
effects F_new does not depend on θ and one draw is exact. Each position mean's variance is that of the fitted noise
over its dwell T, 3600N²/T + Σ σ²·f(T/τ) over the Gauss–Markov terms (f of :func:`gyrojax.noise.meancov.
gm_mean_factor`); the covariance between positions is left out of the search (the prediction after the design,
:func:`gyrojax.adaptive.information.test_information`, holds it).

**Hours.** For each design, the shortest total dwell H* at which every ratio is at most 1 (bisection on the design
scaled in time: every ratio falls as H grows), at least :attr:`gyrojax.adaptive.lab.Lab.min_dwell_s` a position
on average and at most the hours the lab allows one test; the design of fewest
table hours (dwell, settling, remounting) is re-designed at its H* and kept. When no design meets every ratio
within the cap, the one with the smallest worst ratio is kept: the test makes the most progress the hours allow;
or, given stricter requirements to shape such a test for (``shape`` of :func:`design_test`), the one the same search
makes for them, its hours still those of the requirements.
:attr:`TestDesign.hours_needed` is the dwell a test of the kept shape would need to meet every requirement (up to
:data:`MAX_HOURS`; None beyond): what the campaign's budget is checked against.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.adaptive.information import rows
from gyrojax.adaptive.requirements import variances
from gyrojax.errors import ModelError
from gyrojax.noise.meancov import gm_mean_factor
from gyrojax.physics.kept_model import kept_jit
from gyrojax.planning import search
from gyrojax.planning.fisher import Table
from gyrojax.planning.optimal import dwell_from_logits

TEMPERATURES = (1.0, 0.05)
"""The smooth maximum's temperature τ falls geometrically from the first to the second over the first four fifths of
the iterations and stays there (the search's convergence is judged on its last ones): early on
every requirement pulls (a soft mean of the log ratios), at the end the worst does; a fixed sharp maximum leaves
positions collapsed on a few angles where a requirement that is not yet the worst has no gradient."""
MAX_HOURS = 1000.0
"""The longest dwell (h) the hours search considers when it estimates what the goal needs."""
STARTS, STEPS, LEARNING_RATE = 3, 300, 0.05


@dataclass
class TestDesign:
    """A designed test, run by run, and what it does to the requirements (ratios q ≤ 1 met)."""

    mountings: list  # index into the lab's mountings, per run (0: the records' mounting)
    triads: np.ndarray  # (runs, 3, 3) instrument axes as rows, platform coordinates
    angles_deg: np.ndarray  # (runs, n, k)
    dwell_s: np.ndarray  # (runs, n)
    ratio_after: np.ndarray  # (R,) q after the test (design margin included)
    hours_needed: float | None  # dwell (h) a test of this shape needs for every q ≤ 1; None beyond MAX_HOURS
    ratio_at_budget: float  # the largest q a test of this shape reaches with the whole budget's dwell
    history: np.ndarray = field(default=None, repr=False)

    @property
    def dwell_hours(self) -> float:
        """Total dwell of the test, h."""
        return float(np.sum(self.dwell_s)) / 3600.0

    @property
    def convergence_note(self) -> str:
        """Why the search is not taken as converged ("" when it is; :mod:`gyrojax.planning.search`)."""
        h = np.asarray(self.history)
        return search.convergence_note(h, float(h[-1]) if h.size else math.nan, "raise steps")


GM_TERMS = 2
"""Gauss–Markov terms of the noise a search takes (fixed, so that one compiled search serves every noise)."""


class _Problem:
    """The compiled search and ratio function of one configuration: ``runs`` mountings of ``n`` positions each, kept
    across processes for a universe of built-in effects (:func:`gyrojax.physics.kept_model.kept_jit`)."""

    def __init__(self, uni, runs: int, n: int, limits: tuple, steps: int, learning_rate: float):
        m_frac = 0.25 / (runs * n)

        def angles(u):  # (runs, n, k) unconstrained -> rad
            cols = []
            for i, lim in enumerate(limits):
                if lim is None:
                    cols.append(u[..., i])
                else:
                    lo, hi = math.radians(lim[0]), math.radians(lim[1])
                    cols.append(lo + (hi - lo) * jax.nn.sigmoid(u[..., i]))
            return jnp.stack(cols, axis=-1)

        def information(template, triads, ang, dwell, a):
            table = Table.of_template(template)
            flat = dwell.reshape(-1)
            times = a["start"] + jnp.cumsum(flat + a["gap"]) - a["gap"] - 0.5 * flat
            times = times.reshape(runs, n) + a["remount"] * jnp.arange(runs)[:, None]

            # variance of each position mean: white over its dwell and every Gauss–Markov term (module doc)
            var = a["white_var"] / dwell + jnp.sum(
                a["gm_var"] * gm_mean_factor(dwell[..., None] / a["gm_tau"]), axis=-1
            )

            def at(theta):
                f = 0.0
                for j in range(runs):
                    h = rows(uni, table, triads[j], ang[j], times[j], theta)
                    f = f + jnp.einsum("cnp,n,cnq->pq", h, 1.0 / var[j], h)
                return f

            return jnp.mean(jax.vmap(at)(a["thetas"]), axis=0)

        def ratios(template, triads, ang, dwell, a):
            v = variances(a["f_rec"] + information(template, triads, ang, dwell, a), a["masks"], a["index"])
            return jnp.minimum(v / a["target"] ** 2, 1e30)

        def loss(params, tau, triads, template, total, a):
            u, z = params
            dwell = dwell_from_logits(z, total, m_frac).reshape(runs, n)
            q = ratios(template, triads, angles(u), dwell, a)
            return tau * jax.nn.logsumexp(jnp.log(q) / tau, b=a["weight"])

        vg = jax.value_and_grad(loss)
        fall = max(1, int(0.8 * steps))  # τ settles for the last fifth, where convergence is judged
        taus = jnp.concatenate(
            [jnp.geomspace(TEMPERATURES[0], TEMPERATURES[1], fall), jnp.full(steps - fall, TEMPERATURES[1])]
        )

        def run(p0, triads, template, total, a):
            p, hist = search.adam_scan(vg, p0, steps, learning_rate, triads, template, total, a, schedule=taus)
            return p, hist, loss(p, taus[-1], triads, template, total, a)

        statics = (runs, n, limits, steps, learning_rate)
        self.search = kept_jit("design_search", uni, jax.vmap(run, in_axes=(0, 0, None, None, None)), *statics)
        self.ratios = kept_jit("design_ratios", uni, ratios, *statics)
        self.angles = kept_jit("design_angles", uni, angles, *statics)
        self.fractions = kept_jit(
            "design_fractions", uni, lambda z: dwell_from_logits(z, 1.0, m_frac).reshape(runs, n), *statics
        )


@lru_cache(maxsize=8)
def _problem(uni, runs, n, limits, steps, learning_rate) -> _Problem:
    """The compiled search of one problem shape (the most recent ones are kept)."""
    return _Problem(uni, runs, n, limits, steps, learning_rate)


def _arrays(reqs_arrays, f_rec, lab, noise, start_s, margin, thetas, rows: int = 0) -> dict:
    masks, index, target = reqs_arrays
    r, p = masks.shape
    m = max(r, rows)
    rp = max(8, -(-m // 8) * 8)  # requirement rows padded to a multiple of 8 (fewer shapes to compile)
    k = len(lab.axes)
    gm = np.array(list(noise.gauss_markov)[:GM_TERMS] + [(0.0, 1.0)] * GM_TERMS)[:GM_TERMS]
    if len(noise.gauss_markov) > GM_TERMS:
        raise ModelError(
            f"the design search takes at most {GM_TERMS} Gauss–Markov terms; the noise has {len(noise.gauss_markov)}"
        )
    return {
        "f_rec": jnp.asarray(f_rec),
        "masks": jnp.asarray(np.vstack([masks, np.zeros((rp - r, p))])),
        "index": jnp.asarray(np.concatenate([index, np.zeros(rp - r, int)])),
        "target": jnp.asarray(np.concatenate([np.asarray(target) * margin, np.ones(rp - r)])),
        "weight": jnp.asarray(np.concatenate([np.ones(r), np.zeros(rp - r)])),
        "white_var": jnp.asarray(3600.0 * noise.white**2),
        "gm_var": jnp.asarray(gm[:, 0] ** 2),
        "gm_tau": jnp.asarray(gm[:, 1]),
        "thetas": jnp.zeros((1, p)) if thetas is None else jnp.atleast_2d(jnp.asarray(thetas)),
        "start": jnp.asarray(float(start_s)),
        "gap": jnp.asarray(float(lab.gap_s([[0.0] * k, [180.0] * k]))),
        "remount": jnp.asarray(float(lab.remount_s)),
    }


def design_test(
    uni,
    reqs_arrays,
    f_rec: np.ndarray,
    lab,
    noise,
    hours: float,
    start_s: float,
    margin: float,
    thetas=None,
    budget_hours: float | None = None,
    starts: int = STARTS,
    steps: int = STEPS,
    seed: int = 0,
    learning_rate: float = LEARNING_RATE,
    shape=None,
) -> TestDesign:
    """Design the next test (module doc) of at most ``hours`` dwell on ``lab``'s table.

    ``reqs_arrays`` = (masks, index, target) of :func:`gyrojax.adaptive.requirements.arrays`; ``f_rec`` the records'
    information on ``uni``; ``noise`` the noise of the new test (a :class:`~gyrojax.noise.spec.NoiseSpec`);
    ``start_s`` its start on the campaign clock (s); ``margin`` the design margin m; ``thetas`` (D, p) posterior
    draws (default θ = 0, exact for linear effects); ``budget_hours`` the dwell the campaign has left (default
    ``hours``), at which :attr:`TestDesign.ratio_at_budget` is read.

    ``shape``: arrays of requirements at least as strict as ``reqs_arrays`` (every test that meets them meets
    ``reqs_arrays``) for which a test that cannot meet ``reqs_arrays`` within ``hours`` is shaped instead: the same
    search from the same random starts, its largest ratio lowered at ``hours``; :attr:`TestDesign.hours_needed`,
    :attr:`TestDesign.ratio_at_budget` and :attr:`TestDesign.ratio_after` stay those of ``reqs_arrays``. Both sets
    are padded to one row count, so one compiled search serves them."""
    r = reqs_arrays[0].shape[0]
    rows = max(r, shape[0].shape[0] if shape is not None else 0)
    a = _arrays(reqs_arrays, f_rec, lab, noise, start_s, margin, thetas, rows)
    limits, n, k = lab.limited(), lab.positions, len(lab.axes)
    template = lab.table().template
    mounts = np.asarray(lab.mountings())
    n_m = mounts.shape[0]
    rng = np.random.default_rng(seed)

    def random_u(count, runs):
        u = np.empty((count, runs, n, k))
        for i, lim in enumerate(limits):
            shape = u.shape[:3]
            u[..., i] = rng.uniform(0.0, 2 * math.pi, shape) if lim is None else rng.normal(0.0, 1.5, shape)
        return u

    def batch(runs: int) -> int:
        """Lanes of every search of ``runs`` runs, so that each configuration compiles once: ``starts`` per mounting
        for one run; one per mounting for more, whose earlier runs start from the previous best and whose new run
        tries every mounting once."""
        return n_m * starts if runs == 1 else n_m

    def optimise(runs, u0, z0, mi, total_h, arrays=a):
        prob = _problem(uni, runs, n, limits, steps, learning_rate)
        k0 = len(u0)
        take = np.arange(batch(runs)) % k0  # the starts repeated and perturbed: a local multi-start, and no new shape
        u0, z0, mi = np.array(u0)[take], np.asarray(z0)[take], np.asarray(mi)[take]
        u0[k0:] += rng.normal(0.0, 0.3, u0[k0:].shape)
        tri = jnp.asarray(mounts[mi])
        (u, z), hist, vals = prob.search((jnp.asarray(u0), jnp.asarray(z0)), tri, template, total_h * 3600.0, arrays)
        vals = np.where(np.isfinite(np.asarray(vals)), np.asarray(vals), np.inf)
        b = int(np.argmin(vals))
        return {
            "runs": runs,
            "mi": [int(x) for x in np.asarray(mi)[b]],
            "ang": np.asarray(prob.angles(u[b])),
            "frac": np.asarray(prob.fractions(z[b])),
            "u": np.asarray(u[b]),
            "z": np.asarray(z[b]),
            "hist": np.asarray(hist[b]),
        }

    def worst(d, h, arrays=a, r=r):
        prob = _problem(uni, d["runs"], n, limits, steps, learning_rate)
        dwell = jnp.asarray(d["frac"] * h * 3600.0)
        q = np.asarray(prob.ratios(template, jnp.asarray(mounts[d["mi"]]), jnp.asarray(d["ang"]), dwell, arrays))
        return float(q[:r].max()) if r else 0.0

    def shortest(d, cap):
        if worst(d, cap) > 1.0:
            return None
        lo, hi = 0.0, cap
        floor = min(d["runs"] * n * lab.min_dwell_s / 3600.0, cap)
        if worst(d, floor) <= 1.0:  # met by the shortest test worth moving the table for
            return floor
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if worst(d, mid) <= 1.0 else (mid, hi)
            if hi - lo < 1e-3 * hi:
                break
        return hi

    def table_hours(d, h):
        overhead = d["runs"] * (n - 1) * float(a["gap"]) + (d["runs"] - 1) * lab.remount_s
        return h + overhead / 3600.0

    mi1 = np.repeat(np.arange(n_m), starts)[:, None]

    def designs(arrays):
        """The search's best design of every run count at ``hours``, run by run."""
        out = [optimise(1, random_u(n_m * starts, 1), np.zeros((n_m * starts, n)), mi1, hours, arrays)]
        for runs in range(2, min(lab.mountings_per_test, n_m) + 1):  # one run more, at every other mounting
            prev = out[-1]
            new = np.array([m for m in range(n_m) if m not in prev["mi"]])
            u0 = random_u(len(new), runs)
            u0[:, : runs - 1] = prev["u"]
            z0 = np.tile(np.concatenate([prev["z"], np.zeros(n)]), (len(new), 1))
            mi = np.column_stack([np.tile(prev["mi"], (len(new), 1)), new])
            out.append(optimise(runs, u0, z0, mi, hours, arrays))
        return out

    def most_progress(candidates, arrays=a, r=r):
        """The design that lowers the largest ratio most for the same table hours."""
        base = table_hours(candidates[0], 0.0)
        return min(
            candidates,
            key=lambda c: worst(c, max(hours - (table_hours(c, 0.0) - base), 0.1 * hours), arrays, r),
        )

    candidates = designs(a)
    needs = [shortest(d, hours) for d in candidates]
    longer = None
    if any(x is not None for x in needs):
        best = min(
            (i for i, x in enumerate(needs) if x is not None), key=lambda i: table_hours(candidates[i], needs[i])
        )
        d, need = candidates[best], needs[best]
        again = optimise(d["runs"], d["u"][None], d["z"][None], np.asarray(d["mi"])[None], need)
        need2 = shortest(again, hours)
        if need2 is not None and need2 < need:
            d, need = again, need2
        use, total_need = need, need
    else:  # none meets them within the hours of a test: the most progress for the same table hours
        d = most_progress(candidates)
        use = hours
        # what the goal needs: the test of most runs designed at the hours the budget leaves
        cap = max(hours, budget_hours if budget_hours is not None else hours)
        widest = candidates[-1]
        longer = optimise(widest["runs"], widest["u"][None], widest["z"][None], np.asarray(widest["mi"])[None], cap)
        total_need = shortest(longer, cap)
        if total_need is None:  # a refusal rests on it: fresh random starts too, not only the test's local optimum
            runs = widest["runs"]
            mi = mi1 if runs == 1 else np.tile(widest["mi"], (batch(runs), 1))
            fresh = optimise(runs, random_u(batch(runs), runs), np.zeros((batch(runs), runs * n)), mi, cap)
            if shortest(fresh, cap) is not None or worst(fresh, cap) < worst(longer, cap):
                longer = fresh
            total_need = shortest(longer, cap)
        if total_need is None:  # beyond the budget: how far, by a design made for the long run, then for its need
            far = optimise(
                longer["runs"], longer["u"][None], longer["z"][None], np.asarray(longer["mi"])[None], MAX_HOURS
            )
            total_need = shortest(far, MAX_HOURS)
            if total_need is not None:
                near = optimise(far["runs"], far["u"][None], far["z"][None], np.asarray(far["mi"])[None], total_need)
                total_need = min(total_need, shortest(near, MAX_HOURS) or math.inf)
    at_budget = worst(d, budget_hours if budget_hours is not None else hours)
    if longer is not None and budget_hours is not None:
        at_budget = min(at_budget, worst(longer, budget_hours))
    if shape is not None and longer is not None and (total_need is None or total_need > hours):
        # the test takes all its hours either way: shaped for ``shape``, from the starts the search above drew
        s = _arrays(shape, f_rec, lab, noise, start_s, margin, thetas, rows)
        rng = np.random.default_rng(seed)
        d = most_progress(designs(s), s, shape[0].shape[0])
    prob = _problem(uni, d["runs"], n, limits, steps, learning_rate)
    dwell = d["frac"] * use * 3600.0
    q = np.asarray(prob.ratios(template, jnp.asarray(mounts[d["mi"]]), jnp.asarray(d["ang"]), jnp.asarray(dwell), a))
    deg = np.rad2deg(d["ang"])
    free = np.array([lim is None for lim in limits])
    deg[..., free] = np.mod(deg[..., free], 360.0)
    return TestDesign(d["mi"], mounts[d["mi"]], deg, dwell, q[:r], total_need, at_budget, d["hist"])
