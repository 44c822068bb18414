"""An instrument as the diagnosis sees it: the plug-in interface of :func:`gyrojax.inference.diagnose.diagnose`.

A plug-in holds one instrument's records at a fit — turntable records
(:class:`gyrojax.inference.turntable_diagnosis.TurntableSession`) or ``imu-triad`` records
(:class:`gyrojax.inference.triad_diagnosis.TriadSession`) — and answers the loop's questions: the score tests of its
candidates under its noise model with some candidates taken among the fixed effects (:meth:`Session.score`), the
shapes no candidate explains, the refit that vets a proposal, the plausibility of sizes, and the noise processes
beyond the fit's noise model. What every instrument answers alike is written here once, as the defaults.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from gyrojax.errors import ModelError
from gyrojax.inference.verdict import Candidate


@dataclass(frozen=True)
class Rules:
    """How an instrument's diagnosis walks from its significant candidates to a proposal, where instruments differ
    (:func:`gyrojax.inference.diagnose.propose`): ``retest_shapes`` — the shapes a refused or implausible candidate
    would have hidden are tested again without it; ``refit_budget`` — significant candidates refitted at most (None:
    every one, until one is accepted); ``skip_aliased`` — a candidate with statistical aliases is passed over;
    ``plausible_before_refit`` — its size is judged on the one-step estimate, before any refit (else on the refit's)."""

    retest_shapes: bool
    refit_budget: int | None
    skip_aliased: bool
    plausible_before_refit: bool


class Session:
    """The plug-in interface (module doc). A plug-in defines ``fit`` (the fit under diagnosis), ``records``,
    ``kind`` (the registry's kind: the order of exact aliases), ``rules`` (:class:`Rules`), :meth:`score`,
    :meth:`implausible` and :meth:`fit_terms`; the other answers default to those below.

    A round of :meth:`score` is an object with ``candidates`` (the named candidates tested, spanned ones with df 0),
    ``unexcited`` (names) and ``perps`` (name -> orthonormal basis of the candidate's projected regressors)."""

    def score(self, taken: list, previous):
        """The score tests of every candidate under the noise model re-estimated with the candidates ``taken``
        among the fixed effects (``previous``: the last round, or None)."""
        raise NotImplementedError

    def selectable(self, rnd) -> list:
        """What competes to be taken into the noise fit: the named candidates."""
        return rnd.candidates

    def outweighs_colour(self, rnd, taken: list, alpha: float) -> str | None:
        """A candidate that explains the records better with white noise than the colour of ``rnd`` does without
        it, where the colour could hide it (one that follows a slowly varying input; any, where the records cannot
        resolve the colour), to be taken among the fixed effects of the noise fit before the colour hides it; None
        (the default: an instrument whose noise has no colour to judge)."""
        return None

    def explaining(self, live: list, alpha: float) -> list[str]:
        """The candidates that may explain a shape: every candidate tested."""
        return [c.name for c in live]

    def structure(self, rnd, explaining: list) -> list:
        """The model-free shapes no candidate of ``explaining`` explains, unadjusted (none by default)."""
        return []

    def near_aliases(self, rnd, names: list, alpha: float) -> dict:
        """The candidates each of ``names`` cannot be told from at level ``alpha`` (none by default)."""
        return {}

    def beside(self, rnd, name: str, stronger: list, shapes: list):
        """log10 p of the score test (:func:`gyrojax.inference.scoring.score_beside`) of candidate ``name`` beside the
        candidates ``stronger`` and the :class:`~gyrojax.inference.verdict.Structure` s ``shapes`` (0: nothing of it
        is left beside them), or None where the instrument cannot form it (the candidate is then judged alone)."""
        return None

    def no_term(self, c: Candidate) -> str | None:
        """Why the fit has no term for ``c``'s effect, or None when it has."""
        return None

    def refit(self, c: Candidate):
        """The fit with ``c``'s effect added, exactly as the fit would add it (:class:`ModelError` when it refuses)."""
        return self.fit_terms(tuple(self.fit.terms) + (self.effect_of(c),))

    def with_refit(self, c: Candidate, f) -> Candidate:
        """``c`` after the fit accepted it: the refit kept for the next step of the main loop."""
        return replace(c, refit=(tuple(self.records), f))

    def refusal(self, e: ModelError) -> str:
        """Why the fit refuses a candidate."""
        return str(e)

    def implausible(self, c: Candidate, overrides) -> str | None:
        """Sizes of ``c`` beyond what real instruments have (:mod:`gyrojax.physics.plausibility`), or None."""
        raise NotImplementedError

    def effect_of(self, c: Candidate) -> str:
        """The effect a candidate adds to the model."""
        return c.name

    def fit_terms(self, terms):
        """The fit of ``terms`` to the session's records (the next step of the main loop)."""
        raise NotImplementedError

    def noise_processes(self, rnd, taken: list, alpha: float) -> list:
        """Noise beyond the fit's noise model, significant at ``alpha`` (none by default)."""
        return []

    def components_chi2(self, rnd) -> tuple:
        """χ² and degrees of freedom of the fit's rows whitened with the noise processes (None, None: no such rows)."""
        return None, None

    def finish(
        self, rnd, ranked: list, significant: list, family: int, alpha: float, noise: list, suggest_tests: bool
    ) -> list:
        """The candidates as reported, from the ranked ones (as they are by default)."""
        return ranked
