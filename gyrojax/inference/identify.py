"""Identification: joint fits of named effects to one or many records, with honest uncertainties.

The measurement model of every record (:func:`gyrojax.physics.model.predict`) is linearised by ``jax.jacfwd``; the
stacked system is solved by one least-squares step when every effect is linear in its coefficients; the set-up
effects, which enter through the kinematics, are fitted by Levenberg–Marquardt (``scipy.optimize.least_squares``,
method ``"lm"``) on the same weighted or whitened system with the exact ``jax.jacfwd`` Jacobian, and its stopping
status is the fit's ``converged`` flag (:class:`~gyrojax.errors.ConvergenceWarning` when it did not).

With ``noise="ar"`` (the default) a white + Gauss–Markov (or AR) noise model is fitted by REML to the residuals of
each group of records of one mode and sample interval, jointly (:func:`campaign_noise`), so the fit is feasible GLS
and standard errors stay honest under coloured drift, also when the drift is slower than one position (module
:mod:`gyrojax.noise.whiten`).

Before any number is reported the plan's identifiability is checked: the singular values of the column-normalised,
whitened regressor matrix give the rank, the condition number and the groups of effects the plan cannot tell apart
(for example D_F, D_II, D_OO and D_SS in any 1 g test, since a_I² + a_O² + a_S² is constant). Such a fit raises
:class:`IdentifiabilityError` naming the groups, unless ``allow_aliases=True``.

This is the torque-to-balance procedure of the 1967 CIGTF standard in modern form: least squares on all records of
all positions and modes at once, each coefficient with its standard error and significance.
"""

from __future__ import annotations

import hashlib
import json
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import jax.numpy as jnp
import numpy as np
from scipy import stats
from scipy.optimize import least_squares

from gyrojax.data.records import Record, interval_key
from gyrojax.data.triad import TRIAD_KIND
from gyrojax.errors import ConvergenceWarning, FormatError, ModelError, RecordError
from gyrojax.inference.lstsq import lstsq
from gyrojax.noise import reml
from gyrojax.noise.readout import record_readout_variance, white_beside_readout
from gyrojax.noise.whiten import (
    FIT_TAU_SPAN_FRACTION,
    ARNoise,
    GMNoise,
    first_difference_std,
    fit_noise,
    gls_residual,
    gm_reml,
    whiten,
)
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model, RecordData, check_servo, jacobian_jit, predict_jit, record_data
from gyrojax.protocol import atomic_write_text

ALIAS_TOL = 1e-7  # singular value / largest below this: a direction the plan cannot see
RESIDUE_TOL = 1e-12
"""A whitened regressor column whose norm is below this fraction of the largest column's is floating-point residue
(cos 90° = 6e-17, not 0): the plan does not excite that coefficient. Legitimately weak columns (E_2 under the Earth
rate alone, ~1e-8) stay well above it; residue stays below ~1e-14."""
DEFAULT_TERMS = {
    fx.SDF: ("D_F", "D_I", "D_O", "D_S"),
    fx.TDF: ("DX_F", "DY_F"),
    fx.ACCEL: ("K_0", "K_1"),
    fx.FOG: ("D_F", "sf_error"),
    fx.RLG: ("D_F", "sf_error"),
}


class IdentifiabilityError(ModelError):
    """The plan cannot separate some effects of the model; ``report`` holds the details."""

    def __init__(self, message, report):
        super().__init__(message)
        self.report = report


# ---- the stacked system -----------------------------------------------------------------------------------------


def measurement_labels(record: Record, data: RecordData) -> np.ndarray:
    """Continuous-segment label of every measurement (−1: not a measurement, e.g. a servo interval across a gap)."""
    seg = record.segment_id
    if data.mode == "servo":
        lab = seg[:-1].copy()
        lab[np.asarray(data.weight) == 0] = -1
        return lab
    if data.kind == fx.TDF:
        return np.concatenate([seg, seg + seg.max() + 1])
    return seg.copy()


def measurement_times(record: Record, data: RecordData) -> np.ndarray:
    """Time (s) of every measurement: the sample time; a servo interval's midpoint; TDF channels one after the other."""
    t = np.asarray(record.time_s, dtype=float)
    if data.mode == "servo":
        return 0.5 * (t[1:] + t[:-1])
    if data.kind == fx.TDF:
        return np.concatenate([t, t])
    return t


def _check_finite(record: Record) -> None:
    """Records built in memory bypass the loader's checks: every value must still be finite."""
    for k, v in record.columns.items():
        bad = ~np.isfinite(np.asarray(v, dtype=float))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise RecordError(
                f"{record.path or record.name}: row {i + 2}, column {k!r} holds {float(v[i])}; values must be finite"
            )


def _is_triad(records) -> bool:
    recs = [records] if isinstance(records, Record) else records
    return isinstance(recs, (list, tuple)) and any(isinstance(r, Record) and r.kind == TRIAD_KIND for r in recs)


def instrument_id(record: Record) -> str:
    """Which instrument (and channel) a record measured: its JSON keys ``instrument.id`` and
    ``instrument.channel`` joined as ``id[channel]`` (either may be absent; ``""`` when both are)."""
    inst = record.meta.get("instrument", {})
    ident = inst.get("id")
    chan = inst.get("channel")
    out = "" if ident is None else str(ident)
    return out + (f"[{chan}]" if chan is not None else "")


def check_one_instrument(records) -> None:
    """Refuse records of different instruments or channels in one fit: one coefficient set for several gyros
    would be a blend of theirs. Records without ``instrument.id``/``channel`` are taken as one instrument."""
    ids: dict[str, list[str]] = {}
    for r in records:
        ids.setdefault(instrument_id(r), []).append(r.name)
    if len(ids) > 1:
        listing = "; ".join(f"{k or '(no id)'}: {', '.join(v[:3])}{' …' if len(v) > 3 else ''}" for k, v in ids.items())
        raise ModelError(
            f"records of {len(ids)} different instruments/channels cannot share one coefficient set ({listing}); "
            "fit each instrument on its own (fit_per_instrument, or `gyrojax fit --per-instrument`)"
        )


def split_by_instrument(records) -> dict[str, list]:
    """Records grouped by :func:`instrument_id`, in order of first appearance."""
    out: dict[str, list] = {}
    for r in records:
        out.setdefault(instrument_id(r), []).append(r)
    return out


@dataclass
class Campaign:
    """Records of one fit as arrays: ``data[i]`` (:class:`gyrojax.physics.model.RecordData`), ``labels[i]``
    (segment of each
    measurement, −1 for none) and ``times[i]`` (time of each measurement, s) per record."""

    records: list
    data: list
    labels: list
    kind: str
    times: list = field(default_factory=list)

    @classmethod
    def of(cls, records) -> "Campaign":
        """A campaign from one :class:`Record` or a list of records of one instrument kind; checks that every value
        is finite and that servo records can null the pickoff (Hu 3-59)."""
        if isinstance(records, Record):
            records = [records]
        records = list(records)
        if not records:
            raise ModelError("no records to fit")
        kinds = {r.kind for r in records}
        if TRIAD_KIND in kinds:
            raise ModelError(
                "imu-triad records have no turntable: they are fitted per channel by fit() "
                "(gyrojax.inference.triad.fit_triad); diagnose and the turntable tools do not take them"
            )
        if len(kinds) > 1:
            raise ModelError(f"records of different instrument kinds cannot be fitted together: {sorted(kinds)}")
        check_one_instrument(records)
        for r in records:
            _check_finite(r)
        data = [record_data(r) for r in records]
        for r, d in zip(records, data):
            check_servo(d, r.path or r.name)
        labels = [measurement_labels(r, d) for r, d in zip(records, data)]
        times = [measurement_times(r, d) for r, d in zip(records, data)]
        return cls(records, data, labels, records[0].kind, times)

    @property
    def n_measurements(self) -> int:
        """Number of measurements in all records (rows with a label ≥ 0)."""
        return int(sum((lab >= 0).sum() for lab in self.labels))


def check_terms(model: Model, campaign: Campaign) -> None:
    """Refuse a model whose inputs the records lack: ``bias_temperature`` needs a ``temperature_C`` column (°C) that
    varies, or it aliases D_F. Raises :class:`ModelError`."""
    if "bias_temperature" in model.terms:
        temps = []
        for r in campaign.records:
            if r.temperature_C is None:
                raise ModelError(
                    f"{r.path or r.name}: effect 'bias_temperature' needs column 'temperature_C', which is absent"
                )
            temps.append(r.temperature_C)
        t = np.concatenate(temps)
        if np.ptp(t) < 1e-6:
            raise ModelError(
                "effect 'bias_temperature' cannot be fitted: column 'temperature_C' is constant "
                f"({t[0]} °C) in every record, so it aliases D_F"
            )


def linearize(model: Model, theta, campaign: Campaign):
    """Per record (r, J, labels, times): residuals r = y − predict (output units: deg/h for gyros, g for
    accelerometers), Jacobians J = ∂predict/∂θ (output units per report unit), segment labels and measurement
    times (s); measurement rows only. ``theta`` in report units."""
    out = []
    th = jnp.asarray(theta, dtype=jnp.float64)
    for d, lab, t in zip(campaign.data, campaign.labels, campaign.times):
        ok = lab >= 0
        r = (np.asarray(d.y) - np.asarray(predict_jit(model, th, d)))[ok]
        jac = np.asarray(jacobian_jit(model, th, d))[ok] if model.size else np.zeros((int(ok.sum()), 0))
        out.append((r, jac, lab[ok], t[ok]))
    return out


def residue_columns(jw: np.ndarray, tol: float = RESIDUE_TOL) -> np.ndarray:
    """Mask of the columns of a (whitened) regressor matrix that are only floating-point residue
    (:data:`RESIDUE_TOL`): their coefficients are not excited, and an estimate of them would be noise / 1e-16."""
    norms = np.sqrt((jw * jw).sum(axis=0))
    if norms.size == 0:
        return np.zeros(0, dtype=bool)
    return norms <= tol * max(float(norms.max()), 1e-300)


def identifiability(jw: np.ndarray, model: Model, tol: float = ALIAS_TOL) -> dict:
    """Rank, condition number and alias groups of a (whitened) regressor matrix.

    Columns are normalised first, so the condition number measures correlation, not units. An alias group is the
    set of effects whose coefficients carry weight (|v| > 0.05) in a right singular vector whose singular value is
    below ``tol`` × the largest: a combination of their regressors that the plan leaves (nearly) unseen.
    """
    names = model.coefficient_names
    if jw.shape[1] == 0:
        return {"rank": 0, "size": 0, "condition": 1.0, "aliases": [], "unexcited": []}
    norms = np.sqrt((jw * jw).sum(axis=0))
    residue = residue_columns(jw)
    unexcited = [names[i] for i in np.flatnonzero(residue)]
    z = np.where(residue, 0.0, jw / np.where(norms > 0, norms, 1.0))
    _, s, vt = np.linalg.svd(z, full_matrices=False)
    smax = s[0] if s.size else 1.0
    small = s < tol * smax
    groups: list[set] = []
    coef_to_effect = {c: fx.effect_of_coefficient(c) for c in names}
    for i in np.flatnonzero(small):
        v = vt[i]
        members = {coef_to_effect[names[k]] for k in np.flatnonzero(np.abs(v) > 0.05)}
        merged = [g for g in groups if g & members]
        for g in merged:
            members |= g
            groups.remove(g)
        groups.append(members)
    order = {t: i for i, t in enumerate(model.terms)}
    alias_groups = [sorted(g, key=order.get) for g in groups if len(g) > 1 or g & set(unexcited)]
    positive = s[s > 0]
    return {
        "rank": int((~small).sum()),
        "size": len(names),
        "condition": float(smax / positive[-1]) if positive.size and positive[-1] > 0 else math.inf,
        "aliases": alias_groups,
        "unexcited": sorted({coef_to_effect[c] for c in unexcited}, key=order.get),
        "singular_values": s.tolist(),
    }


def alias_message(report: dict) -> str:
    """The message of :class:`IdentifiabilityError` for a report of :func:`identifiability`: the alias groups, the
    unexcited effects, the rank, and what to do about them."""
    parts = []
    for g in report["aliases"]:
        parts.append(" + ".join(g))
    msg = "this plan cannot tell apart: " + "; ".join(f"[{p}]" for p in parts) if parts else ""
    if report["unexcited"]:
        msg += ("; " if msg else "") + "not excited by this plan: " + ", ".join(report["unexcited"])
    return (
        f"{msg} (rank {report['rank']} of {report['size']}); drop all but one effect of each group, "
        "or add positions/mountings that separate them"
    )


# ---- the result -------------------------------------------------------------------------------------------------


@dataclass
class FitResult:
    """Estimates with units, standard errors, correlation, residuals per record and fit statistics."""

    model: Model
    theta: np.ndarray
    cov: np.ndarray
    residuals: list  # raw residual per record (measurements only), output units
    labels: list
    record_names: list
    record_paths: list
    noise: list  # noise model of each record (GMNoise or ARNoise; the records of one noise group share one)
    identifiability: dict
    n_samples: int
    iterations: int = 1
    converged: bool = True
    convergence_note: str = ""  # why the fit did not converge ("" when it did)
    chi2_whitened: float = float("nan")
    dof: int = 0
    inputs: list = field(default_factory=list)
    dof_eff: np.ndarray | None = None  # Satterthwaite degrees of freedom of each variance (None: not estimated)

    # -- views --
    @property
    def coefficient_names(self):
        """Coefficient names in θ order (:attr:`gyrojax.physics.model.Model.coefficient_names`)."""
        return self.model.coefficient_names

    @property
    def std(self) -> np.ndarray:
        """Standard error of each coefficient, report units, θ order (NaN for an unseen direction)."""
        return np.sqrt(np.clip(np.diag(self.cov), 0.0, None))

    @property
    def values(self) -> dict:
        """Coefficient name -> estimate, report units (:meth:`units`)."""
        return dict(zip(self.coefficient_names, map(float, self.theta)))

    @property
    def stds(self) -> dict:
        """Coefficient name -> standard error, report units."""
        return dict(zip(self.coefficient_names, map(float, self.std)))

    @property
    def correlation(self) -> np.ndarray:
        """Correlation matrix of the estimates (p, p), dimensionless."""
        s = self.std
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.cov / np.outer(s, s)

    @property
    def t_statistics(self) -> np.ndarray:
        """Estimate / standard error of each coefficient (dimensionless)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.theta / self.std

    @property
    def p_values(self) -> np.ndarray:
        """Two-sided p-value of "coefficient = 0" from Student's t with the degrees of freedom of its variance.

        The same ν as the standard error: where it was t-widened (:attr:`dof_eff`, Satterthwaite; :func:`fit`),
        the plain estimate/σ ratio (σ before the widening by :func:`small_sample_factor`) is referred to t_ν, so the
        p-value and θ̂ ± 2σ tell one story; elsewhere to t at the residual degrees of freedom :attr:`dof` of the
        pooled variance (the normal distribution when ``dof`` is 0, i.e. unknown).
        """
        t = np.abs(self.t_statistics)
        if self.dof_eff is not None:
            nu = np.asarray(self.dof_eff, dtype=float)
            t = t * small_sample_factor(nu)
        else:
            nu = np.full(t.shape, float(self.dof) if self.dof > 0 else np.inf)
        finite = np.isfinite(nu)
        with np.errstate(invalid="ignore"):
            return np.where(finite, 2 * stats.t.sf(t, np.where(finite, nu, 1.0)), 2 * stats.norm.sf(t))

    @property
    def residual_rms(self) -> float:
        """RMS of the raw residuals of all records, output units (deg/h for gyros, g for accelerometers)."""
        r = np.concatenate(self.residuals) if self.residuals else np.zeros(0)
        return float(np.sqrt(np.mean(r * r))) if r.size else float("nan")

    @property
    def noise_floor(self) -> float:
        """RMS the residual would have if only white noise were left (successive differences, pooled)."""
        acc, n = 0.0, 0
        for r, lab in zip(self.residuals, self.labels):
            s = first_difference_std(r, lab)
            acc += s * s * len(r)
            n += len(r)
        return float(np.sqrt(acc / n)) if n else float("nan")

    def units(self) -> dict:
        """Coefficient name -> report unit (``"deg/h"``, ``"deg/h/g"``, ``"ppm"``, ``"arcsec"`` …)."""
        return dict(zip(self.coefficient_names, self.model.coefficient_units))

    def to_json(self) -> dict:
        """The JSON of CONVENTIONS §7 (``gyrojax fit --json``), with extra keys that tools may ignore; ``fit.converged``
        is false, with ``fit.reason``, when the nonlinear or the noise-model step stopped before converging."""
        from gyrojax import __version__

        coeffs = {}
        for c, v, s, u, t, p in zip(
            self.coefficient_names, self.theta, self.std, self.model.coefficient_units, self.t_statistics, self.p_values
        ):
            coeffs[c] = {
                "value": float(v),
                "std": _num(s),
                "unit": u,
                "t": _num(t),
                "p_value": _num(p),
                "significant": bool(p < 0.05) if np.isfinite(p) else False,
            }
        if self.dof_eff is not None:
            for c, nu in zip(self.coefficient_names, self.dof_eff):
                coeffs[c]["dof_eff"] = _num(nu)
        corr = self.correlation
        return {
            "terms": list(self.model.terms),
            "coefficients": coeffs,
            "residual_rms_deg_per_h": self.residual_rms,
            "noise_floor_deg_per_h": self.noise_floor,
            "n_samples": int(self.n_samples),
            "records": [
                {
                    "name": n,
                    "path": p,
                    "n": int(len(r)),
                    "residual_rms": float(np.sqrt(np.mean(r * r))),
                    "noise_model": _noise_json(nz),
                }
                for n, p, r, nz in zip(self.record_names, self.record_paths, self.residuals, self.noise)
            ],
            "instrument": self.model.kind,
            "correlation": [[_num(x) for x in row] for row in corr],
            "identifiability": {k: v for k, v in self.identifiability.items() if k != "singular_values"},
            "not_excited": list(self.identifiability.get("unexcited", [])),
            "fit": {
                "iterations": self.iterations,
                "converged": self.converged,
                **({"reason": self.convergence_note} if not self.converged else {}),
                "dof": self.dof,
                "chi2_whitened": _num(self.chi2_whitened),
            },
            "gyrojax_version": __version__,
            "inputs": self.inputs,
        }

    def save(self, path, force: bool = False) -> Path:
        """Write :meth:`to_json` plus ``theta`` and ``cov`` to ``path`` atomically, tagged with
        :data:`RESULT_FORMAT` and :data:`RESULT_VERSION`; an existing file is an error unless ``force``.
        :meth:`load` reads it back. Returns the path."""
        p = Path(path)
        if p.exists() and not force:
            raise ModelError(f"{p}: exists; pass force=True (or --force) to overwrite")
        d = self.to_json()
        d["format"] = RESULT_FORMAT
        d["format_version"] = RESULT_VERSION
        d["theta"] = [float(x) for x in self.theta]
        d["cov"] = [[float(x) for x in row] for row in self.cov]
        atomic_write_text(p, json.dumps(d, indent=1, allow_nan=True) + "\n")
        return p

    @classmethod
    def load(cls, path) -> "FitResult":
        """A result written by :meth:`save`: model, estimates, covariance, degrees of freedom, convergence and the
        input hashes (residuals are not stored, so :attr:`residuals` is empty). Raises
        :class:`~gyrojax.errors.FormatError` naming the file and the key when it is not a gyrojax fit result of
        a version this gyrojax reads."""
        return result_from_json(load_result(path), where=str(path))

    # -- using the result --
    def error_of(self, record: Record) -> np.ndarray:
        """The fitted instrument error (everything but the inertial input) at each sample of a rebalance record."""
        if record.mode != "rebalance":
            raise ModelError(f"{record.name}: correction applies to rebalance records (this one is {record.mode})")
        d = record_data(record)
        full = np.asarray(predict_jit(self.model, jnp.asarray(self.theta), d))
        base = np.asarray(predict_jit(Model((), self.model.kind), jnp.zeros(0), d))
        return full - base

    def correct(self, record: Record) -> Record:
        """A copy of ``record`` with the fitted error removed from its torquer current (compensation)."""
        return self._shift(record, -self.error_of(record))

    def apply(self, record: Record) -> Record:
        """The inverse of :meth:`correct`: add the fitted error to the current."""
        return self._shift(record, self.error_of(record))

    @staticmethod
    def _shift(record: Record, delta: np.ndarray) -> Record:
        sf = record.scale_factor
        if record.kind == fx.TDF:
            n = record.n
            return record.with_columns(
                current_x_mA=record.columns["current_x_mA"] + delta[:n] / sf,
                current_y_mA=record.columns["current_y_mA"] + delta[n:] / sf,
            )
        return record.with_columns(current_mA=record.columns["current_mA"] + delta / sf)


def _noise_json(nz) -> dict:
    if getattr(nz, "order", 0) == "gm":
        out = {
            "kind": "white+gauss_markov",
            "white_std": float(np.sqrt(nz.white_var)),
            "gauss_markov_std": float(np.sqrt(nz.gm_var)),
            "tau_s": float(nz.tau_s),
            "innovation_std": nz.innovation_std,
            "std": nz.std,
        }
        if nz.readout_var > 0:  # a servo readout's angle error over the interval (gyrojax.noise.readout)
            out["readout_std"] = float(np.sqrt(nz.readout_var))
        return out
    return {"kind": "ar", "ar_order": int(nz.order), "innovation_std": nz.innovation_std, "std": nz.std}


def _num(x):
    x = float(x)
    return x if math.isfinite(x) else None


RESULT_FORMAT = "gyrojax-fit"
"""The ``format`` key of a saved fit result (:meth:`FitResult.save`)."""
RESULT_VERSION = 1
"""The ``format_version`` this gyrojax writes; it reads versions up to this one (``gyrojax-fit-1`` files of 0.2
carry the version in the format string)."""


def load_result(path) -> dict:
    """A saved fit result as a dict (its ``theta``/``cov`` arrays restore the numbers), after checking its format
    and version; :class:`~gyrojax.errors.FormatError` naming the file and the key otherwise."""
    try:
        d = json.loads(Path(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as e:
        raise FormatError(f"{path}: not JSON ({e.msg} at line {e.lineno}); not a gyrojax fit result") from None
    if not isinstance(d, dict):
        raise FormatError(f"{path}: not a gyrojax fit result (a JSON object with key 'format' is expected)")
    fmt, version = d.get("format"), d.get("format_version")
    if fmt == "gyrojax-fit-1" and version is None:  # 0.2 wrote the version into the format string
        fmt, version = RESULT_FORMAT, 1
    if fmt != RESULT_FORMAT:
        raise FormatError(f"{path}: key 'format' is {_plain(fmt)}, not {RESULT_FORMAT!r}; not a gyrojax fit result")
    if not isinstance(version, int) or isinstance(version, bool) or not 1 <= version <= RESULT_VERSION:
        raise FormatError(
            f"{path}: key 'format_version' is {_plain(version)}; this gyrojax reads versions 1 to {RESULT_VERSION}"
        )
    for key in ("terms", "theta", "cov", "records", "n_samples"):
        if key not in d:
            raise FormatError(f"{path}: key {key!r} is missing from the fit result")
    return d


def _plain(v) -> str:
    """A value as a message shows it: strings quoted, numbers plain, absence as 'absent'."""
    return "absent" if v is None else repr(v) if isinstance(v, str) else str(v)


def result_from_json(d: dict, where: str = "fit result") -> FitResult:
    """Rebuild a :class:`FitResult` (estimates, covariance, fit statistics; residuals are not stored) from the dict
    of a saved result (:func:`load_result`). ``where`` names the source in error messages."""
    try:
        model = Model(tuple(d["terms"]), d.get("instrument", fx.SDF))
        theta = np.asarray(d["theta"], dtype=float)
        cov = np.asarray(d["cov"], dtype=float)
    except (KeyError, TypeError, ValueError) as e:
        raise FormatError(f"{where}: cannot rebuild the fit ({e})") from None
    if theta.shape != (model.size,) or cov.shape != (model.size, model.size):
        raise FormatError(
            f"{where}: keys 'theta' {list(theta.shape)} and 'cov' {list(cov.shape)} do not match the "
            f"{model.size} coefficients of {list(model.terms)}"
        )
    fit_stats = d.get("fit", {})
    return FitResult(
        model,
        theta,
        cov,
        [],
        [],
        [r["name"] for r in d["records"]],
        [r.get("path") for r in d["records"]],
        [ARNoise(np.zeros(0), 1.0, 1.0) for _ in d["records"]],
        d.get("identifiability", {}),
        d["n_samples"],
        iterations=int(fit_stats.get("iterations", 1)),
        converged=bool(fit_stats.get("converged", True)),
        convergence_note=str(fit_stats.get("reason", "")),
        chi2_whitened=float("nan") if fit_stats.get("chi2_whitened") is None else float(fit_stats["chi2_whitened"]),
        dof=int(fit_stats.get("dof", 0)),
        inputs=d.get("inputs", []),
        dof_eff=_dof_eff_of(d),
    )


def _dof_eff_of(d: dict):
    nus = [d["coefficients"].get(c, {}).get("dof_eff") for c in d.get("coefficients", {})]
    return None if not nus or any(v is None for v in nus) else np.array(nus, dtype=float)


def _hash_inputs(records) -> list:
    out = []
    for r in records:
        h = hashlib.sha256()
        for k in sorted(r.columns):
            h.update(k.encode())
            h.update(np.ascontiguousarray(r.columns[k]).tobytes())
        h.update(json.dumps(r.meta, sort_keys=True).encode())
        out.append({"name": r.name, "path": r.path, "sha256": h.hexdigest()})
    return out


# ---- the solver -------------------------------------------------------------------------------------------------


def stack_whitened(lin, noises, scales):
    """Whitened, weighted stacked system from per-record (r, J, labels)."""
    rows_r, rows_j = [], []
    for (r, j, lab, t), nz, s in zip(lin, noises, scales):
        if nz is None:
            rows_r.append(r / s)
            rows_j.append(j / s)
        else:
            both = np.column_stack([r, j])
            w, _ = whiten(both, lab, nz, t)
            rows_r.append(w[:, 0])
            rows_j.append(w[:, 1:])
    return np.concatenate(rows_r), np.concatenate(rows_j, axis=0)


def noise_groups(campaign: Campaign) -> list[list[int]]:
    """Indices of the records that share one noise model: same mode and sample interval (s). One instrument's
    drift is one random process, whatever the position; a servo record's interval means, or another sample
    interval, see it through a different filter.

    The interval is the median step rounded to 3 significant digits (:func:`gyrojax.data.records.interval_key`),
    so the last digits of the timestamps (a clock written with 7 digits, logger jitter) never split a group.
    A record JSON key ``noise_group`` (any string) chooses the group instead."""
    groups: dict[tuple, list[int]] = {}
    for i, (rec, t, lab) in enumerate(zip(campaign.records, campaign.times, campaign.labels)):
        user = rec.meta.get("noise_group")
        if user is not None:
            groups.setdefault(("user", str(user)), []).append(i)
            continue
        groups.setdefault((rec.mode, interval_key(mean_interval(t, lab))), []).append(i)
    return list(groups.values())


def mean_interval(times: np.ndarray, labels: np.ndarray) -> float:
    """Sample interval (s) of a record's measurements: the median over its continuous segments of each segment's
    mean step (span / steps), so that timestamps rounded to a few digits give the interval, not their last digit."""
    steps = []
    for s in np.unique(labels[labels >= 0]):
        t = times[labels == s]
        if len(t) > 1:
            steps.append((t[-1] - t[0]) / (len(t) - 1))
    return float(np.median(steps)) if steps else 0.0


def campaign_noise(lin, campaign: Campaign) -> list:
    """Noise model of every record, fitted jointly over each :func:`noise_groups` group: the residuals of the
    group's records stacked as independent series (each restarts), REML with the fit's regressors of all of them.

    Pooling matters for campaigns of many short records (the 8-position test): a Gauss–Markov drift slower than a
    position shows only in the scatter of the position means, which per-record noise fits cannot see; the joint
    REML does, so the GLS standard errors stay honest (``benchmarks/bench_coverage.py``). White + Gauss–Markov is
    preferred to AR(p) whenever it can be fitted (``prefer_gm``), and a drift the REML cannot tell from white noise
    is dropped (:data:`WHITE_LR_CRITICAL`).

    ``lin`` as from :func:`linearize` (residuals in the output unit, deg/h or g; times in s). Returns one
    :class:`~gyrojax.noise.whiten.GMNoise` or :class:`~gyrojax.noise.whiten.ARNoise` per record (variances in the
    output unit
    squared, τ in s); records of one group share the same object.
    """
    noises = [None] * len(lin)
    for idx in noise_groups(campaign):
        r, j, lab, t = group_series(lin, idx)
        q = group_readout_variance(campaign, idx)
        kw = {"tau_span_fraction": FIT_TAU_SPAN_FRACTION, "neutral_start": True, "prefer_gm": True, "readout_var": q}
        nz = fit_noise(r, lab, t, design=j, **kw)
        if isinstance(nz, GMNoise):
            nz = _white_unless_drift(r, j, lab, t, nz)
        for i in idx:
            noises[i] = nz
    return noises


WHITE_LR_CRITICAL = 2.71
"""REML likelihood ratio below which a fitted Gauss–Markov component is dropped for white noise: the 5 % point of
½χ²₀ + ½χ²₁, the null law of a variance on its boundary."""


def group_readout_variance(campaign: Campaign, idx) -> float:
    """The servo readout's noise σ_q² ((deg/h)², :mod:`gyrojax.noise.readout`) of the records ``idx`` of one noise
    group (their largest; 0 for records that are not servo or not quantised)."""
    return max(
        record_readout_variance(campaign.records[i], mean_interval(campaign.times[i], campaign.labels[i])) for i in idx
    )


def _white_unless_drift(r, j, lab, t, gm: GMNoise):
    """White noise instead of ``gm`` when the pooled REML cannot tell the drift from white (ratio below
    :data:`WHITE_LR_CRITICAL`). On white data a Gauss–Markov variance is estimated on its boundary, so positive by
    construction, and it would widen the standard errors of position means for nothing (8-position, white noise:
    ±2σ coverage 0.974 with it, 0.959 without). The pooled REML sees the scatter of the position means, so a drift
    that matters for them is not missed by this test (8-position, τ = 300 s drift: 0.934)."""
    ok = lab >= 0
    if gm.readout_var > 0:  # white rate noise beside the known readout: its REML optimum by a 1-D search
        white = white_beside_readout(r, j, lab, t, gm)
        if gm_reml(r, j, lab, t, white) - gm_reml(r, j, lab, t, gm) >= WHITE_LR_CRITICAL:
            return gm
        return white
    e, _ = gls_residual(r[ok], j[ok])
    rank = np.linalg.matrix_rank(j[ok]) if j.shape[1] else 0
    var = float(e @ e) / max(int(ok.sum()) - rank, 1)
    if var <= 0:
        return gm
    white = GMNoise(gm.tau_s, 0.0, var)  # REML optimum of white noise: |ẽ|²/(n − p)
    if gm_reml(r, j, lab, t, white) - gm_reml(r, j, lab, t, gm) >= WHITE_LR_CRITICAL:
        return gm
    return ARNoise(np.zeros(0), float(np.sqrt(var)), float(np.sqrt(var)))


def group_series(lin, idx):
    """(r, J, labels, times) of the records ``idx`` of ``lin`` stacked as independent series: labels kept apart,
    each record's clock (s) restarted at 0, so that the noise model restarts at each record."""
    rs, js, labs, ts, off = [], [], [], [], 0
    for i in idx:
        r, j, lab, t = lin[i]
        rs.append(r)
        js.append(j)
        labs.append(lab + off)
        ts.append(t - t[0] if len(t) else t)
        off += int(lab.max()) + 1 if len(lab) else 0
    return tuple(np.concatenate(v) for v in (rs, js, labs, ts))


# ---- small-sample correction ------------------------------------------------------------------------------------

INTERVAL_LEVEL = 0.97725
"""P(Z ≤ 2): standard errors are widened so that θ̂ ± 2σ keeps this one-sided level under Student's t."""


def satterthwaite_dof(lin, campaign: Campaign, noises, scales) -> np.ndarray:
    """Effective degrees of freedom ν_k of each coefficient's GLS variance V_k when the Gauss–Markov noise
    parameters are estimated (Satterthwaite 1946, as Giesbrecht & Burns 1985 apply it to REML fits):
    ν_k = 2 V_k² / Var(V̂_k), Var(V̂_k) ≈ ∇V_kᵀ I⁻¹ ∇V_k, with I the REML information of each group's
    u = (log τ, log σ_g², log σ_w²) — half the Hessian of −2 log L_R, by central differences of its exact gradient
    (:func:`gyrojax.noise.reml.reml_hessian`) — and ∇V_k = −diag(V ∂(J̃ᵀJ̃)/∂u V), the derivative by central
    differences of the compiled whitened Gram matrix (:func:`gyrojax.noise.reml.whitened_gram`).

    Drift slower than a position is seen only in the scatter of the position means: an 8-position test leaves a
    handful of such degrees of freedom, and a plug-in σ̂ then covers ±2σ in ~0.88 of the cases, not 0.954.
    A τ at its cap is held fixed. Records with an AR or white model add nothing (their ν is large).
    Returns ν (dimensionless, ≥ 1; ``inf`` where no noise parameter was estimated).
    """
    rw, jw = stack_whitened(lin, noises, scales)
    cov = solve(jw, rw)[1]
    v0 = np.diag(cov)
    var_v = np.zeros_like(v0)
    for idx in noise_groups(campaign):
        nz = noises[idx[0]]
        if not isinstance(nz, GMNoise) or nz.gm_var <= 0 or nz.white_var <= 0:
            continue
        r, j, lab, t = group_series(lin, idx)
        theta = (nz.tau_s, nz.gm_var, nz.white_var)
        series = reml.prepare(r, j, lab, t, FIT_TAU_SPAN_FRACTION)
        free = [1, 2] if nz.tau_s >= 0.999 * series.tau_max else [0, 1, 2]
        hess = reml.reml_hessian(series, theta)[np.ix_(free, free)]
        if not np.all(np.isfinite(hess)):
            names = ", ".join(campaign.records[i].name for i in idx)
            warnings.warn(
                f"the REML curvature of the noise of records {names} is not finite at its estimate"
                ": their Satterthwaite degrees of freedom are not computed and the standard errors are "
                "not widened for the estimated noise",
                ConvergenceWarning,
                stacklevel=3,
            )
            continue
        w, vec = np.linalg.eigh(0.5 * (hess + hess.T))  # −2 log L_R: information = hess / 2
        w = np.maximum(w, 1e-9 * max(float(w.max()), 1e-300))
        cov_u = 2.0 * (vec / w) @ vec.T
        _, dgram = reml.whitened_gram(reml.prepare(r, j, lab, t, FIT_TAU_SPAN_FRACTION, select=False), theta)
        grad = -np.einsum("ki,ija,jk->ka", cov, dgram, cov)[:, free]  # ∂V_k/∂u = −(V ∂A/∂u V)_kk
        var_v += np.einsum("ka,ab,kb->k", grad, cov_u, grad)
    with np.errstate(divide="ignore", invalid="ignore"):
        nu = np.where(var_v > 0, 2.0 * v0**2 / var_v, np.inf)
    return np.maximum(np.nan_to_num(nu, nan=np.inf), 1.0)


def small_sample_factor(nu) -> np.ndarray:
    """t_ν / z at :data:`INTERVAL_LEVEL` (dimensionless, ≥ 1; 1 for ν = ∞): the widening of a standard error
    whose variance has ν effective degrees of freedom."""
    nu = np.asarray(nu, dtype=float)
    z = stats.norm.ppf(INTERVAL_LEVEL)
    return np.where(np.isfinite(nu), stats.t.ppf(INTERVAL_LEVEL, np.where(np.isfinite(nu), nu, 1.0)) / z, 1.0)


def _rms(r) -> float:
    return float(np.sqrt(np.mean(r * r))) if len(r) else 0.0


def noise_scale(r, labels) -> float:
    """Initial per-record noise level in the residual's unit (deg/h or g): from the residual's first differences
    (:func:`gyrojax.noise.whiten.first_difference_std`), floored for noise-free data."""
    return max(first_difference_std(r, labels), 1e-9 * _rms(r), 1e-15)


def solve(jw, rw, rank_tol=ALIAS_TOL):
    """Least-squares step and (JᵀJ)⁻¹ in normalised columns, by SVD with a rank cut
    (:func:`gyrojax.inference.lstsq.lstsq`). Floating-point residue columns (:func:`residue_columns`) get no step
    and no finite uncertainty."""
    if jw.shape[1]:
        jw = np.where(residue_columns(jw), 0.0, jw)
    return lstsq(jw, rw, "svd", rank_tol)


def _least_squares(model: Model, theta, campaign: Campaign, noises, scales, max_iter: int):
    """θ minimising the weighted (``noises[i] is None``: divided by ``scales[i]``) or whitened residual of every
    record, for fixed noise models. Returns (θ, iterations, reason it did not converge or ``""``).

    A model linear in θ needs one solve (:func:`_solve`, rank-cut SVD). The nonlinear set-up effects (table tilt
    and azimuth, encoder harmonics; CONVENTIONS §6) are fitted by Levenberg–Marquardt
    (``scipy.optimize.least_squares``, method ``"lm"``, MINPACK) with the exact ``jax.jacfwd`` Jacobian, so a start
    far from the optimum is damped instead of overshooting. The trust region is measured in report units (arcsec,
    ppm, deg/h …, the natural scale of each coefficient): scaling it by the Jacobian's columns instead lets the
    first steps wander along the weakly seen set-up angles when a record is nearly noise-free. The whitening is
    linear in the data, so the whitened residual and Jacobian of :func:`stack_whitened` are exact for the solver too.
    """
    if model.is_linear or model.size == 0:
        rw, jw = stack_whitened(linearize(model, theta, campaign), noises, scales)
        step, _ = solve(jw, rw)
        return theta + step, 1, ""
    cache = {}

    def system(th):
        key = th.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = stack_whitened(linearize(model, th, campaign), noises, scales)
        return cache[key]

    sol = least_squares(
        lambda th: -system(th)[0],
        np.asarray(theta, dtype=float),
        jac=lambda th: system(th)[1],
        method="lm",
        x_scale=1.0,
        xtol=1e-12,
        ftol=1e-12,
        gtol=1e-12,
        max_nfev=max_iter * (model.size + 1),
    )
    why = "" if sol.status > 0 else f"Levenberg–Marquardt stopped after {sol.nfev} evaluations: {sol.message}"
    return np.asarray(sol.x, dtype=float), int(sol.nfev), why


def _noise_not_converged(noises) -> str:
    """Reason a noise model's fit did not converge (an object with ``converged`` False), or ``""``."""
    bad = [nz for nz in noises if nz is not None and getattr(nz, "converged", True) is False]
    if not bad:
        return ""
    return "the noise model's fit did not converge" + (f" ({bad[0].note})" if getattr(bad[0], "note", "") else "")


def fit(
    records,
    terms=None,
    *,
    kind: str | None = None,
    noise: str = "ar",
    allow_aliases: bool = False,
    theta0=None,
    max_iter: int = 30,
    campaign: Campaign | None = None,
) -> FitResult:
    """Fit the named effects ``terms`` to ``records`` jointly (CONVENTIONS §6 names).

    Args:
      records: a :class:`Record`, or a list of records of one instrument kind (any plans, mountings, modes).
      terms: effect names (or coefficient names); default: D_F, D_I, D_O, D_S for an SDF gyro.
      noise: ``"ar"`` (GLS with a white + Gauss–Markov or AR noise model per group of records, :func:`campaign_noise`;
        default), ``"white"`` (WLS, one σ per record), or a given noise model with a ``whitening_model(dt_s)``
        method (e.g. :class:`gyrojax.noise.gmwm.NoiseModel` from ``gyrojax noise``): GLS with that covariance, not
        re-estimated, and the standard errors not rescaled by the residual χ² (the noise is known).
      allow_aliases: return a minimum-norm fit instead of raising when the plan cannot separate some effects
        (those coefficients then have no finite standard error).
      theta0: starting coefficients (report units) for the nonlinear set-up effects.

    Returns: a :class:`FitResult`.

    Raises: :class:`IdentifiabilityError` naming the effects the plan cannot tell apart.
    """
    if campaign is None and _is_triad(records):  # a hand-moved IMU: per-channel fit (gyrojax.inference.triad)
        from gyrojax.inference.triad import fit_triad

        return fit_triad(records, terms, allow_aliases=allow_aliases)
    camp = campaign or Campaign.of(records)
    kind = kind or camp.kind
    model = Model.of(terms if terms is not None else DEFAULT_TERMS[kind], kind)
    check_terms(model, camp)
    theta = np.zeros(model.size) if theta0 is None else np.asarray(theta0, dtype=float).copy()
    n_rec = len(camp.records)

    # white pass: per-record σ from the high-frequency residual; one solve, or Levenberg–Marquardt when nonlinear
    lin = linearize(model, theta, camp)
    scales = [noise_scale(r, lab) for r, _, lab, _ in lin]
    noises = [None] * n_rec
    rw, jw = stack_whitened(lin, noises, scales)
    report = identifiability(jw, model)
    if (report["aliases"] or report["unexcited"]) and not allow_aliases:
        raise IdentifiabilityError(alias_message(report), report)
    theta, it, why = _least_squares(model, theta, camp, noises, scales, max_iter)
    lin = linearize(model, theta, camp)
    # noise model and GLS pass
    known = hasattr(noise, "whitening_model")  # a given noise model (e.g. gmwm.NoiseModel): GLS, not re-estimated
    if known:
        if kind == fx.ACCEL:
            raise ModelError(f"a noise model in deg/h applies to gyro records, not to {kind!r}")
        noises = [noise.whitening_model(float(np.median(np.diff(t)))) for *_, t in lin]
        for _ in range(3 if not model.is_linear else 1):
            rw, jw = stack_whitened(lin, noises, scales)
            step, _ = solve(jw, rw)
            theta = theta + step
            lin = linearize(model, theta, camp)
    elif noise == "ar":
        noises = campaign_noise(lin, camp)
        theta, it_gls, why_gls = _least_squares(model, theta, camp, noises, scales, max_iter)
        it, why = it + it_gls, why or why_gls
        lin = linearize(model, theta, camp)
        why = why or _noise_not_converged(noises)
    elif noise != "white":
        raise ModelError(f"noise must be 'ar' or 'white', got {noise!r}")
    else:
        scales = [max(float(np.std(r)), 1e-9 * _rms(r), 1e-15) for r, *_ in lin]
    rw, jw = stack_whitened(lin, noises, scales)
    report = identifiability(jw, model)
    if len(rw) - report["rank"] < 1:
        raise ModelError(
            f"{len(rw)} measurement(s) for {report['rank']} coefficient(s): no degrees of freedom are left to "
            "estimate the noise, so no standard error can be stated; add samples or drop effects"
        )
    _, cov = solve(jw, rw)
    dof = max(len(rw) - report["rank"], 1)
    chi2 = float(rw @ rw)
    if not known:
        cov = cov * chi2 / dof  # the noise levels were estimated: scale by the pooled reduced χ² of the whitened fit
    dof_eff = None
    if noise == "ar" and any(isinstance(nz, GMNoise) for nz in noises):
        dof_eff = satterthwaite_dof(lin, camp, noises, scales)
        g = small_sample_factor(dof_eff)
        cov = cov * np.outer(g, g)  # Student-t widening: θ̂ ± 2σ keeps its coverage when ν is small
    noise_models = [nz if nz is not None else ARNoise(np.zeros(0), s, s) for nz, s in zip(noises, scales)]
    if why:
        warnings.warn(f"fit of {', '.join(model.terms)} did not converge: {why}", ConvergenceWarning, stacklevel=2)
    return FitResult(
        model=model,
        theta=theta,
        cov=cov,
        residuals=[r for r, *_ in lin],
        labels=[lab for _, _, lab, _ in lin],
        record_names=[r.name for r in camp.records],
        record_paths=[r.path for r in camp.records],
        noise=noise_models,
        identifiability=report,
        n_samples=camp.n_measurements,
        iterations=it,
        converged=not why,
        convergence_note=why,
        chi2_whitened=chi2,
        dof=dof,
        inputs=_hash_inputs(camp.records),
        dof_eff=dof_eff,
    )


def fit_per_instrument(records, terms=None, **kw) -> dict:
    """One :func:`fit` per instrument (:func:`instrument_id`), never pooled: ``{id: FitResult}``."""
    return {k: fit(v, terms, **kw) for k, v in split_by_instrument(records).items()}
