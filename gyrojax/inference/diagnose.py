"""Diagnosis: see where the model fails and learn which named effect is missing — one loop for every instrument.

The records' instrument chooses its plug-in (turntable records: :mod:`gyrojax.inference.turntable_diagnosis`;
``imu-triad`` records: :mod:`gyrojax.inference.triad_diagnosis`), which says what its candidates, noise and shapes
are. The loop itself is the same for all:

1. **Noise by forward selection.** Every candidate is score-tested at the current fit
   (:func:`gyrojax.inference.scoring.score_tests`) under the plug-in's noise model; the most significant one
   (Bonferroni) is taken among the fixed effects of the noise fit and the noise re-estimated, until none is
   significant or the next adds nothing new (:func:`gyrojax.inference.scoring.spanned`): a strong missing effect then
   does not pass for coloured noise, and colour does not pass for an effect. When none is significant under the
   colour, the colour is judged against the candidates that follow a slowly varying recorded input (temperature) by
   likelihood — white noise with the candidate against the colour alone (the plug-in's ``outweighs_colour``) — and
   the one that wins, if it also holds beside the colour re-fitted with it, is taken: a colour never hides what an
   input explains, and an input never takes what one realisation of slow drift drew. Where the records' positions hold a
   few samples each and the colour's memory spans them (they cannot tell it from an offset per position), every
   candidate is judged so: a colour never hides an effect that differs between positions either. Taking changes
   only the noise model the candidates are tested under; a taken candidate is proposed only if its test then says
   so.
2. **Aliases**: candidates whose projected regressors are collinear (:func:`gyrojax.inference.scoring.alias_pairs`).
3. **One family**: the named candidates and the model-free shapes the plug-in tests beside them
   (:class:`gyrojax.inference.verdict.Structure`) are adjusted together by Holm
   (:func:`gyrojax.inference.scoring.holm_log10`); the verdict is ``missing-effect`` when any adjusted p-value is
   below α (:data:`gyrojax.inference.scoring.ALPHA` by default).
4. **Proposal** (:func:`propose`): the significant candidates in rank order, each refitted exactly as the fit would
   add it, the first that the fit accepts, whose size is plausible and that holds — still significant beside every
   stronger significant candidate (refused ones included) and every significant unexplained shape
   (:func:`does_not_hold`); where instruments differ in this walk, the plug-in's
   :class:`~gyrojax.inference.instrument.Rules` say how.
5. **Noise processes** beyond the fit's noise model (colour, a bias scatter between poses …), tested by likelihood
   ratio and never proposed.

:func:`add_and_refit` is one step of the main loop: add the proposal (or a given effect), refit, diagnose again.
"""

from __future__ import annotations

import math
from dataclasses import replace

from gyrojax.data.record import Record
from gyrojax.errors import ModelError
from gyrojax.inference.campaign import Campaign
from gyrojax.inference.identify import fit
from gyrojax.inference.scoring import ALPHA, alias_pairs, by_evidence, holm_log10, spanned
from gyrojax.inference.triad import is_triad_input
from gyrojax.inference.triad_diagnosis import TriadSession
from gyrojax.inference.turntable_diagnosis import TurntableSession
from gyrojax.inference.verdict import Diagnosis, Step, effect_to_add
from gyrojax.runtime.threads import narrow_blas

MAX_NOISE_ROUNDS = 4
"""Rounds of the forward selection of the noise model at most."""


def session(
    records, terms=None, *, candidates=None, result=None, campaign=None, earth_rate=None, model_free=True, alpha=ALPHA
):
    """The plug-in of the records' instrument at the fit ``result`` (default: the fit of ``terms``; ``earth_rate`` as
    the triad fit takes it, a bool: dimensionless; ``alpha`` the level of the noise processes it whitens with); an
    option the instrument has no use for is refused, never dropped."""
    if campaign is None and is_triad_input(records):
        return TriadSession.of(records, terms, result, candidates, earth_rate, model_free, alpha)
    if earth_rate is not None:
        raise ModelError(
            "earth_rate applies to imu-triad records; the Earth rate of a turntable record follows its site "
            "(JSON key site.latitude_deg)"
        )
    return TurntableSession.of(records, terms, result, campaign, candidates)


@narrow_blas
def diagnose(
    records,
    terms=None,
    *,
    alpha: float = ALPHA,
    candidates=None,
    result=None,
    campaign: Campaign | None = None,
    suggest_tests: bool = True,
    model_free: bool = True,
    plausible: dict | None = None,
    earth_rate: bool | None = None,
    vet: bool = True,
) -> Diagnosis:
    """Rank the effects the model ``terms`` is missing, from the data of ``records`` (module doc).

    Args:
      records: records of one instrument (turntable records of any plans and modes, or ``imu-triad`` records).
      terms: the current model (effect names; on a triad, applied to every channel); default as
        :func:`gyrojax.inference.identify.fit`.
      alpha: family-wise significance level for the verdict (dimensionless).
      candidates: effect names to test (default: every named effect not in the model that the records can carry).
      result: a fit of ``terms`` to these records, if already at hand.
      campaign: turntable records already built into a :class:`gyrojax.inference.campaign.Campaign`, if at hand.
      suggest_tests: name built-in plans that would separate aliased candidates (turntable records).
      model_free: also test the residual against model-free shapes (:mod:`gyrojax.inference.adequacy`, and the
        triad's shapes); the family of the multiple-comparison control then holds the named candidates and the shapes.
      plausible: overrides of the plausible sizes (:mod:`gyrojax.physics.plausibility`), by coefficient or effect name.
      earth_rate: ``imu-triad`` records: override the records' ``earth_rate``, as the triad fit takes it.
      vet: refit with each significant candidate in rank order, as the fit would add it, before proposing it
        (False: propose on the one-step estimates).

    Returns: a :class:`~gyrojax.inference.verdict.Diagnosis` with ``verdict`` ``"missing-effect"`` or
    ``"adequate"``; residuals and noise floor in the output unit (deg/h for gyros, g for accelerometers), candidate
    estimates in report units.
    """
    s = session(
        records,
        terms,
        candidates=candidates,
        result=result,
        campaign=campaign,
        earth_rate=earth_rate,
        model_free=model_free,
        alpha=alpha,
    )
    rnd, taken = select_noise(s, alpha)

    # aliases between candidates: collinear projected regressors
    tested = {c.name: c for c in rnd.candidates}
    for a, b in alias_pairs({n: rnd.perps[n] for n in tested if n in rnd.perps}):
        tested[a] = replace(tested[a], aliases=[*tested[a].aliases, b])
        tested[b] = replace(tested[b], aliases=[*tested[b].aliases, a])
    live = [n for n, c in tested.items() if c.df > 0]
    ranked = [c.name for c in by_evidence(list(tested.values()), s.kind)]

    # one Holm family of candidates and shapes; shapes a barred candidate would have hidden are tested again
    explaining = s.explaining([tested[n] for n in live], alpha)
    near: dict = {}
    for _round in range(2 if s.rules.retest_shapes else 1):
        shapes = s.structure(rnd, explaining) if model_free else []
        adj = holm_log10([tested[n].log10_p for n in live] + [x.log10_p for x in shapes])
        for n, a in zip(live, adj):
            tested[n] = replace(tested[n], p_adjusted=float(10.0**a))
        shapes = [replace(x, p_adjusted=float(10.0**a)) for x, a in zip(shapes, adj[len(live) :])]
        sig = {n for n, a in zip(live, adj) if a < math.log10(alpha)}
        significant = [n for n in ranked if n in sig]
        unexplained = sorted(
            [x for x, a in zip(shapes, adj[len(live) :]) if a < math.log10(alpha)], key=lambda x: x.log10_p
        )
        family = len(live) + len(shapes)
        proposal, tested = propose(s, rnd, tested, significant, alpha, plausible, vet, near, (unexplained, family))
        barred = {n for n in significant if tested[n].refused or tested[n].implausible}
        if not barred & set(explaining):
            break
        explaining = [n for n in explaining if n not in barred]

    verdict = "missing-effect" if significant or unexplained else "adequate"
    noise = s.noise_processes(rnd, taken, alpha)
    ranked_c = s.finish(rnd, [tested[n] for n in ranked], significant, family, alpha, noise, suggest_tests)
    chi2, dof = s.components_chi2(rnd)
    return Diagnosis(verdict, s.fit, ranked_c, alpha, rnd.unexcited, unexplained, proposal, family, noise, chi2, dof)


def select_noise(s, alpha: float) -> tuple:
    """The forward selection of the noise model (module doc, step 1): (the last round of score tests, the names
    taken among the fixed effects of the noise fit)."""
    rnd, taken = None, []
    for _round in range(MAX_NOISE_ROUNDS):
        rnd = s.score(taken, rnd)
        live = [c for c in s.selectable(rnd) if c.df > 0]
        if not live:
            break
        best = by_evidence(live, s.kind)[0]
        if best.log10_p + math.log10(len(live)) < math.log10(alpha) and not spanned(rnd.perps, best.name, taken):
            taken.append(best.name)
            continue
        follows = s.outweighs_colour(rnd, taken, alpha)
        if follows is None:
            break
        taken.append(follows)
    return rnd, taken


def propose(s, rnd, tested: dict, significant: list, alpha: float, plausible, vet: bool, near: dict, held=((), 1)):
    """The proposal and the candidates after the walk (module doc, step 4): (effect to add or None, ``tested`` with
    each significant candidate's near-aliases, refusal, refit and plausibility set).

    A proposal must hold: ``held`` = (the significant unexplained shapes, the family size); a candidate is proposed
    only when its score test beside every stronger significant candidate (refused and implausible ones included)
    and every such shape (:meth:`~gyrojax.inference.instrument.Session.beside`) stays significant at the family's
    first Holm step, α / m; else it is marked ``refused`` with the names that explain it.

    For the significant candidates in rank order: their near-aliases (``indistinguishable``, kept in ``near`` across
    the rounds of one diagnosis); a refit with the candidate added, exactly as the fit would add it, so that a
    candidate the fit refuses is marked ``refused`` with the fit's reason; and the sizes against
    :mod:`gyrojax.physics.plausibility` (``implausible``). The first candidate that passes is the proposal. The
    plug-in's rules bound the refits (``refit_budget``, counted across the rounds), pass over aliased candidates
    (``skip_aliased``) and judge the size before the refit (``plausible_before_refit``)."""
    rules = s.rules
    out = dict(tested)
    todo = [n for n in significant if n not in near and out[n].df > 0]
    if todo:
        near.update(s.near_aliases(rnd, todo, alpha))
    refits = sum(1 for n in significant if out[n].refit is not None or out[n].refused)
    proposal = None
    for n in significant:
        c = out[n]
        c = replace(c, indistinguishable=[d for d in near.get(n, []) if d not in c.aliases])
        if rules.plausible_before_refit:
            c = replace(c, implausible=s.implausible(c, plausible))
        eligible = not (rules.skip_aliased and c.aliases) and not (rules.plausible_before_refit and c.implausible)
        budget = rules.refit_budget is None or refits < rules.refit_budget
        if proposal is None and eligible and c.refused is None and c.refit is None:
            why = s.no_term(c) or does_not_hold(s, rnd, c, significant[: significant.index(n)], held, alpha)
            if why is not None:
                c = replace(c, refused=why)
            elif vet and budget:
                refits += 1
                try:
                    c = s.with_refit(c, s.refit(c))
                except ModelError as e:
                    c = replace(c, refused=s.refusal(e))
        if not rules.plausible_before_refit:
            c = replace(c, implausible=s.implausible(c, plausible))
        if proposal is None and eligible and c.refused is None and c.implausible is None:
            if c.refit is not None or not vet:
                proposal = s.effect_of(c)
        out[n] = c
    for n, c in out.items():
        if n not in significant and c.df > 0:
            out[n] = replace(c, implausible=s.implausible(c, plausible))
    return proposal, out


def does_not_hold(s, rnd, c, stronger: list, held: tuple, alpha: float) -> str | None:
    """Why candidate ``c`` is not significant beside the ``stronger`` candidates and the unexplained shapes of
    ``held`` (:func:`propose`), or None when it holds (or the plug-in cannot tell)."""
    shapes, family = held
    if not stronger and not shapes:
        return None
    log10_p = s.beside(rnd, c.name, stronger, list(shapes))
    if log10_p is None or log10_p + math.log10(max(family, 1)) < math.log10(alpha):
        return None
    what = ", ".join([*stronger, *(x.name for x in shapes)])
    return f"not significant beside {what} (p {10.0**log10_p:.2g} before adjustment): they explain it"


def fit_with(d: Diagnosis, records, effect: str | None = None, campaign: Campaign | None = None, earth_rate=None):
    """The fit of the diagnosed model with ``effect`` added (default: the proposal,
    :func:`~gyrojax.inference.verdict.effect_to_add`), exactly the fit the diagnosis computed when it vetted that
    candidate on the same records (:func:`propose`), else a new fit (:func:`gyrojax.inference.identify.fit`,
    aliases refused; ``earth_rate`` as it takes it). The main loop's next step then costs one fit less. Coefficients
    in report units."""
    effect = effect_to_add(d, effect)
    recs = campaign.records if campaign is not None else [records] if isinstance(records, Record) else list(records)
    for c in d.candidates:
        if c.refit is not None and (c.name == effect or c.name.startswith(effect + "[")):
            done_on, res = c.refit
            if len(done_on) == len(recs) and all(a is b for a, b in zip(done_on, recs)):
                return res
    terms = tuple(d.fit.terms) + (effect,)
    return fit(recs, terms, campaign=campaign, allow_aliases=False, earth_rate=earth_rate)


@narrow_blas
def add_and_refit(records, terms=None, effect: str | None = None, *, diagnosis: Diagnosis | None = None, **kw) -> Step:
    """Add ``effect`` (default: the diagnosis' proposal) to ``terms``, refit, and diagnose again: a
    :class:`~gyrojax.inference.verdict.Step`, which unpacks as ``(new_terms, new_fit, new_diagnosis, added)``.
    ``kw``: the options of :func:`diagnose` (``campaign``, ``earth_rate`` … included)."""
    if isinstance(records, Campaign):
        kw = {**kw, "campaign": records}
        records = records.records
    if kw.get("campaign") is None and not is_triad_input(records):
        kw = {**kw, "campaign": Campaign.of(records)}
    recs = kw["campaign"].records if kw.get("campaign") is not None else records
    d = diagnosis or diagnose(recs, terms, **kw)
    effect = effect_to_add(d, effect)
    new_terms = tuple(d.fit.terms) + (effect,)
    new_fit = fit_with(d, recs, effect, campaign=kw.get("campaign"), earth_rate=kw.get("earth_rate"))
    return Step(new_terms, new_fit, diagnose(recs, new_terms, result=new_fit, **kw), effect)
