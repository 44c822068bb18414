"""What a diagnosis answers, for every instrument: the candidates it tested, the residual structure no named effect
explains, the verdict, and one step of the main loop (add an effect, refit, diagnose again). Frozen results, built
whole by :mod:`gyrojax.inference.diagnose`; ``to_json`` is the diagnosis JSON of conventions §7."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

from gyrojax.errors import ModelError

POWERS = {1: "linear", 2: "quadratic", 3: "cubic", 4: "quartic"}
"""Names of the powers of an input among the model-free shapes."""


@dataclass(frozen=True)
class Candidate:
    """One effect (or noise process) the model lacks, with the evidence for it: the test statistic and p-values
    (dimensionless), the residual RMS after adding it (deg/h for gyros, g for accelerometers), and its estimate in
    report units."""

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
    indistinguishable: list = field(default_factory=list)  # near-aliases within the test's critical difference
    refused: str | None = None  # why the fit refuses the model with this candidate added (never proposed then)
    implausible: str | None = None  # sizes beyond what real instruments have (gyrojax.physics.plausibility)
    rms_after_refit: bool = False  # rms_after is the fit's own after adding the candidate (else the one-step value)
    p_drift_refitted: float | None = None  # slow candidates: p of the Wald test with the drift re-fitted beside them
    refit: tuple | None = field(default=None, repr=False, compare=False)  # (records, fit) of the vetting refit

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


@dataclass(frozen=True)
class Structure:
    """Residual structure that no named effect explains: one model-free shape of the test family.

    ``name`` what the report calls it (``rate_cross[z]``, ``a_I: cubic``), ``versus`` the input it is a shape of,
    ``shape`` its form, ``description`` one line on it; ``statistic`` ~ χ²(``df``) (or ``df`` · F) under "no such
    structure". ``estimate``/``std`` (single-column shapes of an instrument input) are the coefficient the shape
    would get if added to the model alone, in ``unit`` (output unit per unit of ``expression``); ``expression`` is
    what to give ``--effect NAME=EXPR`` to model it; ``same_as`` the inputs through which the same structure shows.
    """

    name: str
    versus: str
    shape: str
    statistic: float
    df: int
    p_value: float
    log10_p: float
    p_adjusted: float = 1.0
    description: str = ""
    expression: str | None = None
    estimate: float | None = None
    std: float | None = None
    unit: str | None = None
    same_as: list = field(default_factory=list)

    def to_json(self) -> dict:
        """One entry of ``unexplained`` in the diagnosis JSON."""
        out = {
            "name": self.name,
            "versus": self.versus,
            "shape": self.shape,
            "description": self.description or self.line,
            "statistic": float(self.statistic),
            "df": int(self.df),
            "p_value": float(self.p_value),
            "p_adjusted": float(self.p_adjusted),
            "log10_p": float(self.log10_p),
            "same_as": list(self.same_as),
        }
        if self.expression is not None:
            out["expression"] = self.expression
            out["effect_option"] = f"--effect '{self.suggested_name}={self.expression}'"
        if self.estimate is not None:
            out["estimate"] = {"value": float(self.estimate), "std": float(self.std), "unit": self.unit}
        return out

    @property
    def line(self) -> str:
        """The report line: "residual structure vs a_I that no named effect explains: cubic"."""
        extra = f" (also seen vs {', '.join(self.same_as)})" if self.same_as else ""
        return f"residual structure vs {self.versus} that no named effect explains: {self.shape}{extra}"

    @property
    def suggested_name(self) -> str:
        """A coefficient name for an ``--effect`` modelling this structure (``U_a_I_3`` for a_I³)."""
        base = self.versus.replace(" ", "_")
        power = {v: k for k, v in POWERS.items()}.get(self.shape)
        return f"U_{base}_{power}" if power else f"U_{base}_{self.shape.replace(' ', '_').replace('|', 'abs')}"


@dataclass(frozen=True)
class Diagnosis:
    """Verdict, ranked candidates and the fit they were tested against, at the family-wise level ``alpha``.

    ``unexplained``: the significant :class:`Structure` s, strongest first; ``proposal``: the effect to add
    (significant, accepted by the fit, plausible) or None; ``tests``: the size of the multiple-comparison family
    (named candidates and shapes); ``noise_processes``: the noise the residual shows beyond the fit's noise model
    (colour, a bias scatter between poses …), tested by likelihood ratio and never proposed; ``chi2_components``
    and ``dof``: the χ² of the fit's rows whitened with the noise processes, where the instrument has such rows.
    """

    verdict: str
    fit: object
    candidates: list
    alpha: float
    unexcited: list = field(default_factory=list)
    unexplained: list = field(default_factory=list)
    proposal: str | None = None
    tests: int = 0
    noise_processes: list = field(default_factory=list)
    chi2_components: float | None = None
    dof: int | None = None

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
        fit = self.fit.to_json()
        out = {
            "verdict": self.verdict,
            "residual_rms_deg_per_h": self.residual_rms,
            "noise_floor_deg_per_h": self.noise_floor,
            "candidates": [c.to_json() for c in self.candidates],
            "terms": list(self.fit.terms),
            "alpha": self.alpha,
            "not_excited": list(self.unexcited),
            "unexplained": [s.to_json() for s in self.unexplained],
            "proposal": self.proposal,
            "family_size": self.tests,
            "fit": fit,
            "instrument": fit["instrument"],
            "noise_processes": [c.to_json() for c in self.noise_processes],
        }
        if self.chi2_components is not None:
            out["chi2_with_components"] = {"chi2": self.chi2_components, "dof": self.dof}
        return out


def effect_to_add(d: Diagnosis, effect: str | None = None) -> str:
    """The effect an add-and-refit step adds: ``effect`` when given, else the diagnosis' proposal; with neither,
    a :class:`ModelError` naming the first unexplained structures (or saying the model is adequate)."""
    if effect is not None:
        return effect
    if d.proposal is None:
        found = [s.line for s in d.unexplained[:3]]
        raise ModelError(f"no named effect to add: {'; '.join(found) or 'the model is adequate for these records'}")
    return d.proposal


class Step(NamedTuple):
    """One step of the main loop: the ``terms`` with the ``added`` effect, their ``fit`` and its ``diagnosis``.
    Unpacks as ``terms, fit, diagnosis, added``."""

    terms: tuple
    fit: object
    diagnosis: Diagnosis
    added: str
