"""Design criteria: losses of the Fisher information (:mod:`gyrojax.planning.fisher`) to minimise, and the
score-test power of an omitted effect.

**Criteria** (all written as a loss to minimise):

=================  ===========================================================================================
``D``              −log det F (D-optimal: smallest confidence ellipsoid)
``A``              trace(W F⁻¹), W = diag(weights) (default 1): mean variance
``E``              −λ_min(F) (unit-dependent: θ is in report units; non-smooth where eigenvalues cross, so
                   its final gradient norm need not vanish)
``c:C1=w1,...``    cᵀ F⁻¹ c: the variance of the combination cᵀθ
``ratio``          (1/q) log Σ_i (w_i [F⁻¹]_ii)^q, q = :data:`RATIO_POWER`: a smooth maximum of the variances
                   over their targets, w_i = 1/target_i² (0 for a coefficient without one; given to :meth:`loss`
                   as ``weights``, so that one compiled search serves every goal); below 0 every σ is on target
``detect:NAME``    −log λ_NAME with λ = δᵀ (F_aa − F_aθ F_θθ⁻¹ F_θa) δ the noncentrality of the score test for the
                   omitted effect NAME at nominal magnitude δ (the information on NAME orthogonal to the model's
                   regressors); a small D term (weight 1/10 per coefficient) keeps the model itself estimable
=================  ===========================================================================================

The power of the score test at level α is P(χ²_q(λ) > χ²_{q,1−α}), q = size of NAME (:func:`detect_power`).
For nonlinear effects F depends on θ; :func:`gyrojax.planning.optimal.design` takes a prior sample of θ and
minimises the mean loss over it (Bayesian design by ``vmap``); for linear models any θ gives the same F.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.errors import ModelError
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model
from gyrojax.planning.fisher import static_fisher

RATIO_POWER = 8.0
"""The power of the ``ratio`` criterion's smooth maximum: (Σ r^q)^{1/q} exceeds max r by a factor ≤ n^{1/q}."""
DEFAULT_MAGNITUDE = 0.05  # nominal size of an omitted effect for detect: (report units, e.g. deg/h/g²)


@dataclass(frozen=True)
class Criterion:
    """A design criterion: ``kind`` in D, A, E, c, detect; ``vector`` (A weights or c), ``effect``, ``magnitude``.

    ``magnitude`` is the detect effect's size in its coefficients' report units (deg/h/g², …); weights are
    dimensionless.
    """

    kind: str = "D"
    vector: tuple | None = None
    effect: str | None = None
    magnitude: tuple | None = None
    d_weight: float = 0.1

    @classmethod
    def parse(cls, text: str, model: Model, names=None) -> "Criterion":
        """``D``, ``A``, ``A:C=w,...``, ``E``, ``c:C=w,...``, ``detect:NAME`` or ``detect:NAME=δ``, for the
        coefficients ``names`` of F (default the model's; e.g. an instrument's per-channel names ``D_F[x]``, which
        takes no ``detect``)."""
        detect = names is None
        names = list(model.coefficient_names if names is None else names)
        head, _, rest = text.partition(":")
        if head in ("D", "E") and not rest:
            return cls(head)
        if head in ("A", "c"):
            if not rest:
                if head == "c":
                    raise ModelError(f"criterion c needs a vector: c:COEF=w,... (e.g. c:{names[0]})")
                return cls("A")
            w = {}
            for item in rest.split(","):
                k, _, v = item.partition("=")
                k = k.strip()
                if k not in names:
                    raise ModelError(
                        f"criterion {text!r}: {k!r} is not a coefficient of the model ({', '.join(names)})"
                    )
                try:
                    w[k] = float(v) if v else 1.0
                except ValueError:
                    raise ModelError(f"criterion {text!r}: weight {v!r} of {k} is not a number") from None
            return cls(head, tuple(w.get(c, 0.0) for c in names))
        valid = "D, A, E, c:COEF=w,..." + (", detect:NAME[=magnitude]" if detect else "")
        if head == "detect" and rest and detect:
            name, _, mag = rest.partition("=")
            e = fx.get(name if name in fx.names() else fx.effect_of_coefficient(name))
            if e.name in model.terms:
                raise ModelError(f"detect:{e.name}: the effect is already in the model")
            try:
                m = float(mag) if mag else DEFAULT_MAGNITUDE
            except ValueError:
                raise ModelError(f"criterion {text!r}: magnitude {mag!r} is not a number") from None
            return cls("detect", effect=e.name, magnitude=(m,) * e.size)
        raise ModelError(f"unknown criterion {text!r}; valid: {valid} (e.g. c:{names[0]})")

    def design_model(self, model: Model) -> Model:
        """The model whose Fisher information the criterion needs (the model plus the omitted effect)."""
        return model.extend(self.effect) if self.kind == "detect" else model

    def loss(self, f, p: int, weights=None):
        """Loss to minimise from the Fisher information ``f`` of :meth:`design_model` (module doc); ``weights``
        (p,) those of ``ratio`` (the others take none)."""
        if self.kind == "D":
            return -_logdet(f)
        if self.kind == "E":
            return -jnp.linalg.eigvalsh(f)[0]
        if self.kind == "A":
            w = jnp.ones(p) if self.vector is None else jnp.asarray(self.vector)
            return jnp.sum(w * jnp.diag(jnp.linalg.inv(f)))
        if self.kind == "c":
            c = jnp.asarray(self.vector)
            return c @ jnp.linalg.solve(f, c)
        if self.kind == "ratio":
            r = jnp.asarray(weights) * jnp.diag(jnp.linalg.inv(f))
            top = jax.lax.stop_gradient(jnp.max(r))  # scaled by the largest: no overflow of r^q
            return jnp.log(top) + jnp.log(jnp.sum((r / top) ** RATIO_POWER)) / RATIO_POWER
        if self.kind == "detect":
            lam = noncentrality(f, p, jnp.asarray(self.magnitude))
            return -jnp.log(jnp.maximum(lam, 1e-300)) - self.d_weight * _logdet(f[:p, :p])
        raise ModelError(f"unknown criterion kind {self.kind!r}")

    def label(self) -> str:
        """Short name of the criterion for reports: ``D``, ``A``, …, or ``detect:EFFECT``."""
        return self.kind if self.kind != "detect" else f"detect:{self.effect}"


def _logdet(f):
    return jnp.linalg.slogdet(f)[1]


def noncentrality(f_full, p: int, delta):
    """λ = δᵀ (F_aa − F_aθ F_θθ⁻¹ F_θa) δ: score-test noncentrality for the effect in rows/cols p: of F."""
    fa = f_full[p:, p:] - f_full[p:, :p] @ jnp.linalg.solve(f_full[:p, :p], f_full[:p, p:])
    return delta @ fa @ delta


def detect_power(lam: float, df: int = 1, alpha: float = 0.01) -> float:
    """Power of the χ²_df score test at level α for noncentrality λ."""
    from gyrojax import tails  # and so scipy.special, which a D, A or E design never needs

    return tails.score_power(max(lam, 1e-300), df, alpha)


def criterion_values(f, model: Model, extra: dict | None = None) -> dict:
    """D, A, E of a Fisher information and the Cramér–Rao std of every coefficient (inf when not estimable)."""
    f = np.asarray(f, float)
    s = np.sqrt(np.maximum(np.diag(f), 1e-300))
    fs = f / np.outer(s, s)
    ev, vec = np.linalg.eigh(fs)
    null = ev < 1e-10 * max(ev[-1], 1e-300)
    std = np.sqrt(np.maximum(np.diag(np.linalg.pinv(f, rcond=1e-12, hermitian=True)), 0.0))
    if null.any():
        bad = np.abs(vec[:, null]).max(axis=1) > 1e-6
        std = np.where(bad, np.inf, std)
    ok = not null.any()
    out = {
        "D": float(np.linalg.slogdet(f)[1]) if ok else -math.inf,
        "A": float(np.sum(std**2)) if ok else math.inf,
        "E": float(np.linalg.eigvalsh(f)[0]),
        "std": dict(zip(model.coefficient_names, map(float, std))),
    }
    out.update(extra or {})
    return out


def detect_noncentrality(model, crit: Criterion, table, angles_rad, dwell_s, noise, dt_s=1.0) -> float:
    """Score-test noncentrality λ (dimensionless) of the criterion's effect at static positions ``angles_rad``
    (rad) held ``dwell_s`` (s) each, sampled every ``dt_s`` (s); see :func:`noncentrality`."""
    full = crit.design_model(model)
    f = static_fisher(full, table, jnp.asarray(angles_rad), jnp.asarray(dwell_s), noise, dt_s)
    return float(noncentrality(f, model.size, jnp.asarray(crit.magnitude)))
