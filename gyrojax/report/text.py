"""Readable text of the results: coefficient tables and diagnosis summaries, every number with its unit.

No plotting library is imported here, so the command line prints a fit or a diagnosis without loading one.
"""

from __future__ import annotations

import math

import numpy as np

from gyrojax.inference.result import FitResult
from gyrojax.inference.scoring import ALPHA
from gyrojax.inference.triad_result import TriadFit
from gyrojax.inference.verdict import Diagnosis
from gyrojax.physics.triad import CHANNELS


def _fmt(v: float, s: float | None = None) -> str:
    if s is None or not np.isfinite(s):
        return f"{v: .6g}"
    if s == 0:
        return f"{v: .6g} ± 0"
    digits = max(0, 2 - int(math.floor(math.log10(abs(s))))) if s > 0 else 6
    digits = min(digits, 10)
    return f"{v: .{digits}f} ± {s:.2g}"


def fit_table(res: FitResult | TriadFit) -> str:
    """Coefficient table: name, value ± std, unit, t statistic and significance at α
    (:data:`gyrojax.inference.scoring.ALPHA`; CIGTF style); for a triad fit one row per coefficient and channel
    (:func:`triad_fit_table`)."""
    if isinstance(res, TriadFit):
        return triad_fit_table(res)
    lines = [f"fit of {', '.join(res.model.terms)} to {len(res.record_names)} record(s), {res.n_samples} samples"]
    lines.append(f"{'coefficient':14s} {'value ± std':>28s}  {'unit':12s} {'t':>9s}  significant")
    for c, v, s, u, t, p in zip(
        res.coefficient_names, res.theta, res.std, res.model.coefficient_units, res.t_statistics, res.p_values
    ):
        sig = "yes" if np.isfinite(p) and p < ALPHA else ("—" if not np.isfinite(p) else "no")
        lines.append(f"{c:14s} {_fmt(v, s):>28s}  {u:12s} {t:9.2f}  {sig}")
    lines.append(f"residual RMS {res.residual_rms:.6g} deg/h; white-noise floor {res.noise_floor:.6g} deg/h")
    idf = res.identifiability
    cond = idf.get("condition", float("nan"))
    lines.append(f"condition number {cond:.3g}; rank {idf.get('rank')} of {idf.get('size')}")
    for name, nz in zip(res.record_names, res.noise):
        if nz.gauss_markov:
            lines.append(
                f"  noise {name}: white {math.sqrt(nz.white_variance):.3g} + Gauss–Markov "
                f"{math.sqrt(nz.gm_variance):.3g} deg/h, τ {nz.gm_tau:.3g} s"
            )
        elif nz.order:
            lines.append(f"  noise {name}: AR({nz.order}), innovation std {nz.innovation_std:.3g} deg/h")
    return "\n".join(lines)


def triad_fit_table(res: TriadFit) -> str:
    """A triad fit's coefficient table, one row per coefficient and channel, with what its χ² says."""
    lines = [f"{'coefficient':14s} {'value':>14s} {'std':>12s}  unit"]
    u = res.units()
    for n, v, s in zip(res.names, res.theta, res.std):
        lines.append(f"{n:14s} {v:14.6g} {s:12.4g}  {u[n]}")
    if "ia_misalignment" in res.model.terms:
        ang = res.misalignment_angles()
        lines.append("misalignment as angles (arcsec; independent of the nominal scale):")
        for ch in CHANNELS:
            cells = [(k, ang[f"{k}[{ch}]"]) for k in ("M_O", "M_S", "psi")]
            lines.append(f"  {ch}: " + ", ".join(f"{k} {a['value']:.6g} ± {a['std'] or np.nan:.3g}" for k, a in cells))
    lines.append(f"earth rate: {res.earth_mode}; chi2 {res.chi2:.3g} on {res.dof} dof")
    if res.segment_residuals and res.dof > 0 and res.chi2_p_value < ALPHA:
        lines.append("chi2 driven by: " + ", ".join(f"{n} ({100 * f:.0f} %)" for n, f in res.chi2_drivers()))
    if any(v > 0 for v in res.variance_components.values()):
        lines.append(
            "sigma include the variance components (REML): "
            + ", ".join(f"{k} {v:.3g}" for k, v in res.variance_components.items() if "indicated" not in k)
        )
    if not res.converged:
        lines.append(f"not converged: {res.convergence_note}")
    lines.extend(f"note: {n}" for n in res.notes)
    return "\n".join(lines)


def triad_diagnosis_text(d: Diagnosis) -> str:
    """A triad diagnosis: the verdict, the candidates that matter, the noise processes and the unnamed structure."""
    lines = [f"verdict: {d.verdict} (alpha {d.alpha:g}, {d.tests} tests, Holm)"]
    lines.append(
        f"fit: chi2 {d.fit.chi2:.4g} on {d.fit.dof} dof (white noise); "
        f"{d.chi2_components:.4g} on {d.dof} with the variance components"
    )
    for c in d.noise_processes:
        est = ", ".join(f"{k} {v['value']:.3g} {v['unit']}" for k, v in c.estimate.items())
        lines.append(f"noise process {c.name}: LR {c.statistic:.3g}, p {c.p_value:.2g} ({est})")
    for c in d.candidates[:8]:
        if c.df == 0:
            lines.append(f"  {c.name}: indistinguishable from {', '.join(c.aliases) or 'the model'}")
            continue
        est = ", ".join(f"{k} {v['value']:.4g} {v['unit']}" for k, v in c.estimate.items())
        flag = f" [implausible: {c.implausible}]" if c.implausible else ""
        flag += f" [refused: {c.refused}]" if c.refused else ""
        alias = f" aliases {', '.join(c.aliases)}" if c.aliases else ""
        lines.append(f"  {c.name}: p_adj {c.p_adjusted:.2g} ({est}){alias}{flag}")
    for s in d.unexplained:
        lines.append(f"unexplained structure: {s.name}: p_adj {s.p_adjusted:.2g} ({s.description})")
    drift = [c.name for c in d.candidates if "bias_random_walk" in c.indistinguishable]
    if drift:
        lines.append(
            f"indistinguishable from drift with these poses: {', '.join(drift)} or the bias random walk explain the "
            "data alike; not proposed (more poses, or a longer session, would tell a trend from the walk)"
        )
    lines.append(f"proposal: {d.proposal}" if d.proposal else "proposal: none")
    return "\n".join(lines)


def diagnosis_text(d: Diagnosis, add: str | None = None) -> str:
    """Verdict, residual against floor, and the ranked candidates with their aliases (a triad diagnosis:
    :func:`triad_diagnosis_text`).

    ``add``: the effect the caller will add, when it picks an alias of the top candidate (the plan cannot tell them
    apart, so either explains the residual equally); default the top candidate itself.
    """
    if isinstance(d.fit, TriadFit):
        return triad_diagnosis_text(d)
    lines = [
        f"verdict: {d.verdict}   (family-wise α = {d.alpha})",
        f"model: {', '.join(d.fit.terms)}",
        f"residual RMS {d.residual_rms:.6g} deg/h; white-noise floor {d.noise_floor:.6g} deg/h",
    ]
    lines.append(f"{'candidate':18s} {'statistic':>12s} {'df':>3s} {'p (Holm)':>10s} {'RMS after':>12s}  aliases")
    for c in d.candidates[:12]:
        al = ", ".join(c.aliases) if c.aliases else ""
        if c.separated_by:
            al += f"  (separate with: {'; '.join(c.separated_by[:3])})"
        lines.append(f"{c.name:18s} {c.statistic:12.4g} {c.df:3d} {c.p_adjusted:10.3g} {c.rms_after:12.6g}  {al}")
    if d.unexcited:
        lines.append("not excited by this plan: " + ", ".join(d.unexcited))
    lines += adequacy_lines(d)
    top = next((c for c in d.candidates if c.name == d.proposal), None)
    if d.verdict == "missing-effect" and top is not None:
        name = add or top.name
        terms = ",".join(d.fit.terms + (name,))
        if name != top.name:
            why = (
                f"an alias of the top candidate {top.name!r}: this plan cannot tell them apart"
                if name in top.aliases
                else f"chosen instead of the top candidate {top.name!r}"
            )
            lines.append(f"→ add {name!r} ({why}) and refit (gyrojax fit … --terms {terms})")
        else:
            lines.append(f"→ add {name!r} and refit (gyrojax fit … --terms {terms})")
    return "\n".join(lines)


def adequacy_lines(d) -> list[str]:
    """The lines of a diagnosis about what no named effect explains, near-aliases, and candidates that cannot be
    proposed (refused by fit, or of implausible size) — each beside the unexplained structure
    (:class:`gyrojax.inference.verdict.Structure`)."""
    lines = []
    for c in d.candidates:
        if c.df > 0 and c.indistinguishable and c.p_adjusted < d.alpha:
            sep = "; ".join(c.separated_by[:3]) or "no built-in plan"
            lines.append(
                f"{c.name} is indistinguishable in this test from {', '.join(c.indistinguishable)} "
                f"(either explains the data within the critical difference); to separate them: {sep}"
            )
    for c in d.candidates:
        if c.df > 0 and c.p_adjusted < d.alpha and (c.refused or c.implausible):
            why = c.refused or f"implausible size: {c.implausible}"
            lines.append(f"not proposed: {c.name} — {why}")
    for s in d.unexplained[:6]:
        tip = f"; model it with --effect '{s.suggested_name}={s.expression}'" if s.expression else ""
        lines.append(f"{s.line} (χ² {s.statistic:.4g} on {s.df} df, p (Holm) {s.p_adjusted:.3g}){tip}")
    if d.unexplained and d.proposal is None:
        lines.append(
            "→ no named effect explains the residual: model the structure above (gyrojax fit … --effect "
            "'NAME=EXPR') or look for its physical cause"
        )
    return lines
