"""Diagnosis: see where the model fails and learn which named effect is missing.

For every named effect the model lacks (conventions §6) and the plan excites, a **score (Lagrange-multiplier)
test** at the current fit: one Jacobian of the model extended by all candidates, evaluated at (θ̂, 0), no refit per
candidate. With the current regressors J₀ and a candidate's regressors X, both whitened,

    X⊥ = X − P₀ X,    S = r̃ᵀ X⊥ (X⊥ᵀ X⊥)⁺ X⊥ᵀ r̃ / σ̃²,   S / k  ~  F(k, ν)   under "the effect is absent",

where P₀ projects on the columns of J₀, k = rank X⊥, and σ̃² is the variance of the whitened residual of the current
fit, r̃ᵀ(I − P₀)r̃ / ν with ν = n − rank J₀ degrees of freedom: the p-value is that of F(k, ν), which tends to
χ²(k) for long records and does not overstate significance for short ones (the same small-sample logic as the
fit's Student-t p-values). The noise model of the whitening (AR per record, :mod:`gyrojax.noise.whiten`) is
estimated from the residual of the *saturated* fit (all candidates in), where a missing effect cannot inflate it, so a
hidden deterministic effect is not mistaken for colour, and colour is not mistaken for an effect. p-values are
adjusted for testing every candidate at once (Holm's step-down procedure); the verdict is ``missing-effect`` when any
adjusted p-value is below α.

A candidate whose X⊥ vanishes is indistinguishable from the model in this plan; two candidates whose X⊥ are
collinear are **aliases** of each other in this plan, and
:func:`gyrojax.inference.separation.separating_plans` names built-in plans that would tell them apart. Residual
colour that no candidate explains is reported as ``gauss_markov``, never as a deterministic effect (conventions §6).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from gyrojax.errors import ModelError
from gyrojax.inference import adequacy
from gyrojax.inference.campaign import Campaign, linearize
from gyrojax.inference.identifiability import residue_columns
from gyrojax.inference.identify import fit
from gyrojax.inference.noisefit import (
    campaign_noise,
    group_readout_variance,
    noise_scale,
    satterthwaite_dof,
    small_sample_factor,
)
from gyrojax.inference.ranking import by_evidence
from gyrojax.inference.result import FitResult
from gyrojax.inference.separation import separating_plans
from gyrojax.inference.solver import solve, stack_whitened
from gyrojax.inference.tails import chi2_logsf, f_logsf_many
from gyrojax.noise import reml
from gyrojax.noise.readout import white_beside_readout
from gyrojax.noise.spec import NoiseSpec
from gyrojax.noise.whiten import fit_noise, gm_reml, whiten
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model
from gyrojax.threads import narrow_blas, parallel_map

SLOW = ("bias_trend", "bias_temperature")
"""Candidates that vary slowly in time and so compete with long-memory drift for the same residual structure. They
get the score test of every candidate, under the diagnosis' noise model, whose Gauss–Markov τ is capped at a fraction
of the record (:data:`gyrojax.noise.whiten.TAU_SPAN_FRACTION`): structure slower than that is not taken for noise.
Measured on null campaigns (``python -m benchmarks.study_slow_candidates``), this is the one of three tests that keeps
the verdict's level under Gauss–Markov drift and under a rate random walk: a Wald test with the noise re-fitted beside
the trend (Satterthwaite ν), and a profile likelihood ratio with the noise re-fitted under both hypotheses, reject
well above their level under the random walk, whose few low-frequency degrees of freedom the white + Gauss–Markov
fit cannot pin down. When the campaign has drift, a significant slow candidate is also read with the drift re-fitted
beside it (:func:`_drift_reading`); if it is not significant that way, it is ``indistinguishable`` from
``gauss_markov`` in this campaign, and ``separated_by`` says what would tell them apart."""
DRIFT_SEPARATION = (
    "repeat the run from a fresh turn-on (a deterministic trend repeats, drift does not), or record for several of "
    "the drift's correlation times"
)
"""What tells a slow candidate from long-memory drift when one campaign cannot."""
COLLINEAR = 0.999  # canonical correlation above which two candidates are aliases in this plan
UNSEEN = 1e-6  # |X⊥| / |X| below which a candidate is indistinguishable from the model


@dataclass
class Candidate:
    """One effect the model lacks, with the evidence for it: the test statistic and p-values (dimensionless), the
    residual RMS after adding it (deg/h for gyros, g for accelerometers), and its estimate in report units."""

    name: str
    statistic: float
    df: int
    p_value: float
    p_adjusted: float
    aliases: list
    rms_after: float
    estimate: dict = field(default_factory=dict)
    separated_by: list = field(default_factory=list)
    log10_p: float = 0.0
    indistinguishable: list = field(default_factory=list)  # near-aliases (gyrojax.inference.adequacy.near_aliases)
    refused: str | None = None  # why `fit` refuses the model with this candidate added (never proposed then)
    implausible: str | None = None  # sizes beyond what real instruments have (gyrojax.physics.plausibility)
    rms_after_refit: bool = False  # rms_after is fit's own after adding the candidate (else the one-step value)
    p_drift_refitted: float | None = None  # slow candidates: p of the Wald test with the drift re-fitted beside them
    refit: tuple | None = field(default=None, repr=False, compare=False)  # (records, FitResult) of the vetting refit

    def to_json(self) -> dict:
        """One entry of ``candidates`` in the diagnosis JSON (conventions §7); ``rms_after_deg_per_h`` is in the
        output unit (deg/h for gyros, g for accelerometers), ``estimate`` maps coefficient -> value and report unit."""
        return {
            "name": self.name,
            "statistic": float(self.statistic),
            "df": int(self.df),
            "p_value": float(self.p_value),
            "p_adjusted": float(self.p_adjusted),
            "log10_p": float(self.log10_p),
            "aliases": list(self.aliases),
            "rms_after_deg_per_h": float(self.rms_after),
            "estimate": self.estimate,
            "separated_by": list(self.separated_by),
            "indistinguishable": list(self.indistinguishable),
            "refused": self.refused,
            "implausible": self.implausible,
            "plausible": self.implausible is None,
            "rms_after_from": "refit" if self.rms_after_refit else "one-step",
            "p_value_drift_refitted": self.p_drift_refitted,
        }


@dataclass
class Diagnosis:
    """Verdict, ranked candidates and the fit they were tested against."""

    verdict: str
    fit: FitResult
    candidates: list
    alpha: float
    unexcited: list = field(default_factory=list)
    unexplained: list = field(default_factory=list)  # significant gyrojax.inference.adequacy.Structure, strongest first
    proposal: str | None = None  # the candidate to add: significant, accepted by fit, plausible
    tests: int = 0  # size of the multiple-comparison family (named candidates + shapes)

    @property
    def top(self) -> Candidate | None:
        """The highest-ranked candidate (possibly ``gauss_markov``), or None when nothing was tested."""
        return self.candidates[0] if self.candidates else None

    @property
    def residual_rms(self) -> float:
        """RMS residual of the tested fit, output units (deg/h for gyros, g for accelerometers)."""
        return self.fit.residual_rms

    @property
    def noise_floor(self) -> float:
        """White-noise level of the tested fit's residual, same units as :attr:`residual_rms`."""
        return self.fit.noise_floor

    def to_json(self) -> dict:
        """The JSON of conventions §7 (``gyrojax diagnose --json``), with extra keys tools may ignore."""
        return {
            "verdict": self.verdict,
            "residual_rms_deg_per_h": self.residual_rms,
            "noise_floor_deg_per_h": self.noise_floor,
            "candidates": [c.to_json() for c in self.candidates],
            "terms": list(self.fit.model.terms),
            "alpha": self.alpha,
            "not_excited": list(self.unexcited),
            "unexplained": [s.to_json() for s in self.unexplained],
            "proposal": self.proposal,
            "family_size": self.tests,
            "fit": self.fit.to_json(),
        }


def candidate_effects(model: Model, campaign: Campaign) -> list[str]:
    """Named effects absent from ``model`` that the records can carry.

    ``bias_temperature`` is a candidate only when every record has ``temperature_C`` (°C) and it varies by more
    than 1e-6 °C over the campaign; otherwise it would alias D_F.
    """
    out = []
    temps = [r.temperature_C for r in campaign.records]
    has_temp = all(t is not None for t in temps) and np.ptp(np.concatenate(temps)) > 1e-6 if temps else False
    for name in fx.names(model.kind):
        if name in model.terms:
            continue
        if name == "bias_temperature" and not has_temp:
            continue
        out.append(name)
    return out


def holm(p: np.ndarray) -> np.ndarray:
    """Holm–Bonferroni adjusted p-values (family-wise error control for many candidates)."""
    m = len(p)
    if m == 0:
        return p
    order = np.argsort(p)
    adj = np.empty(m)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[i]))
        adj[i] = running
    return adj


def _basis(a: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Orthonormal basis of the column space of ``a`` (rank-tolerant)."""
    if a.shape[1] == 0:
        return np.zeros((a.shape[0], 0))
    norms = np.sqrt((a * a).sum(axis=0))
    z = a / np.where(norms > 0, norms, 1.0)
    u, s, _ = np.linalg.svd(z, full_matrices=False)
    if s.size == 0 or s[0] == 0:
        return np.zeros((a.shape[0], 0))
    return u[:, s > tol * s[0]]


def _stack_whitened(lin, noises):
    rows_r, rows_j = [], []
    for (r, j, lab, t), nz in zip(lin, noises):
        w, _ = whiten(np.column_stack([r, j]), lab, nz, t)
        rows_r.append(w[:, 0])
        rows_j.append(w[:, 1:])
    return np.concatenate(rows_r), np.concatenate(rows_j, axis=0)


def _nuisance(t: np.ndarray) -> np.ndarray:
    """Per-record offset: structure that noise models must not absorb (see :func:`_noise_models`)."""
    return np.ones((len(t), 1))


def _noise_models(lin, cols, starts=None, readouts=None) -> list:
    """Per-record noise model from the residual left after projecting on the regressor columns ``cols`` and on a
    per-record offset.

    A misspecified model leaves deterministic structure in its residual; the slowest kind (a record-wide offset, as
    a flipped mounting gives an omitted D_O) would otherwise pass for long-memory noise and hide the very effect
    under test. It is a nuisance regressor only here; REML keeps the noise estimate unbiased when it is absent.
    Slower-than-the-record drift is kept apart from noise by the cap on τ
    (:data:`gyrojax.noise.whiten.TAU_SPAN_FRACTION`). ``starts``: the previous round's models, whose Gauss–Markov
    fits start this round's (one column more changes them little). ``readouts``: each record's servo readout noise
    σ_q² ((deg/h)², :mod:`gyrojax.noise.readout`; 0 for none), beside which the rate noise is fitted, so that the
    readout's MA(1) increments are not taken for colour.
    """
    starts = starts or [None] * len(lin)
    readouts = readouts or [0.0] * len(lin)
    scales = [max(np.sqrt(np.mean(r * r)), 1e-300) for r, *_ in lin]
    n_rec = len(lin)
    blocks = []
    for i, ((r, j, _lab, t), s) in enumerate(zip(lin, scales)):
        nu = np.zeros((len(r), n_rec))
        nu[:, i : i + 1] = _nuisance(t)
        blocks.append(np.column_stack([j[:, cols] / s, nu]))
    r_all = np.concatenate([r / s for (r, *_), s in zip(lin, scales)])
    ub = _basis(np.concatenate(blocks, axis=0))
    res = r_all - ub @ (ub.T @ r_all)
    bounds = np.cumsum([0] + [len(r) for r, *_ in lin])

    def one(i):  # the records' fits are independent: they run side by side (gyrojax.threads.parallel_map)
        r, j, lab, t = lin[i]
        s, st = scales[i], starts[i]
        design = np.column_stack([j[:, cols], _nuisance(t)])
        start = st if st is not None and st.gauss_markov else None
        nz = fit_noise(res[bounds[i] : bounds[i + 1]] * s, lab, t, design=design, start=start, readout_var=readouts[i])
        return nz if nz.innovation_std > 0 else NoiseSpec.from_sample_variances(s * s, reml.sample_interval(t))

    return parallel_map(one, range(n_rec))


def _score(lin, noises, model: Model, full: Model, cand, p0: int, rms_now: float):
    """Score statistic, p-value, estimate and residual-after of every candidate (module doc), and the whitened
    residual and regressors they were computed on.

    On the tall whitened system itself, not on the triangle of its QR (:class:`gyrojax.inference.adequacy.
    WhitenedSystem`), though the statistics are the same to rounding: exact aliases (D_II and D_SS in a 1 g tumble)
    have equal statistics to the last digits, which :func:`gyrojax.inference.ranking.by_evidence` then ranks in the
    conventions' order."""
    sl = full.slices()
    rw, jw = _stack_whitened(lin, noises)
    residue = residue_columns(jw)  # floating-point residue (cos 90° = 6e-17): not excited, never estimated
    j0 = jw[:, :p0]
    u0 = _basis(j0)
    r_perp = rw - u0 @ (u0.T @ rw)
    dof = max(len(rw) - u0.shape[1], 1)
    sigma2 = float(r_perp @ r_perp) / dof
    r_raw = np.concatenate([r for r, *_ in lin])
    j_raw = np.concatenate([j for _, j, *_ in lin], axis=0)
    n_raw = len(r_raw)
    # the model's least-squares fit to every candidate column at once (one factorisation of j0, many right sides)
    x_all = jw * ~residue
    b_all = np.linalg.lstsq(j0, x_all, rcond=None)[0] if p0 else np.zeros((0, x_all.shape[1]))
    tested, perps, unexcited, pending = [], {}, [], []
    for c in cand:
        cols = np.arange(full.size)[sl[c]]
        x = x_all[:, cols]
        xn = float(np.sqrt((x * x).sum()))
        xr = j_raw[:, cols] * ~residue[cols]
        if xn == 0.0 or float(np.abs(xr).max()) == 0.0:
            unexcited.append(c)
            continue
        b_model = b_all[:, cols]
        xp = x - u0 @ (u0.T @ x)
        rel = float(np.sqrt((xp * xp).sum())) / xn
        if rel < UNSEEN:
            weight = np.abs(b_model).max(axis=1) * np.sqrt((j0 * j0).sum(axis=0))
            idx = np.flatnonzero(weight > 1e-3 * weight.max())
            aliases = sorted({fx.effect_of_coefficient(model.coefficient_names[k]) for k in idx}, key=model.terms.index)
            tested.append(Candidate(c, 0.0, 0, 1.0, 1.0, aliases, rms_now))
            continue
        uc = adequacy.perp_basis(u0, x, tol=1e-7)  # directions measured against the candidate's own columns
        proj = uc.T @ r_perp
        stat = float(proj @ proj) / sigma2
        # the candidate's coefficients if it were added (whitened LS), and the raw residual it would leave
        beta, *_ = np.linalg.lstsq(xp, r_perp, rcond=None)
        delta = (xr - j_raw[:, :p0] @ b_model) @ beta
        rms_after = float(np.sqrt(np.mean((r_raw - delta) ** 2))) if n_raw else float("nan")
        est = {
            name: {"value": float(v), "unit": u} for name, v, u in zip(fx.get(c).coefficients, beta, fx.get(c).units)
        }
        cand_c = Candidate(c, stat, uc.shape[1], 1.0, 1.0, [], rms_after, est)
        tested.append(cand_c)
        pending.append(cand_c)
        perps[c] = uc
    # σ̃² estimated with dof degrees of freedom (module doc): F(df, dof) tails, all in one call
    logps = f_logsf_many([c.statistic / c.df for c in pending], [c.df for c in pending], dof)
    for c, logp in zip(pending, logps):
        c.p_value, c.log10_p = math.exp(logp), logp / math.log(10)
    return tested, perps, unexcited, (rw, jw)


def _spanned(perps: dict, name: str, extra: list) -> bool:
    """Whether candidate ``name`` is in ``extra``, or its projected regressors lie in the span of those of ``extra``
    (every canonical correlation above :data:`COLLINEAR`: an exact alias of what was added, D_II after D_SS in a 1 g
    tumble): adding it would leave the noise fit's column space as it is, so the forward selection stops. Without
    this, which of two exact aliases ranks first (the last digits of equal statistics, which BLAS threading
    changes) decided whether one more round of noise fits ran."""
    if name in extra:
        return True
    if name not in perps or not extra or any(e not in perps for e in extra):
        return False
    u = perps[name]
    span = adequacy.basis(np.column_stack([perps[e] for e in extra]))
    s = np.linalg.svd(u.T @ span, compute_uv=False)
    return bool(u.shape[1] and s.size >= u.shape[1] and s[u.shape[1] - 1] > COLLINEAR)


def _drift_reading(c: Candidate, camp: Campaign, lin, full: Model, p0: int) -> None:
    """The reading of a significant slow candidate with the drift re-fitted beside it: its GLS estimate ± the standard
    error `fit` would state, and the p-value of its Wald test, into ``estimate`` and ``p_drift_refitted``."""
    cols_c = np.arange(full.size)[full.slices()[c.name]]
    c.p_drift_refitted, beta, sd = wald_beside_drift(camp, lin, np.concatenate([np.arange(p0), cols_c]), p0)
    fx_c = fx.get(c.name)
    est = zip(fx_c.coefficients, beta, sd, fx_c.units)
    c.estimate = {n: {"value": float(v), "std": float(e), "unit": u} for n, v, e, u in est}


def wald_beside_drift(camp: Campaign, lin, cols: np.ndarray, p0: int):
    """(p-value, estimate, standard error) of the coefficients ``cols[p0:]`` by GLS with the fit's noise model
    re-estimated with them in (:func:`gyrojax.inference.noisefit.campaign_noise`); Wald W / k ~ F(k, ν), ν the
    smallest Satterthwaite degrees of freedom of those coefficients when the noise has a Gauss–Markov part."""
    sub = [(r, j[:, cols], lab, t) for r, j, lab, t in lin]
    noises = campaign_noise(sub, camp)
    scales = [noise_scale(r, lab) for r, _, lab, _ in sub]
    rw, jw = stack_whitened(sub, noises, scales)
    step, cov = solve(jw, rw)
    e = rw - jw @ step
    diag = np.diag(cov)
    dof = max(len(rw) - int(np.sum(np.isfinite(diag) & (diag > 0))), 1)
    cov = cov * float(e @ e) / dof
    idx = np.arange(p0, len(cols))
    beta, v = step[idx], cov[np.ix_(idx, idx)]
    sd = np.sqrt(np.where(np.diag(v) > 0, np.diag(v), np.nan))
    ok = np.isfinite(sd)
    if not ok.any():
        return 1.0, beta, sd
    stat = float(beta[ok] @ np.linalg.solve(v[np.ix_(ok, ok)], beta[ok]))
    nus = np.full(len(idx), float(dof))
    if any(nz.gauss_markov for nz in noises):
        nus = satterthwaite_dof(sub, camp, noises, scales)[idx]
    k = int(ok.sum())
    # the standard error as `fit` states it: widened by t_ν / z (gyrojax.inference.noisefit.small_sample_factor)
    return float(stats.f.sf(stat / k, k, float(np.min(nus[ok])))), beta, sd * small_sample_factor(nus)


@narrow_blas
def diagnose(
    records,
    terms=None,
    *,
    alpha: float = 0.01,
    candidates=None,
    result: FitResult | None = None,
    campaign: Campaign | None = None,
    suggest_tests: bool = True,
    model_free: bool = True,
    plausible: dict | None = None,
) -> Diagnosis:
    """Rank the effects the model ``terms`` is missing, from the data of ``records``.

    Args:
      records: records of one instrument (any plans and modes), or a list of them.
      terms: the current model (effect names); default as :func:`gyrojax.inference.identify.fit`.
      alpha: family-wise significance level for the verdict (dimensionless).
      candidates: effect names to test (default: every named effect not in the model that the records can carry).
      result: a fit of ``terms`` to these records, if already at hand.
      campaign: the records already built into a :class:`gyrojax.inference.campaign.Campaign`, if at hand.
      suggest_tests: name built-in plans that would separate aliased candidates.
      model_free: also test the residual against shapes in every input (:mod:`gyrojax.inference.adequacy`); the
        family of the multiple-comparison control then holds the named candidates and the shapes.
      plausible: overrides of the plausible sizes (:mod:`gyrojax.physics.plausibility`), by coefficient or effect name.

    Returns: a :class:`Diagnosis` with ``verdict`` ``"missing-effect"`` or ``"adequate"``; residuals and noise
    floor in the output unit (deg/h for gyros, g for accelerometers), candidate estimates in report units.
    """
    camp = campaign or Campaign.of(records)
    res = result or fit(camp.records, terms, campaign=camp)
    model = res.model
    cand = list(candidates) if candidates is not None else candidate_effects(model, camp)
    for c in cand:
        if c not in fx.names(model.kind):
            raise ModelError(f"unknown candidate effect {c!r} for a {model.kind}")
    full = Model(model.terms + tuple(c for c in cand if c not in model.terms), model.kind)
    theta_full = np.concatenate([res.theta, np.zeros(full.size - model.size)])
    lin = linearize(full, theta_full, camp)
    p0 = model.size
    sl = full.slices()

    # noise model by forward selection: from the current residual, re-estimated after adding the most
    # significant candidate (so that a strong missing effect does not pass for coloured noise, and a plan whose
    # candidates span every position cannot soak the drift's low-frequency power into a saturated fit)
    # (each round's noise fits start from the previous round's)
    extra: list[str] = []
    noises = None
    readouts = [group_readout_variance(camp, [i]) for i in range(len(camp.records))]
    for _round in range(4):
        cols = np.concatenate([np.arange(p0)] + [np.arange(full.size)[sl[c]] for c in extra]).astype(int)
        noises = _noise_models(lin, cols, noises, readouts)
        tested, perps, unexcited, scored = _score(lin, noises, model, full, cand, p0, res.residual_rms)
        live = [c for c in tested if c.df > 0]
        if not live:
            break
        best = by_evidence(live, model.kind)[0]
        if best.log10_p + math.log10(len(live)) >= math.log10(alpha) or _spanned(perps, best.name, extra):
            break
        extra.append(best.name)

    # aliases between candidates: collinear projected regressors
    names_t = [c.name for c in tested if c.name in perps]
    for i, a in enumerate(names_t):
        for b in names_t[i + 1 :]:
            s = np.linalg.svd(perps[a].T @ perps[b], compute_uv=False)
            if s.size and s[0] > COLLINEAR:
                ca = next(c for c in tested if c.name == a)
                cb = next(c for c in tested if c.name == b)
                ca.aliases.append(b)
                cb.aliases.append(a)

    # ---- model-free adequacy, joint Holm, vetting of what is proposed (gyrojax.inference.adequacy) -------
    live = [c for c in tested if c.df > 0]
    tested = by_evidence(tested, model.kind)
    explaining = [c.name for c in live]  # named effects that may explain a shape: not refused, plausible
    if any(d.mode == "servo" for d in camp.data):
        # servo records: a candidate's column is its drift seen through the servo, and those built on ω_I (the nulled
        # input, ≈ −drift: sf_quadratic's ω_I² holds every harmonic the fitted drift has) span slow shapes jointly
        # with sizes no instrument has; only the candidates the data asks for (significant at α, Holm) explain them
        bar = math.log10(alpha) - math.log10(max(len(live), 1))
        explaining = [c.name for c in live if c.log10_p < bar]
    system = adequacy.ShapeSystem.build(camp, lin, res.noise, p0, res) if model_free else None
    scored = adequacy.WhitenedSystem.of(*scored, np.zeros((len(scored[0]), 0)), [], p0)  # for the near-aliases
    near: dict = {}  # near-aliases, computed once per candidate across the rounds
    for _round in range(2):
        cols = np.concatenate([np.arange(full.size)[sl[c]] for c in explaining]).astype(int) if explaining else []
        shapes = adequacy.residual_structure(camp, lin, res.noise, p0, cols, res, system) if model_free else []
        adj = adequacy.holm_log10([c.log10_p for c in live] + [s.log10_p for s in shapes])
        for c, a in zip(live + shapes, adj):
            c.p_adjusted = float(10.0**a)
        sig = {id(c) for c, a in zip(live + shapes, adj) if a < math.log10(alpha)}
        significant = [c for c in tested if id(c) in sig]
        unexplained = [s for s in shapes if id(s) in sig]
        proposal = adequacy.vet(tested, significant, camp, res, lin, noises, p0, sl, alpha, plausible, near, scored)
        barred = {c.name for c in significant if c.refused or c.implausible}
        if not barred & set(explaining):
            break
        explaining = [c for c in explaining if c not in barred]  # shapes they would have hidden are tested again
    verdict = "missing-effect" if significant or unexplained else "adequate"
    family = len(live) + len(shapes)
    slow = [c for c in significant if c.name in SLOW] if any(nz.gauss_markov for nz in noises) else []
    for c in slow:  # beside drift: is the candidate still significant with the drift re-fitted beside it?
        _drift_reading(c, camp, lin, full, p0)
        if c.p_drift_refitted * family >= alpha:
            c.indistinguishable.append("gauss_markov")

    # colour that no deterministic effect explains: report it as gauss_markov
    gm = _colour_candidate(noises, lin, alpha, p0)
    if gm is not None:
        if significant:
            tested.insert(len(significant), gm)
        else:
            tested.insert(0, gm)

    if suggest_tests:
        for c in tested[:5]:
            group = (c.name,) + tuple(a for a in c.aliases + c.indistinguishable if a in fx.names())
            if len(group) > 1 and c.name in perps:
                context = (camp, lin, full, res, tested)  # for the test designed on this table (issue 27)
                c.separated_by = separating_plans(model.kind, group, context) or adequacy.setup_measurements(group)
    for c in slow:
        if "gauss_markov" in c.indistinguishable:
            c.separated_by = [*c.separated_by, DRIFT_SEPARATION]
    return Diagnosis(verdict, res, tested, alpha, unexcited, unexplained, proposal, family)


def _colour_candidate(noises, lin, alpha, p0: int = 0) -> Candidate | None:
    """Likelihood-ratio test of the AR noise model against white noise, pooled over records.

    A servo record whose readout noise is known (:mod:`gyrojax.noise.readout`) is tested by the REML likelihood
    ratio of its white + Gauss–Markov rate noise against white rate noise, both beside the readout (the first ``p0``
    columns of J the fitted regressors): colour is then that of the rate, never the readout's MA(1) increments."""
    stat, df, rms_acc, n_acc = 0.0, 0, 0.0, 0
    for nz, (r, j, lab, t) in zip(noises, lin):
        n = len(r)
        if nz.gauss_markov and nz.readout_var > 0:
            if nz.gm_variance > 0:
                design = np.column_stack([j[:, :p0], np.ones(n)])
                white = white_beside_readout(r, design, lab, t, nz)
                stat += max(gm_reml(r, design, lab, t, white) - gm_reml(r, design, lab, t, nz), 0.0)
            df += 2
        elif nz.order and nz.innovation_std > 0:
            stat += n * math.log(max(nz.variance_ratio, 1.0))
            df += 2 if nz.order == "gm" else nz.order
        rms_acc += nz.innovation_std**2 * n
        n_acc += n
    if df == 0:
        return None
    logp = float(chi2_logsf(stat, df))
    p = math.exp(logp)
    if p >= alpha:
        return None
    return Candidate(
        "gauss_markov",
        stat,
        df,
        p,
        p,
        [],
        float(math.sqrt(rms_acc / max(n_acc, 1))),
        {"ar_order": {"value": df, "unit": "-"}},
        log10_p=logp / math.log(10),
    )


def effect_to_add(d: Diagnosis, effect: str | None = None) -> str:
    """The effect an add-and-refit step adds: ``effect`` when given, else the diagnosis' proposal; with neither,
    a :class:`ModelError` naming the first unexplained structures (or saying the model is adequate)."""
    if effect is not None:
        return effect
    if d.proposal is None:
        found = [getattr(s, "line", None) or s.name for s in d.unexplained[:3]]
        raise ModelError(f"no named effect to add: {'; '.join(found) or 'the model is adequate for these records'}")
    return d.proposal


def fit_with(d: Diagnosis, records, effect: str | None = None, campaign: Campaign | None = None) -> FitResult:
    """The fit of the diagnosed model with ``effect`` added (default: the proposal, :func:`effect_to_add`), exactly
    ``fit(records, terms + (effect,), allow_aliases=False)``: the one the diagnosis already computed when it vetted
    that candidate on the same records (:func:`gyrojax.inference.adequacy.vet`, the same call), else a new fit. The
    main loop's next step then costs one fit less."""
    effect = effect_to_add(d, effect)
    camp = campaign if campaign is not None else Campaign.of(records)
    for c in d.candidates:
        if c.name == effect and c.refit is not None:
            done_on, res = c.refit
            if len(done_on) == len(camp.records) and all(a is b for a, b in zip(done_on, camp.records)):
                return res
    return fit(camp.records, tuple(d.fit.model.terms) + (effect,), campaign=camp, allow_aliases=False)


@narrow_blas
def add_and_refit(records, terms, effect: str | None = None, *, diagnosis: Diagnosis | None = None, **kw):
    """Add ``effect`` (default: the top deterministic candidate) to ``terms``, refit, and diagnose again.

    Returns ``(new_terms, new_fit, new_diagnosis, added)``.
    """
    camp = Campaign.of(records) if not isinstance(records, Campaign) else records
    d = diagnosis or diagnose(camp.records, terms, campaign=camp, **kw)
    effect = effect_to_add(d, effect)
    new_terms = tuple(d.fit.model.terms) + (effect,)
    new_fit = fit_with(d, camp.records, effect, campaign=camp)
    new_d = diagnose(camp.records, new_terms, campaign=camp, result=new_fit, **kw)
    return new_terms, new_fit, new_d, effect
