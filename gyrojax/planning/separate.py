"""The follow-up test that separates two effects a campaign cannot tell apart (``gyrojax design --separate A,B``).

**What is designed.** From the lab's own records (their table axes, instrument mounting, site and fitted noise)
and the current fit, a static test on that table: N positions of the records' gimbal chain, their dwells, and
the mounting of the gyro on the platform, one of the 24 turns of its case by multiples of 90° about its own
axes (the records' mounting is the identity turn; a flipped one, as in Hu's polar tumble, is another). Angles and
dwells are optimised by gradients (optax Adam, exact JAX derivatives of the measurement model), one search for
each mounting, several starts each; the best is kept.

**Criterion.** With M = base ∪ A ∪ B and F = F_records + F_new(positions, dwells, mounting) the Fisher information
of the joint fit, the score test for A with B in the model has noncentrality λ_A = δ_Aᵀ (F_AA − F_A· F_··⁻¹ F_·A) δ_A
(:func:`gyrojax.planning.criteria.noncentrality`, the other block being base ∪ B) and likewise λ_B. The design
maximises the smaller: the loss is logsumexp(−log λ_A, −log λ_B) ≈ −log min λ. δ_A is the current fit's estimate of
A (fit of base ∪ A); δ_B the estimate of B that would explain the same fitted signal (the least-squares projection of
that signal on base ∪ B). The power of each test at level α is P(χ²_q(λ) > χ²_{q,1−α}) (:func:`detect_power`). The
time it needs is the shortest total dwell H at which the smaller power reaches :data:`TARGET_POWER`, by bisection of
the designed plan scaled in time, then of the plan re-designed at that H.

**Refusal.** If the regressors of base ∪ A ∪ B are collinear at every orientation the table reaches (the records'
own, and random angles of the chain at each of the 24 mountings), no test on that table separates A and B:
:func:`reachable_null` finds the null combination of the normalised information of every reachable orientation.
Example: a base tilt about North and an azimuth error both turn Earth's rate into the table East axis (Ω × δ is
East for δ along North or Up), so δ_N sin φ + δ_U cos φ … is invisible; only levelling or surveying the base
separates them. Regressors are taken at θ = 0 (the drift terms are linear; set-up angles to first order).

The new test's samples follow the static-position information of :mod:`gyrojax.planning.fisher` (white +
Gauss–Markov noise of a position mean); the records' information is Jᵀ J / σ² with σ² the fitted white variance.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.data import plans
from gyrojax.errors import ConvergenceWarning, ModelError
from gyrojax.inference.separation import case_turns
from gyrojax.noise.spec import NoiseSpec
from gyrojax.optimize import bisect
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model, jacobian
from gyrojax.planning import search
from gyrojax.planning.criteria import detect_power, noncentrality
from gyrojax.planning.fisher import TIME_EFFECTS, Table, measurement_dt
from gyrojax.planning.optimal import dwell_from_logits

TARGET_POWER = 0.9
ALPHA = 0.01  # level of the score tests
NULL_RTOL = 1e-10  # eigenvalue / largest below which a direction of the normalised information is unseen
NULL_PART = 1e-3  # a null vector "involves" an effect when its coefficients carry more than this (unit norm)


@dataclass(frozen=True)
class Setup:
    """What the records fix: table, site, mounting(s), the model M = base ∪ A ∪ B and the records' information."""

    kind: str
    a: str
    b: str
    model: Model  # base + A + B
    table: Table  # the records' chain with their first mounting
    triads: np.ndarray  # (24, 3, 3) mountings reachable by turning the case (rows: instrument axes, platform coords)
    f_records: np.ndarray  # (p, p) information of the records on M (zero until :func:`with_fit`)
    noise: NoiseSpec  # of the new test: the records' fitted white (+ Gauss–Markov) noise
    dt_s: float
    delta_a: np.ndarray
    delta_b: np.ndarray

    def index(self, name: str) -> np.ndarray:
        """Columns of effect ``name`` in M."""
        return np.arange(self.model.size)[self.model.slices()[name]]


def check_request(records, a: str, b: str, terms=None) -> tuple:
    """Validate ``--separate A,B`` against the records: (kind, base terms); ModelError naming what is wrong."""
    if not records:
        raise ModelError("design --separate: no records given (--from RECORDS)")
    kinds = {r.kind for r in records}
    if len(kinds) != 1:
        raise ModelError(f"design --separate: the records mix instrument kinds {sorted(kinds)}")
    kind = kinds.pop()
    if kind != fx.SDF:
        raise ModelError(f"design --separate: {kind} records are not supported yet (sdf-gyro only)")
    if a == b:
        raise ModelError(f"design --separate: {a} twice; name two different effects")
    for e in (a, b):
        if e not in fx.names():
            raise ModelError(f"design --separate: unknown effect {e!r}; valid for {kind}: {', '.join(fx.names(kind))}")
        if e not in fx.names(kind):
            raise ModelError(f"design --separate: {e} is not an effect of the records' instrument kind {kind}")
    from gyrojax.inference.identify import DEFAULT_TERMS

    base = [t for t in (terms or DEFAULT_TERMS[kind]) if t not in (a, b)]
    for t in base:
        if t not in fx.names(kind):
            raise ModelError(f"design --separate: --terms: {t!r} is not an effect of {kind}")
    bad = [t for t in base + [a, b] if t in TIME_EFFECTS]
    if bad:
        raise ModelError(f"design --separate: {bad} need a clock; the static follow-up design cannot use them")
    return kind, base


def geometry(records, a: str, b: str, base) -> Setup:
    """The table, site and mountings of the records (first record's chain), noise and information still empty."""
    meta = records[0].meta
    axes = tuple((ax["name"], tuple(float(c) for c in ax["axis_enu"])) for ax in meta["table"]["axes"])
    for r in records[1:]:
        other = tuple((ax["name"], tuple(float(c) for c in ax["axis_enu"])) for ax in r.meta["table"]["axes"])
        if other != axes:
            raise ModelError(
                f"design --separate: record {r.name!r} has another table ({[n for n, _ in other]}) than "
                f"{records[0].name!r} ({[n for n, _ in axes]}); pass the records of one table"
            )
    ins = meta["instrument"]
    table = Table.of(axes, plans.sdf_mount(ins["ia"], ins["oa"]), float(meta["site"]["latitude_deg"]))
    g = float(meta["site"].get("gravity_mps2", float(table.template.gravity)))
    table = replace(table, template=replace(table.template, gravity=jnp.asarray(g)))
    triad0 = np.asarray(table.template.triad)
    triads = np.einsum("mij,jk->mik", case_turns(), triad0)
    model = Model(tuple(base) + (a, b), fx.SDF)
    p = model.size
    return Setup(
        fx.SDF, a, b, model, table, triads, np.zeros((p, p)), NoiseSpec(white=1.0), 1.0, np.ones(1), np.ones(1)
    )


def _rows(model: Model, table: Table, triad, angles_rad):
    """Regressor rows (n, p) of static positions ``angles_rad`` (n, k) at mounting ``triad``, θ = 0."""
    tab = replace(table, template=replace(table.template, triad=triad))
    d = tab.positions_data(angles_rad)
    return jacobian(model, jnp.zeros(model.size), d).reshape(angles_rad.shape[0], model.size)


def _record_information(model: Model, records, white=None) -> np.ndarray:
    """Σ Jᵀ J / σ² of the records on ``model`` at θ = 0 (σ² = (60 N)²/Δt per measurement; N = 1 when not given)."""
    from gyrojax.inference.campaign import Campaign, linearize

    camp = Campaign.of(records)
    f = np.zeros((model.size, model.size))
    for i, ((_r, j, lab, _t), d) in enumerate(zip(linearize(model, np.zeros(model.size), camp), camp.data)):
        n = 1.0 if white is None else white[i]
        w = measurement_dt(d, lab) / (60.0 * n) ** 2
        f += (j * w[:, None]).T @ j
    return f


def reachable_null(setup: Setup, records, samples: int = 96, seed: int = 0) -> str:
    """Why no test on the records' table separates A and B ("" when one can): the null combinations of the
    normalised information of the records and of ``samples`` random chain angles (rad, uniform on [0, 2π)) at each
    of the 24 mountings."""
    model, k = setup.model, len(setup.table.axis_names)
    rng = np.random.default_rng(seed)
    ang = jnp.asarray(rng.uniform(0.0, 2.0 * math.pi, (samples, k)))
    rows = jax.jit(jax.vmap(lambda t: _rows(model, setup.table, t, ang)))(jnp.asarray(setup.triads))
    rows = np.asarray(rows).reshape(-1, model.size)
    f_rec = _record_information(model, records)
    f_reach = rows.T @ rows
    f = f_rec / max(np.abs(f_rec).max(), 1e-300) + f_reach / max(np.abs(f_reach).max(), 1e-300)
    s = np.sqrt(np.maximum(np.diag(f), 1e-300))
    ev, vec = np.linalg.eigh(f / np.outer(s, s))
    null = vec[:, ev < NULL_RTOL * ev[-1]]
    if not null.size:
        return ""
    ia, ib = setup.index(setup.a), setup.index(setup.b)
    names = model.coefficient_names
    for v in null.T:
        v = v / s  # back to report units
        v = v / np.abs(v).max()
        on_a, on_b = np.abs(v[ia]).max() > NULL_PART, np.abs(v[ib]).max() > NULL_PART
        if on_a or on_b:
            combo = " + ".join(f"{c:.3g}·{n}" for c, n in zip(v, names) if abs(c) > NULL_PART)
            what = f"{setup.a} and {setup.b}" if on_a and on_b else (setup.a if on_a else setup.b)
            return (
                f"no test on this table can separate {setup.a} and {setup.b}: the regressors of {what} are collinear "
                f"with the model's at every orientation the table reaches (24 mountings × {samples} chain angles): "
                f"{combo} is invisible; only an outside measurement (levelling, surveying the base) separates them"
            )
    return ""


def with_fit(setup: Setup, records, result) -> Setup:
    """``setup`` with the records' noise, information and the sizes δ_A, δ_B from ``result`` (fit of base ∪ A)."""
    model = setup.model
    white = [float(nz.white) for nz in result.noise]
    if not all(w > 0 and math.isfinite(w) for w in white):
        raise ModelError(f"design --separate: the fit's white noise {white} is not positive")
    f_rec = _record_information(model, records, white)
    sl_fit = result.model.slices()
    delta_a = np.asarray(result.theta[sl_fit[setup.a]], float)
    # δ_B: the B that explains the fitted signal of A best beside the base (projection, records' weights)
    ia, ib = setup.index(setup.a), setup.index(setup.b)
    base = np.setdiff1d(np.arange(model.size), np.concatenate([ia, ib]))
    keep = np.concatenate([base, ib])
    sol = np.linalg.lstsq(f_rec[np.ix_(keep, keep)], f_rec[np.ix_(keep, ia)] @ delta_a, rcond=None)[0]
    delta_b = sol[len(base) :]
    gm = next((nz.gauss_markov for nz in result.noise if nz.gauss_markov), ())
    noise = NoiseSpec(white=float(np.sqrt(np.mean(np.square(white)))), gauss_markov=tuple(gm))
    dts = [float(np.median(np.diff(r.columns["time_s"]))) for r in records]
    return replace(setup, f_records=f_rec, noise=noise, dt_s=float(np.median(dts)), delta_a=delta_a, delta_b=delta_b)


def _lambdas(setup: Setup, f_new):
    """(λ_A, λ_B): score-test noncentralities of A with B in the model and of B with A (module doc)."""
    f = jnp.asarray(setup.f_records) + f_new
    ia, ib = setup.index(setup.a), setup.index(setup.b)
    base = np.setdiff1d(np.arange(setup.model.size), np.concatenate([ia, ib]))
    out = []
    for test, other, delta in ((ia, ib, setup.delta_a), (ib, ia, setup.delta_b)):
        order = np.concatenate([base, other, test])
        out.append(noncentrality(f[np.ix_(order, order)], len(base) + len(other), jnp.asarray(delta)))
    return out


def _new_information(setup: Setup, triad, angles_rad, dwell_s):
    rows = _rows(setup.model, setup.table, triad, angles_rad)
    w = 1.0 / setup.noise.mean_variance(dwell_s)
    return jnp.einsum("np,n,nq->pq", rows, w, rows)


@dataclass
class SeparationDesign:
    """The designed follow-up test and its predicted powers."""

    setup: Setup
    mounting: int  # index into setup.triads (0: the records' mounting)
    angles_deg: np.ndarray  # (n, k)
    dwell_s: np.ndarray  # (n,)
    power_a: float  # of the score test for A with B in the model
    power_b: float
    lambda_a: float
    lambda_b: float
    hours_needed: float | None  # shortest total dwell (h) with both powers ≥ TARGET_POWER; None beyond MAX_HOURS
    history: np.ndarray | None = None  # the best start's loss per Adam iteration (the ``hours`` design)

    @property
    def convergence_note(self) -> str:
        """Why the search is not taken as converged ("" when it is; :mod:`gyrojax.planning.search`)."""
        if self.history is None:
            return ""
        return search.convergence_note(self.history, float(np.asarray(self.history)[-1]), "raise --adam-steps")

    @property
    def converged(self) -> bool:
        """Whether the search settled (see :attr:`convergence_note`)."""
        return not self.convergence_note

    @property
    def triad(self) -> np.ndarray:
        """Instrument axes (IA, OA, SA rows) in platform coordinates at the designed mounting."""
        return self.setup.triads[self.mounting]

    def plan(self, name: str | None = None, gap_s: float = 30.0) -> plans.Plan:
        """The designed test as a plan ``gyrojax simulate`` runs: one run on the records' chain and the designed
        mounting, one static segment per position (dwell rounded to whole samples of the records' Δt)."""
        s = self.setup
        t, dt = s.table, s.dt_s
        segs = tuple(
            plans.Segment(tuple(round(float(x), 6) for x in a), max(1, round(d / dt)) * dt, dt, label=i)
            for i, (a, d) in enumerate(zip(self.angles_deg, self.dwell_s))
        )
        ia, oa = self.triad[0], self.triad[1]
        run = plans.Run(
            f"separate-{s.a}-{s.b}", tuple(zip(t.axis_names, t.axes_enu)), plans.sdf_mount(ia, oa), segs, gap_s=gap_s
        )
        return plans.Plan(
            name or f"separate-{s.a}-{s.b}",
            (run,),
            t.latitude_deg,
            description=f"{len(segs)}-position test separating {s.a} from {s.b} (gyrojax design --separate)",
            reference="score-test power of the joint fit; Hu ch. 3-4 (multiposition tests)",
        )

    def summary(self) -> dict:
        """JSON-ready report: powers, noncentralities, sizes (report units), hours, mounting and positions."""
        s = self.setup
        return {
            "separate": [s.a, s.b],
            "power": {s.a: self.power_a, s.b: self.power_b},
            "noncentrality": {s.a: self.lambda_a, s.b: self.lambda_b},
            "size": {s.a: s.delta_a.tolist(), s.b: s.delta_b.tolist()},
            "alpha": ALPHA,
            "target_power": TARGET_POWER,
            "hours_needed": self.hours_needed,
            "converged": self.converged,
            **({"reason": self.convergence_note} if not self.converged else {}),
            "dwell_hours": float(np.sum(self.dwell_s) / 3600.0),
            "mounting": {"ia": self.triad[0].tolist(), "oa": self.triad[1].tolist(), "sa": self.triad[2].tolist()},
            "positions": [
                {"angles_deg": a.tolist(), "dwell_s": float(d)} for a, d in zip(self.angles_deg, self.dwell_s)
            ],
        }


def _power_function(setup: Setup):
    """f(triad, angles rad, dwell s) -> (power_A, power_B, λ_A, λ_B), the noncentralities compiled once."""
    lam = jax.jit(lambda t, a, d: jnp.stack(_lambdas(setup, _new_information(setup, t, a, d))))
    qa, qb = setup.delta_a.size, setup.delta_b.size

    def powers(triad, angles_rad, dwell_s):
        la, lb = (float(x) for x in lam(jnp.asarray(triad), jnp.asarray(angles_rad), jnp.asarray(dwell_s)))
        return detect_power(la, qa, ALPHA), detect_power(lb, qb, ALPHA), la, lb

    return powers


def _search(setup: Setup, n_positions: int, starts: int, steps: int, seed: int, learning_rate: float):
    """Adam over (angles, dwell logits) for every mounting × start; f(total_s) -> (mounting, angles, dwell)."""
    k, m_frac = len(setup.table.axis_names), 0.25 / n_positions
    triads = jnp.asarray(setup.triads)
    n_m = triads.shape[0]

    def loss(params, triad, total):
        ang, z = params
        la, lb = _lambdas(setup, _new_information(setup, triad, ang, dwell_from_logits(z, total, m_frac)))
        return jax.nn.logsumexp(-jnp.log(jnp.maximum(jnp.stack([la, lb]), 1e-300)))

    vg = jax.value_and_grad(loss)

    def run(p0, triad, total):
        p, hist = search.adam_scan(vg, p0, steps, learning_rate, triad, total)
        return p, hist, loss(p, triad, total)

    ang0 = jax.random.uniform(jax.random.PRNGKey(seed), (n_m * starts, n_positions, k), maxval=2 * math.pi)
    z0 = jnp.zeros((n_m * starts, n_positions))
    tri = jnp.repeat(triads, starts, axis=0)
    compiled = jax.jit(jax.vmap(run, in_axes=(0, 0, None)))

    def optimise(total_s: float):
        (ang, z), hist, vals = compiled((ang0, z0), tri, jnp.asarray(total_s))
        vals = np.where(np.isfinite(np.asarray(vals)), np.asarray(vals), np.inf)
        b = int(np.argmin(vals))
        if not np.isfinite(vals[b]):
            raise ModelError("design --separate: every start of the search ended with a non-finite loss")
        dwell = np.asarray(dwell_from_logits(z[b], total_s, m_frac))
        return b // starts, np.mod(np.asarray(ang[b]), 2 * math.pi), dwell, np.asarray(hist[b])

    return optimise


MAX_HOURS = 48.0  # the longest test the time search considers (h of dwell)


def _shortest(powers, tri, ang, dwell, hours: float, cap: float) -> float | None:
    """Shortest total dwell (h) at which this design, scaled in time, reaches :data:`TARGET_POWER` for both tests
    (bisection: the noncentralities grow with every dwell); None when even ``cap`` h does not."""

    def ok(h):
        pa, pb, _, _ = powers(tri, ang, dwell * (h / hours))
        return min(pa, pb) >= TARGET_POWER

    if not ok(cap):
        return None
    return bisect(ok, 0.0, cap)[1]


def design_separation(
    setup: Setup,
    hours: float = 4.0,
    n_positions: int = 12,
    starts: int = 2,
    steps: int = 300,
    seed: int = 0,
    learning_rate: float = 0.05,
) -> SeparationDesign:
    """Design the test (module doc) of ``hours`` total dwell, and search the time it needs: the shortest dwell at
    which both powers reach :data:`TARGET_POWER` (the ``hours`` design scaled, then re-designed at that length and
    scaled again; at most :data:`MAX_HOURS`, else ``hours_needed`` is None)."""
    optimise = _search(setup, n_positions, starts, steps, seed, learning_rate)
    powers = _power_function(setup)
    mi, ang, dwell, hist = optimise(hours * 3600.0)
    tri = setup.triads[mi]
    cap = max(hours, MAX_HOURS)
    need = _shortest(powers, tri, ang, dwell, hours, cap)
    if need is not None:
        mi2, ang2, dwell2, _ = optimise(need * 3600.0)  # re-designed at that length: a shorter one may reach it
        need2 = _shortest(powers, setup.triads[mi2], ang2, dwell2, need, cap)
        need = need if need2 is None else min(need, need2)
    pa, pb, la, lb = powers(tri, ang, dwell)
    res = SeparationDesign(setup, mi, np.rad2deg(ang), dwell, pa, pb, la, lb, need, hist)
    if not res.converged:
        warnings.warn(f"design --separate did not converge: {res.convergence_note}", ConvergenceWarning, stacklevel=2)
    return res


def separate(records, a: str, b: str, terms=None, hours: float = 4.0, **kw):
    """The whole request: check, refuse when no test on the table separates A and B (ModelError with the reason),
    fit base ∪ A, design. Returns (SeparationDesign, the fit)."""
    from gyrojax.inference.identify import fit

    kind, base = check_request(records, a, b, terms)
    setup = geometry(records, a, b, base)
    why = reachable_null(setup, records)
    if why:
        raise ModelError(f"design --separate: {why}")
    res = fit(records, list(base) + [a], allow_aliases=True)
    setup = with_fit(setup, records, res)
    return design_separation(setup, hours, **kw), res
