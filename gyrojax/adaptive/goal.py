"""The goal of a test campaign and its error budget.

**Goal.** A target standard error per coefficient, in the coefficient's report unit (conventions §6): one σ for
every coefficient of the final model (``sigma``), and/or per coefficient (``targets``), plus the *watched*
candidates — the effects the campaign must be able to see when it does not add them (default :data:`WATCH`, the
instrument's drift model). The goal is met when the diagnosis finds nothing missing, every coefficient of the model
has its fitted σ at or below its target, and no watched candidate outside the model could hide at a size that
matters.

**Sizes that matter.** A candidate c whose σ, were it added, is σ_c has score-test noncentrality (δ/σ_c)² at true
size δ, so the diagnosis at level α detects it with power P once |δ| ≥ √λ*(α, P)·σ_c, with λ* the noncentrality at
which a χ²₁ test at level α has power P (:func:`noncentrality_for_power`). The size that matters is by default the
largest size real instruments have (:mod:`gyrojax.physics.plausibility`): the worst case over the plausible sizes
is that every one of them, down to ``detect`` (a size in report units, per coefficient or for all), is detected
with power P, i.e. σ_c ≤ detect/√λ*. A candidate the records do not excite, or cannot tell from the model (σ_c =
∞), could hide at any plausible size: the next test must make it visible. By default the loop does not try to rule
out candidates smaller than plausible sizes: that is the precision goal's job once they are in the model.

**Many tests in one look.** A look tests every candidate and model-free shape together (Holm at the look's level):
a lone missing candidate among m tests is declared once its p-value is below α/m, Holm's first step
(:func:`detect_level`). The sizes that matter are read at that level, so the stated power is the least the look
has, not that of a single test at α.

**Error budget over the campaign.** Every diagnosis of the campaign is a look at the data for a missing effect;
look j (1, 2, …) tests at the family-wise level α_j = α/(j(j+1)) (Holm over the candidates within the look,
:func:`gyrojax.diagnose`), an alpha-spending rule whose levels sum to α (Σ 1/(j(j+1)) = 1). By the union bound
the probability that the campaign ever adds an effect the instrument does not have is at most α, however many
tests it runs and however the looks depend on each other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from gyrojax import tails
from gyrojax.data.triad import CHANNELS
from gyrojax.errors import ModelError
from gyrojax.physics import effects as fx
from gyrojax.physics import plausibility

WATCH = {
    fx.SDF: ("D_F", "D_I", "D_O", "D_S", "D_II", "D_SS", "D_IO", "D_IS", "D_OS"),
    fx.TDF: tuple(f"D{c}_{t}" for c in "XY" for t in ("F", "X", "Y", "Z", "XX", "YY", "XY", "XZ", "YZ")),
    fx.ACCEL: ("K_0", "K_1", "K_2", "K_3", "K_IP", "K_IO"),
    fx.FOG: ("D_F",),
    fx.RLG: ("D_F",),
}
"""The watched candidates of each kind: the drift model Hu 2-45 (SDF), 2-46 (TDF, per channel) and the
accelerometer's 3-38. At 1 g, a_I² + a_O² + a_S² = 1, so one squared term aliases D_F and the other two in every
test on the ground: D_OO (SDF) and the spin-axis terms DX_ZZ, DY_ZZ (TDF) are left out, as the classical plans do."""

DETECT_MULTIPLE = 10.0
"""The default size that matters of a watched candidate, in units of its coefficient's target σ."""
POWER = 0.9
"""Detection power at the smallest size that matters."""
ALPHA = 0.05
"""The campaign-wide probability of adding an effect the instrument does not have (default)."""
MARGIN = 0.95
"""Designs aim at σ ≤ MARGIN·target, so that the fitted σ (an estimate, a few % from its prediction) meets the
target without a top-up test."""


def _base(coefficient: str) -> str:
    """The coefficient name of a triad channel's coefficient (``D_F`` of ``D_F[x]``); any other name unchanged."""
    head, bracket, rest = coefficient.partition("[")
    return head if bracket and rest[:-1] in CHANNELS and rest.endswith("]") else coefficient


def look_alpha(look: int, alpha: float = ALPHA) -> float:
    """The family-wise level of the campaign's ``look``-th diagnosis (1, 2, …): α/(look·(look+1)); the levels of
    all looks sum to ``alpha`` (module doc)."""
    if look < 1:
        raise ModelError(f"looks are counted from 1, got {look}")
    return alpha / (look * (look + 1))


def noncentrality_for_power(alpha: float, power: float = POWER, df: int = 1) -> float:
    """λ* at which the χ²_df test at level ``alpha`` has power ``power``: P(χ²_df(λ*) > χ²_{df,1−α}) = power."""
    from scipy import optimize

    return float(optimize.brentq(lambda lam: tails.score_power(lam, df, alpha) - power, 1e-9, 1e4))


def detect_level(alpha: float, family: int) -> float:
    """The level at which a look at family-wise level ``alpha`` tests a lone missing candidate among ``family``
    tests: Holm's first step, α/m. Its power is the least the look has for that candidate (later steps are at
    α/(m − k)), so sizes that matter read at this level are detected with at least the stated power."""
    if family < 1:
        raise ValueError(f"a Holm family has at least one test, got {family}")
    return alpha / family


def detection_power(size: float, sigma: float, alpha: float) -> float:
    """Power of the χ²₁ score test at level ``alpha`` for an effect of ``size`` whose σ, were it added, is
    ``sigma`` (same unit): noncentrality (size/σ)²."""
    if not math.isfinite(sigma) or sigma <= 0:
        return alpha if math.isinf(sigma) else 1.0
    return tails.score_power((size / sigma) ** 2, 1, alpha)


@dataclass(frozen=True)
class Goal:
    """What the campaign must reach: σ targets in report units and the watched candidates (module doc)."""

    sigma: float | None = None
    targets: dict = field(default_factory=dict)
    watch: tuple | None = None
    detect: float | dict | None = None
    alpha: float = ALPHA
    power: float = POWER
    margin: float = MARGIN

    def __post_init__(self):
        if self.sigma is not None and not (math.isfinite(self.sigma) and self.sigma > 0):
            raise ModelError(f"goal: key 'sigma' must be a finite number > 0, got {self.sigma!r}")
        index = fx.coefficient_index()
        for name, value in self.targets.items():
            if _base(name) not in index:
                raise ModelError(
                    f"goal: key 'targets.{name}' is not a coefficient name (conventions §6), nor one of an imu-triad "
                    "channel (D_F[x], E_SF[y], …)"
                )
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ModelError(f"goal: key 'targets.{name}' must be a finite number > 0, got {value!r}")
        if self.sigma is None and not self.targets:
            raise ModelError("goal: give a target σ ('sigma') or per-coefficient targets ('targets')")
        if not 0 < self.alpha < 1:
            raise ModelError(f"goal: key 'alpha' must lie in (0, 1), got {self.alpha!r}")
        if not 0 < self.power < 1:
            raise ModelError(f"goal: key 'power' must lie in (0, 1), got {self.power!r}")
        if not 0 < self.margin <= 1:
            raise ModelError(f"goal: key 'margin' must lie in (0, 1], got {self.margin!r}")
        for name in self.watch or ():
            if name not in fx.names():
                raise ModelError(f"goal: key 'watch': unknown effect {name!r}")
        sizes = self.detect.items() if isinstance(self.detect, dict) else [("", self.detect)]
        for name, value in sizes:
            if value is not None and not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ModelError(f"goal: key 'detect{'.' + name if name else ''}' must be a number > 0, got {value!r}")

    def target(self, coefficient: str) -> float | None:
        """Target σ of ``coefficient`` (report unit), None when the goal sets none. A triad channel's coefficient
        (``D_F[x]``) takes its own target, else that of its name on every channel (``D_F``), else ``sigma``."""
        if coefficient in self.targets:
            return self.targets[coefficient]
        return self.targets.get(_base(coefficient), self.sigma)

    def watched(self, kind: str) -> tuple:
        """The watched candidate effects for instruments of ``kind``."""
        names = self.watch if self.watch is not None else WATCH.get(kind, ())
        return tuple(n for n in names if kind in fx.get(n).kinds)

    def detect_size(self, coefficient: str, kind: str | None = None) -> float | None:
        """The size of ``coefficient`` (report unit) the campaign must detect were it there: ``detect`` (per
        coefficient or for all), else :data:`DETECT_MULTIPLE` times its target σ; at most its plausible limit
        (:func:`gyrojax.physics.plausibility.limit`); None when none of them is known (then it is not required)."""
        size = self.detect.get(coefficient) if isinstance(self.detect, dict) else self.detect
        if size is None and self.target(coefficient) is not None:
            size = DETECT_MULTIPLE * self.target(coefficient)
        lim = plausibility.limit(coefficient, kind=kind)
        if size is None:
            return lim
        return size if lim is None else min(size, lim)

    def detect_sigma(self, coefficient: str, alpha: float, kind: str | None = None) -> float | None:
        """σ_c at which the test at level ``alpha`` detects :meth:`detect_size` with power ``power``:
        size/√λ*(α, power) (module doc); None without a size."""
        size = self.detect_size(coefficient, kind)
        return None if size is None else size / math.sqrt(noncentrality_for_power(alpha, self.power))

    def to_json(self) -> dict:
        """The goal as JSON (report units)."""
        return {
            "sigma": self.sigma,
            "targets": dict(self.targets),
            "watch": list(self.watch) if self.watch is not None else None,
            "detect": self.detect if self.detect is not None else f"{DETECT_MULTIPLE:g} × target σ (at most plausible)",
            "alpha": self.alpha,
            "power": self.power,
            "margin": self.margin,
            "alpha_spending": "look j at alpha/(j(j+1))",
        }
