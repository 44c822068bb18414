"""The turntable records' part of the diagnosis (:mod:`gyrojax.inference.diagnose`): their candidates, noise and
readings.

* **Candidates**: every named effect of the registry the model lacks that the records can carry (conventions §6),
  as columns of one Jacobian of the model extended by all of them, at (θ̂, 0); a column that is floating-point
  residue (cos 90° = 6e-17) is not excited.
* **Noise**: a noise model per record (AR or white + Gauss–Markov, :mod:`gyrojax.noise.whiten`) from the residual
  projected on the model, on the candidates the forward selection took in, and on a per-record offset, so that a
  hidden deterministic effect is not taken for colour, and colour is not taken for an effect. Its Gauss–Markov τ is
  capped at a fraction of the record (:data:`gyrojax.noise.whiten.TAU_SPAN_FRACTION`): slower structure counts as
  a trend. Colour that no candidate explains is reported as ``gauss_markov`` (conventions §6), never as an effect.
  Colour seen in positions of a few samples, whose memory spans them, is judged against every candidate by
  likelihood before it may hide one (:data:`POSITION_SAMPLES`).
* **Shapes**: the model-free shapes of :mod:`gyrojax.inference.adequacy`, whitened with the fit's noise model.
* **Readings beside drift**: a significant slow candidate (:data:`SLOW`) is read again with the drift re-fitted
  beside it; if it is not significant that way it is ``indistinguishable`` from ``gauss_markov``.
* **What separates aliases**: the built-in plans (:func:`gyrojax.inference.separation.separating_plans`), a test
  designed on the campaign's own table, or the set-up measurements.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from gyrojax.errors import ModelError
from gyrojax.inference import adequacy
from gyrojax.inference.campaign import Campaign, linearize
from gyrojax.inference.identifiability import residue_columns
from gyrojax.inference.identify import fit
from gyrojax.inference.instrument import Rules, Session
from gyrojax.inference.knee import grid, input_values, sup_score
from gyrojax.inference.noisefit import (
    campaign_noise,
    group_readout_variance,
    noise_scale,
    satterthwaite_dof,
    small_sample_factor,
)
from gyrojax.inference.scoring import ALPHA, candidates, residual_variance, score_beside, score_tests
from gyrojax.inference.separation import separating_plans, setup_measurements
from gyrojax.inference.solver import solve, stack_whitened
from gyrojax.inference.subspace import WhitenedSystem, basis, perp
from gyrojax.inference.verdict import Candidate
from gyrojax.noise import reml
from gyrojax.noise.readout import white_beside_readout
from gyrojax.noise.spec import NoiseSpec
from gyrojax.noise.whiten import fit_noise, gm_profile, gm_reml, whiten
from gyrojax.physics import effects as fx
from gyrojax.physics import plausibility
from gyrojax.physics.model import Model
from gyrojax.runtime.threads import parallel_map
from gyrojax.tails import chi2_logsf, f_sf

SLOW = ("bias_trend", "bias_temperature")
"""Candidates that vary slowly in time and so compete with long-memory drift for the same residual structure. They
get the score test of every candidate, under the diagnosis' noise model, whose Gauss–Markov τ is capped at a fraction
of the record: structure slower than that is not taken for noise. Measured on null campaigns
(``python -m benchmarks.study_slow_candidates``), this is the one of three tests that comes closest to the verdict's
level (1 %): missing-effect in 1 of 100 null campaigns with Gauss–Markov drift and 0 of 100 with a 4-hour rate random
walk, where a Wald test with the noise re-fitted beside the trend (Satterthwaite ν), and a profile likelihood ratio
with the noise re-fitted under both hypotheses, reject 14 % of the random walks at the first Holm step: their few
low-frequency degrees of freedom the white + Gauss–Markov fit cannot pin down. When the campaign has drift, a
significant slow candidate is also read with the drift re-fitted beside it (:func:`wald_beside_drift`); if it is not
significant that way, it is ``indistinguishable`` from ``gauss_markov`` in this campaign, and ``separated_by`` says
what would tell them apart."""
DRIFT_SEPARATION = (
    "repeat the run from a fresh turn-on (a deterministic trend repeats, drift does not), or record for several of "
    "the drift's correlation times"
)
"""What tells a slow candidate from long-memory drift when one campaign cannot."""

INPUT_FOLLOWING = ("bias_temperature", "temperature_hinge")
"""Candidates that follow a slowly varying recorded input (temperature) and so may be taken for colour: each is judged
against the colour by likelihood before the colour is allowed to hide it (:meth:`TurntableSession.outweighs_colour`,
:func:`colour_against_shape`). Not ``bias_trend``: time is the colour's own axis, and one realisation of slow drift is
often fitted better by a line than by the colour (a 4-hour rate random walk said missing-effect in 5 of 100 null
campaigns with the trend judged so, 0 of 100 without); a trend is judged against the drift by its score test under
the capped colour and its reading beside the drift (:data:`SLOW`)."""

POSITION_SAMPLES = 8
"""Samples a record's median continuous segment (a static position) must hold for its colour to be told from an
offset per position (the fewest a segment must hold for the white + Gauss–Markov fit,
:func:`gyrojax.noise.whiten.fit_gm`). Within a position of n samples the colour is seen only through its first
n − 1 lags (an AR(p) fit then has p ≤ n/4), where a colour whose memory spans the position and a constant level
look alike: an effect the model lacks that differs between positions leaves such levels in the residual, their
lagged products are read as colour, and its whitening removes the very levels the effect is seen in."""
POSITION_CORRELATION_TIMES = 10.0
"""Correlation times of a record's colour its median position must hold for a position's level to pass for the
colour's own wandering rather than an offset (a colour of shorter memory does not hold a position at one level)."""

RULES = Rules(retest_shapes=True, refit_budget=3, skip_aliased=False, plausible_before_refit=False)
"""Turntable proposals: shapes a refused or implausible candidate would have hidden are tested again without it;
at most three significant candidates are refitted (in rank order, until one is accepted and plausible); an alias of
another candidate may be proposed (ties in the conventions' order), its size judged on the refit."""


def candidate_effects(model: Model, campaign: Campaign) -> list[str]:
    """Named effects absent from ``model`` that the records can carry.

    The temperature effects (:data:`gyrojax.physics.effects.TEMPERATURE_EFFECTS`) are candidates only when every
    record has ``temperature_C`` (°C) and it varies by more than 1e-6 °C over the campaign; otherwise they would
    alias D_F.
    """
    out = []
    temps = [r.temperature_C for r in campaign.records]
    has_temp = all(t is not None for t in temps) and np.ptp(np.concatenate(temps)) > 1e-6 if temps else False
    for name in fx.names(model.kind):
        if name in model.terms:
            continue
        if name in fx.TEMPERATURE_EFFECTS and not has_temp:
            continue
        out.append(name)
    return out


@dataclass(frozen=True)
class Round:
    """One round of the forward selection: the records' noise models and the score tests of the candidates under
    them (``candidates`` in the session's order, ``perps`` their X⊥ bases, ``whitened`` the stacked (r̃, J̃))."""

    noises: list
    candidates: list
    unexcited: list
    perps: dict
    whitened: tuple


@dataclass(frozen=True)
class TurntableSession(Session):
    """Turntable records at a fit, as the diagnosis sees them: the campaign, the fit, the model extended by the
    candidates ``names`` and its linearisation at (θ̂, 0), and each record's servo readout variance."""

    campaign: Campaign
    fit: object
    names: list
    full: Model
    lin: list
    readouts: list
    rules: Rules = RULES
    knees: dict = field(default_factory=dict)

    @classmethod
    def of(cls, records, terms=None, result=None, campaign=None, candidates=None) -> TurntableSession:
        """The session of ``records`` (or of ``campaign``) at ``result`` (default: the fit of ``terms``)."""
        camp = campaign or Campaign.of(records)
        res = result or fit(camp.records, terms, campaign=camp)
        model = res.model
        names = list(candidates) if candidates is not None else candidate_effects(model, camp)
        for c in names:
            if c not in fx.names(model.kind):
                raise ModelError(f"unknown candidate effect {c!r} for a {model.kind}")
        full = Model(model.terms + tuple(c for c in names if c not in model.terms), model.kind)
        lin = linearize(full, np.concatenate([res.theta, np.zeros(full.size - model.size)]), camp)
        readouts = [group_readout_variance(camp, [i]) for i in range(len(camp.records))]
        knees = {c: _knee_grid(camp, c, model.kind) for c in names if fx.get(c).knee is not None}
        lin = _at_profile_knees(lin, full, model.size, knees)
        return cls(camp, res, names, full, lin, readouts, knees=knees)

    @property
    def kind(self) -> str:
        """The registry's instrument kind (the order of exact aliases)."""
        return self.fit.model.kind

    @property
    def records(self) -> list:
        """The campaign's records."""
        return self.campaign.records

    @property
    def p0(self) -> int:
        """Columns of the fitted model in the extended Jacobian (the candidates' follow)."""
        return self.fit.model.size

    def columns(self, names) -> np.ndarray:
        """The extended Jacobian's columns of the fitted model and of the candidates ``names``."""
        sl = self.full.slices()
        return np.concatenate([np.arange(self.p0)] + [np.arange(self.full.size)[sl[c]] for c in names]).astype(int)

    # ---- the forward selection -------------------------------------------------------------------------------

    def score(self, taken: list, previous: Round | None) -> Round:
        """Noise models with the candidates ``taken`` among the fixed effects (each started from ``previous``'s),
        and the score tests of every candidate under them."""
        noises = _noise_models(self.lin, self.columns(taken), previous and previous.noises, self.readouts)
        return Round(noises, *_score(self.lin, noises, self.fit, self.full, self.names, self.knees))

    def outweighs_colour(self, rnd: Round, taken: list, alpha: float) -> str | None:
        """The candidate that explains the records better, with white noise, than the colour of ``rnd`` does
        without it (:func:`colour_against_shape`): among those that follow a slow input (:data:`INPUT_FOLLOWING`),
        and among every candidate where the colour is not resolved by the records' positions
        (:func:`colour_unresolved`). None when none does, the noise has no colour, or a record's readout noise is
        known (its white alternative is not white).

        The likelihood comparison is a choice between models, not a test at a level: one realisation of long-memory
        drift is often explained better by a shape that follows time (a line; a temperature that rises with time)
        than by the colour. So the winner is taken only if it is also significant, at the level a candidate is taken
        at (Bonferroni over the live candidates), with the drift re-fitted beside it (:func:`wald_beside_drift`, the
        drift kept: the records have colour, and one realisation of it may look white to the REML). Taken on the
        likelihood alone, it would leave a colour re-fitted without the drift's slowest part, under which it and the
        candidates that differ between positions are then tested too leniently."""
        if not any(nz.gauss_markov or nz.order for nz in rnd.noises) or any(self.readouts):
            return None
        every = colour_unresolved(self.lin, rnd.noises)
        sl = self.full.slices()
        best = None
        for c in rnd.candidates:
            if c.df == 0 or c.name in taken or not (every or c.name in INPUT_FOLLOWING):
                continue
            cols = np.arange(self.full.size)[sl[c.name]]
            gain = colour_against_shape(self.lin, rnd.noises, self.columns(taken), cols, fx.get(c.name).knee)
            if gain > 0 and (best is None or gain > best[0]):
                best = (gain, c.name, cols)
        if best is None:
            return None
        live = sum(1 for c in rnd.candidates if c.df > 0)
        cols0 = self.columns(taken)
        p, _, _ = wald_beside_drift(
            self.campaign, self.lin, np.concatenate([cols0, best[2]]), len(cols0), keep_drift=True
        )
        return best[1] if p * live < alpha else None

    # ---- shapes, near-aliases, proposals ------------------------------------------------------------------------

    def explaining(self, live: list, alpha: float) -> list[str]:
        """The candidates that may explain a shape. On servo records a candidate's column is its drift seen through
        the servo, and those built on ω_I (the nulled input, ≈ −drift: sf_quadratic's ω_I² holds every harmonic the
        fitted drift has) span slow shapes jointly with sizes no instrument has: only the candidates the data ask
        for (significant at α, Holm) explain them."""
        if any(d.mode == "servo" for d in self.campaign.data):
            bar = math.log10(alpha) - math.log10(max(len(live), 1))
            return [c.name for c in live if c.log10_p < bar]
        return [c.name for c in live]

    @cached_property
    def shape_system(self) -> adequacy.ShapeSystem:
        """The shapes of the records whitened with the fit's noise model (one per diagnosis)."""
        return adequacy.ShapeSystem.build(self.campaign, self.lin, self.fit.noise, self.p0, self.fit)

    def structure(self, rnd: Round, explaining: list) -> list:
        """The shapes no candidate of ``explaining`` explains (:func:`gyrojax.inference.adequacy.residual_structure`),
        unadjusted."""
        cols = self.columns(explaining)[self.p0 :] if explaining else []
        return adequacy.residual_structure(
            self.campaign, self.lin, self.fit.noise, self.p0, cols, self.fit, self.shape_system
        )

    def near_aliases(self, rnd: Round, names: list, alpha: float) -> dict:
        """The candidates each of ``names`` cannot be told from at level ``alpha``
        (:func:`gyrojax.inference.adequacy.near_aliases`)."""
        sl = self.full.slices()
        live = {c.name: sl[c.name] for c in rnd.candidates if c.df > 0 and c.name in sl}
        rw, jw = rnd.whitened
        system = WhitenedSystem.of(rw, jw, np.zeros((len(rw), 0)), [], self.p0)
        return adequacy.near_aliases(self.lin, rnd.noises, self.p0, live, names, alpha, system)

    def beside(self, rnd: Round, name: str, stronger: list, shapes: list):
        """The score test of ``name`` beside the candidates ``stronger`` in this round's whitening (the model-free
        shapes are columns of another system, :mod:`gyrojax.inference.adequacy`: not among them)."""
        sl = self.full.slices()
        if name not in sl:
            return None
        rw, jw = rnd.whitened
        others = [jw[:, sl[n]] for n in stronger if n in sl and n != name]
        sc = score_beside(rw, jw[:, : self.p0], jw[:, sl[name]], others)
        return 0.0 if sc is None else sc.log10_p

    def with_refit(self, c: Candidate, f) -> Candidate:
        """``c`` with the refit's residual RMS and estimates (they replace the one-step values)."""
        units = f.units()
        est = {k: {"value": f.values[k], "std": f.stds[k], "unit": units[k]} for k in fx.get(c.name).coefficients}
        return replace(super().with_refit(c, f), rms_after=f.residual_rms, rms_after_refit=True, estimate=est)

    def refusal(self, e: ModelError) -> str:
        """Why the fit refuses a candidate."""
        return f"fit refuses it on these records: {e}"

    def implausible(self, c: Candidate, overrides) -> str | None:
        """Sizes beyond what real instruments and test sets have (:mod:`gyrojax.physics.plausibility`)."""
        return plausibility.implausible(c.estimate, overrides)

    def fit_terms(self, terms):
        """The fit of ``terms`` to the session's records (the next step of the main loop)."""
        return fit(self.campaign.records, terms, campaign=self.campaign, allow_aliases=False)

    # ---- what the diagnosis adds after its verdict ------------------------------------------------------------

    def noise_processes(self, rnd: Round, taken: list, alpha: float) -> list:
        """Colour that no deterministic effect explains, as ``gauss_markov`` (:func:`_colour_candidate`)."""
        gm = _colour_candidate(rnd.noises, self.lin, alpha, self.p0)
        return [] if gm is None else [gm]

    def finish(
        self, rnd: Round, ranked: list, significant: list, family: int, alpha: float, noise: list, suggest_tests: bool
    ) -> list:
        """The candidates as reported: slow ones read again beside the drift (module doc), the colour
        ``gauss_markov`` after the significant ones (first when none is), and what would separate the aliases of
        the first five."""
        by = {c.name: c for c in ranked}
        slow = [n for n in significant if n in SLOW] if any(nz.gauss_markov for nz in rnd.noises) else []
        for n in slow:  # beside drift: is the candidate still significant with the drift re-fitted beside it?
            p, est = _drift_reading(n, self.campaign, self.lin, self.full, self.p0)
            near = by[n].indistinguishable + (["gauss_markov"] if p * family >= alpha else [])
            by[n] = replace(by[n], p_drift_refitted=p, estimate=est, indistinguishable=near)
        out = [by[c.name] for c in ranked]
        if noise:
            out.insert(len(significant), noise[0])
        if suggest_tests:
            for i, c in enumerate(out[:5]):
                group = (c.name,) + tuple(a for a in c.aliases + c.indistinguishable if a in fx.names())
                if len(group) > 1 and c.name in rnd.perps:
                    context = (self.campaign, self.lin, self.full, self.fit, out)
                    plans = separating_plans(self.kind, group, context) or setup_measurements(group)
                    out[i] = replace(c, separated_by=plans)
        for i, c in enumerate(out):
            if c.name in slow and "gauss_markov" in c.indistinguishable:
                out[i] = replace(c, separated_by=[*c.separated_by, DRIFT_SEPARATION])
        return out


def _knee_grid(camp: Campaign, name: str, kind: str) -> tuple:
    """(the knee grid of the hinged effect ``name`` over its input, each record's regressors of its slope at every
    knee of the grid and, last, at a knee below every recorded value — the input itself, the linear part a hinge is
    tested beside: (rows, knees + 1) in the output unit per report unit), by the measurement model itself."""
    values = input_values(camp.records, fx.get(name).knee)
    knees = grid(values)
    below = float(np.min(values)) - 1.0
    one = Model((name,), kind)
    cols = [np.empty((int((lab >= 0).sum()), len(knees) + 1)) for lab in camp.labels]
    for j, k in enumerate([*knees, below]):
        for i, rec in enumerate(linearize(one, np.array([0.0, k]), camp)):
            cols[i][:, j] = rec.jacobian[:, 0]
    return knees, cols


def _at_profile_knees(lin, full: Model, p0: int, knees: dict) -> list:
    """``lin`` with the slope column of each hinged candidate at the knee where its score beside the fitted model is
    largest, each record weighted by its noise level (the knee a fit would start from,
    :func:`gyrojax.inference.knee.profile_start`): the column the noise fit and the shapes are projected on."""
    if not knees:
        return lin
    sl = full.slices()
    scales = [noise_scale(rec.residual, rec.labels) for rec in lin]
    rw = np.concatenate([rec.residual / s for rec, s in zip(lin, scales)])
    j0 = np.concatenate([rec.jacobian[:, :p0] / s for rec, s in zip(lin, scales)], axis=0)
    out = [rec._replace(jacobian=rec.jacobian.copy()) for rec in lin]
    for name, (_, cols) in knees.items():
        h = np.concatenate([c / s for c, s in zip(cols, scales)], axis=0)
        u0 = basis(np.column_stack([j0, h[:, -1]]))  # beside the model and the input's linear part
        r0 = perp(u0, rw)
        h = h[:, :-1]
        hp = perp(u0, h)
        nn = (hp * hp).sum(axis=0)
        z2 = np.where(nn > 0, (hp.T @ r0) ** 2 / np.where(nn > 0, nn, 1.0), -1.0)
        j = int(np.argmax(z2))
        for rec, c in zip(out, cols):
            rec.jacobian[:, sl[name].start] = c[:, j]
    return out


def _neg2_loglik(rec, design: np.ndarray, nz: NoiseSpec) -> float:
    """Profile −2 log-likelihood (without 2π) of a record's residual under the noise model ``nz`` with the regressors
    ``design`` estimated by GLS: exact for white + Gauss–Markov (:func:`gyrojax.noise.whiten.gm_profile`),
    conditional on each segment's first samples for AR(p), scaled to the record's length as the AR/GM choice of
    :func:`gyrojax.noise.whiten.fit_noise` scales it."""
    if nz.gauss_markov:
        return gm_profile(rec.residual, design, rec.labels, rec.times, nz)
    w, keep = whiten(np.column_stack([rec.residual, design]), rec.labels, nz, rec.times)
    e = w[:, 0] - w[:, 1:] @ np.linalg.lstsq(w[:, 1:], w[:, 0], rcond=None)[0]
    n, n_ar = len(rec.residual), max(len(keep), 1)
    return (n_ar * math.log(nz.innovation_std**2) + float(e @ e)) * (n / n_ar)


def colour_against_shape(lin, noises, cols0, cols_c, knee: str | None) -> float:
    """The colour judged against a shape by likelihood: BIC of the records under their coloured noise models
    ``noises`` with the regressors ``cols0`` (and a per-record offset) less BIC under white noise with the
    candidate's regressors ``cols_c`` added (−2 log-likelihood profiled over the regressors and, for white noise,
    its variance: n log(|e|²/n) + n; penalties log n per colour parameter — 2 for Gauss–Markov, p for AR(p) — and
    per shape coefficient, its knee included). Positive: white + shape explains the records better than colour
    alone, so the colour must not hide it."""
    m2_colour = m2_white = 0.0
    k_colour, n_all, k_shape = 0, 0, 0
    for rec, nz in zip(lin, noises):
        n = len(rec.residual)
        d0 = np.column_stack([rec.jacobian[:, cols0], _nuisance(rec.times)])
        xc = rec.jacobian[:, cols_c]
        xc = xc[:, np.abs(xc).max(axis=0) > 0]
        k_shape = max(k_shape, xc.shape[1])
        m2_colour += _neg2_loglik(rec, d0, nz)
        k_colour += 2 if nz.gauss_markov else int(nz.order or 0)
        d1 = np.column_stack([d0, xc])
        e = rec.residual - d1 @ np.linalg.lstsq(d1, rec.residual, rcond=None)[0]
        m2_white += n * math.log(max(float(e @ e) / n, 1e-300)) + n
        n_all += n
    k_shape += knee is not None
    return (m2_colour + k_colour * math.log(n_all)) - (m2_white + k_shape * math.log(n_all))


def correlation_time_s(nz: NoiseSpec) -> float:
    """The correlation time (s) of a noise model's colour: T of its Gauss–Markov term, or of an AR(p) colour
    −Δt / ln ρ, ρ the largest modulus of the roots of z^p − φ_1 z^(p−1) − … − φ_p (the slowest decay of its
    autocorrelation, e^(−kΔt/T) at lag k; −Δt / ln φ for AR(1)); 0 for white noise."""
    if nz.gauss_markov:
        return float(nz.gm_tau)
    if not nz.ar:
        return 0.0
    rho = float(np.max(np.abs(np.roots(np.concatenate([[1.0], -np.asarray(nz.ar, dtype=float)])))))
    if rho <= 0.0:
        return 0.0
    return math.inf if rho >= 1.0 else -float(nz.dt_s) / math.log(rho)


def median_segment_s(times: np.ndarray, labels: np.ndarray) -> float:
    """The median span (s) of a record's continuous segments (its static positions), first to last sample."""
    spans = [float(np.ptp(times[labels == k])) for k in np.unique(labels[labels >= 0])]
    return float(np.median(spans)) if spans else 0.0


def median_segment_samples(labels: np.ndarray) -> float:
    """The median number of samples of a record's continuous segments (its static positions)."""
    _, counts = np.unique(labels[labels >= 0], return_counts=True)
    return float(np.median(counts)) if counts.size else 0.0


def colour_unresolved(lin, noises) -> bool:
    """Whether some record's colour is not resolved by its positions, so that the colour and an effect that differs
    between positions leave the same levels: its median segment holds fewer than :data:`POSITION_SAMPLES` samples and
    spans (s) fewer than :data:`POSITION_CORRELATION_TIMES` correlation times (s, :func:`correlation_time_s`)."""
    return any(
        median_segment_samples(rec.labels) < POSITION_SAMPLES
        and correlation_time_s(nz) * POSITION_CORRELATION_TIMES > median_segment_s(rec.times, rec.labels)
        for rec, nz in zip(lin, noises)
        if nz.order
    )


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
    scales = [max(np.sqrt(np.mean(rec.residual**2)), 1e-300) for rec in lin]
    n_rec = len(lin)
    blocks = []
    for i, (rec, s) in enumerate(zip(lin, scales)):
        nu = np.zeros((len(rec.residual), n_rec))
        nu[:, i : i + 1] = _nuisance(rec.times)
        blocks.append(np.column_stack([rec.jacobian[:, cols] / s, nu]))
    r_all = np.concatenate([rec.residual / s for rec, s in zip(lin, scales)])
    ub = basis(np.concatenate(blocks, axis=0))
    res = perp(ub, r_all)
    bounds = np.cumsum([0] + [len(rec.residual) for rec in lin])

    def one(i):  # the records' fits are independent: they run side by side (gyrojax.runtime.threads.parallel_map)
        rec, s, st = lin[i], scales[i], starts[i]
        design = np.column_stack([rec.jacobian[:, cols], _nuisance(rec.times)])
        start = st if st is not None and st.gauss_markov else None
        r = res[bounds[i] : bounds[i + 1]] * s
        nz = fit_noise(r, rec.labels, rec.times, design=design, start=start, readout_var=readouts[i])
        return nz if nz.innovation_std > 0 else NoiseSpec.from_sample_variances(s * s, reml.sample_interval(rec.times))

    return parallel_map(one, range(n_rec))


def _score(lin, noises, res, full: Model, cand, knees=None) -> tuple:
    """Score statistic, p-value, estimate and residual-after of every candidate (:func:`gyrojax.inference.scoring.
    score_tests`), and the whitened residual and regressors they were computed on: (candidates, unexcited, X⊥ bases,
    (r̃, J̃)).

    On the tall whitened system itself, not on the triangle of its QR (:class:`gyrojax.inference.subspace.
    WhitenedSystem`), though the statistics are the same to rounding: exact aliases (D_II and D_SS in a 1 g tumble)
    have equal statistics to the last digits, which :func:`gyrojax.inference.scoring.by_evidence` then ranks in the
    conventions' order.

    A hinged candidate (``knees``: name -> its knee grid and slope regressors, :func:`_knee_grid`) is tested by the
    sup of its score over the knee, with that statistic's own null law (:func:`gyrojax.inference.knee.sup_score`),
    beside the model and the input's own linear part (a hinge is a change of slope, not a slope, which
    ``bias_temperature`` names); its one-step estimate is the slope change at the knee of the sup, and that knee."""
    model, p0, sl = res.model, res.model.size, full.slices()
    rw, jw = stack_whitened(lin, noises)
    residue = residue_columns(jw)  # floating-point residue (cos 90° = 6e-17): not excited, never estimated
    x_all = jw * ~residue
    cols = {c: np.arange(full.size)[sl[c]] for c in cand}
    tests = score_tests(rw, jw[:, :p0], [x_all[:, cols[c]] for c in cand])
    j_raw = np.concatenate([rec.jacobian for rec in lin], axis=0)
    raw = (
        np.concatenate([rec.residual for rec in lin]),
        j_raw[:, :p0],
        [j_raw[:, cols[c]] * ~residue[cols[c]] for c in cand],
    )
    effs = [fx.get(c) for c in cand]

    def aliases(spanned_by):  # the model's effects whose columns span the candidate
        return sorted({fx.effect_of_coefficient(model.coefficient_names[k]) for k in spanned_by}, key=model.terms.index)

    coefs, units = [e.coefficients for e in effs], [e.units for e in effs]
    scored, perps = candidates(cand, tests, coefs, units, raw, aliases, res.residual_rms)
    tested = [c for c in scored if c is not None]
    unexcited = [c for c, s in zip(cand, scored) if s is None]
    for i, c in enumerate(tested):
        if c.df > 0 and c.name in (knees or {}):
            tested[i], u = _sup_over_knee(c, lin, noises, rw, jw[:, :p0], knees[c.name])
            if u is not None:
                perps[c.name] = u
    return tested, unexcited, perps, (rw, jw)


def _sup_over_knee(c: Candidate, lin, noises, rw, j0w, knee_grid) -> tuple:
    """The hinged candidate ``c`` tested by the sup of its score over the knee grid (:func:`_score`): (the
    candidate, the basis of its projected slope regressor at the knee of the sup)."""
    knees, cols = knee_grid
    _, hw = stack_whitened([rec._replace(jacobian=h) for rec, h in zip(lin, cols)], noises)
    u0 = basis(np.column_stack([j0w, hw[:, -1]]))  # a change of slope: beside the model and the input's linear part
    hw = hw[:, :-1]
    r_perp, sigma2, _ = residual_variance(u0, rw)
    out = sup_score(u0, r_perp, hw, sigma2)
    if out is None:
        return c, None
    stat, j, lp, _ = out
    hp = perp(u0, hw[:, j])
    eff = fx.get(c.name)
    slope = float(hp @ r_perp) / float(hp @ hp)
    est = {eff.coefficients[0]: {"value": slope, "unit": eff.units[0]}}
    est[eff.coefficients[1]] = {"value": float(knees[j]), "unit": eff.units[1]}
    c = replace(c, statistic=stat, p_value=10.0**lp, log10_p=lp, estimate=est)
    return c, (hp / math.sqrt(float(hp @ hp)))[:, None]


def _drift_reading(name: str, camp: Campaign, lin, full: Model, p0: int) -> tuple[float, dict]:
    """The reading of a significant slow candidate with the drift re-fitted beside it: the p-value of its Wald test
    and its GLS estimate ± the standard error `fit` would state."""
    cols_c = np.arange(full.size)[full.slices()[name]]
    p, beta, sd = wald_beside_drift(camp, lin, np.concatenate([np.arange(p0), cols_c]), p0)
    eff = fx.get(name)
    est = zip(eff.coefficients, beta, sd, eff.units)
    return p, {n: {"value": float(v), "std": float(e), "unit": u} for n, v, e, u in est}


def wald_beside_drift(camp: Campaign, lin, cols: np.ndarray, p0: int, keep_drift: bool = False):
    """(p-value, estimate, standard error) of the coefficients ``cols[p0:]`` by GLS with the fit's noise model
    re-estimated with them in (:func:`gyrojax.inference.noisefit.campaign_noise`; ``keep_drift``: its Gauss–Markov
    part kept even where the REML cannot tell it from white noise); Wald W / k ~ F(k, ν), ν the smallest
    Satterthwaite degrees of freedom of those coefficients when the noise has a Gauss–Markov part."""
    sub = [rec._replace(jacobian=rec.jacobian[:, cols]) for rec in lin]
    noises = campaign_noise(sub, camp, keep_drift=keep_drift)
    scales = [noise_scale(rec.residual, rec.labels) for rec in sub]
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
    return float(f_sf(stat / k, k, float(np.min(nus[ok])))), beta, sd * small_sample_factor(nus)


def _colour_candidate(noises, lin, alpha: float = ALPHA, p0: int = 0) -> Candidate | None:
    """Likelihood-ratio test of the AR noise model against white noise, pooled over records.

    A servo record whose readout noise is known (:mod:`gyrojax.noise.readout`) is tested by the REML likelihood
    ratio of its white + Gauss–Markov rate noise against white rate noise, both beside the readout (the first ``p0``
    columns of J the fitted regressors): colour is then that of the rate, never the readout's MA(1) increments."""
    stat, df, rms_acc, n_acc = 0.0, 0, 0.0, 0
    for nz, rec in zip(noises, lin):
        r, lab, t = rec.residual, rec.labels, rec.times
        n = len(r)
        if nz.gauss_markov and nz.readout_var > 0:
            if nz.gm_variance > 0:
                design = np.column_stack([rec.jacobian[:, :p0], np.ones(n)])
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
    rms = float(math.sqrt(rms_acc / max(n_acc, 1)))
    order = {"ar_order": {"value": df, "unit": "-"}}
    return Candidate("gauss_markov", stat, df, p, p, [], rms, order, log10_p=logp / math.log(10))
