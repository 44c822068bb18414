"""The result of a campaign fit: estimates with units, standard errors, correlation, residuals and fit statistics,
its JSON (conventions §7) and the saved file it is read back from."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from gyrojax import protocol, tails
from gyrojax.data.arrays import record_data
from gyrojax.data.record import Record
from gyrojax.errors import FormatError, ModelError
from gyrojax.inference.formats import LEGACY_FORMAT, RESULT_FORMAT, RESULT_VERSION, fit_kind
from gyrojax.inference.noisefit import small_sample_factor
from gyrojax.inference.scoring import ALPHA
from gyrojax.noise.spec import NoiseSpec
from gyrojax.noise.whiten import first_difference_std
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model, predict_jit


class Estimates:
    """The views every fit result shares, from its ``theta``, ``cov`` and ``coefficient_names``."""

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


@dataclass
class FitResult(Estimates):
    """Estimates with units, standard errors, correlation, residuals per record and fit statistics."""

    model: Model
    theta: np.ndarray
    cov: np.ndarray
    residuals: list  # raw residual per record (measurements only), output units
    labels: list
    record_names: list
    record_paths: list
    noise: list  # noise model of each record (NoiseSpec; the records of one noise group share one)
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
    def terms(self) -> tuple:
        """The effect names of the fit (the model's), as the next step of the main loop extends them."""
        return tuple(self.model.terms)

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
            return np.where(finite, 2 * tails.t_sf(t, np.where(finite, nu, 1.0)), 2 * tails.norm_sf(t))

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

    def _stored_residuals(self) -> list:
        """The residuals of each record, or ``None`` for each when they were not kept (a loaded result)."""
        return self.residuals if len(self.residuals) == len(self.record_names) else [None] * len(self.record_names)

    def units(self) -> dict:
        """Coefficient name -> report unit (``"deg/h"``, ``"deg/h/g"``, ``"ppm"``, ``"arcsec"`` …)."""
        return dict(zip(self.coefficient_names, self.model.coefficient_units))

    def to_json(self) -> dict:
        """The JSON of conventions §7 (``gyrojax fit --json``), with extra keys that tools may ignore; ``fit.converged``
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
                "significant": bool(p < ALPHA) if np.isfinite(p) else False,
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
                    **({"n": int(len(r)), "residual_rms": float(np.sqrt(np.mean(r * r)))} if r is not None else {}),
                    "noise_model": _noise_json(nz),
                }
                for n, p, r, nz in zip(self.record_names, self.record_paths, self._stored_residuals(), self.noise)
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
            "alpha": ALPHA,
            "gyrojax_version": __version__,
            "inputs": self.inputs,
        }

    def save(self, path, force: bool = False) -> Path:
        """Write :meth:`to_json` plus what :meth:`load` needs to rebuild the result (``theta``, ``cov``, the noise
        model of each record, the whole identifiability report, the Satterthwaite degrees of freedom) to ``path``
        atomically as strict JSON (``null`` for non-finite), tagged :data:`RESULT_FORMAT` version
        :data:`RESULT_VERSION` (:func:`gyrojax.protocol.save`); an existing file is an error unless ``force``.
        The residuals and segment labels of each record are not stored. Returns the path."""
        d = self.to_json()
        d["theta"] = self.theta
        d["cov"] = self.cov
        d["record_names"] = list(self.record_names)
        d["record_paths"] = list(self.record_paths)
        d["noise_models"] = [nz.to_json() for nz in self.noise]
        d["identifiability"] = dict(self.identifiability)
        d["dof_eff"] = None if self.dof_eff is None else np.asarray(self.dof_eff, dtype=float)  # ∞ saved as null
        return protocol.save(path, d, RESULT_FORMAT, RESULT_VERSION, force=force)

    @classmethod
    def load(cls, path) -> "FitResult":
        """A result written by :meth:`save`, equal to the saved one but for the residuals and labels, which are not
        stored (:attr:`residuals` and :attr:`labels` are empty). Raises :class:`~gyrojax.errors.FormatError` naming
        the file and the key when it is not a gyrojax fit result of a version this gyrojax reads, and saying so
        when it is an imu-triad fit."""
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


def _noise_json(nz: NoiseSpec) -> dict:
    """The per-record summary of a noise model in ``records[i].noise_model`` (per-sample stds, τ in s)."""
    if nz.gauss_markov:
        out = {
            "kind": "white+gauss_markov",
            "white_std": float(np.sqrt(nz.white_variance)),
            "gauss_markov_std": float(np.sqrt(nz.gm_variance)),
            "tau_s": float(nz.gm_tau),
            "innovation_std": nz.innovation_std,
            "std": nz.stationary_std,
            "converged": nz.converged,
        }
        if nz.readout_var > 0:  # a servo readout's angle error over the interval (gyrojax.noise.readout)
            out["readout_std"] = float(np.sqrt(nz.readout_var))
        return out
    return {
        "kind": "ar",
        "ar_order": int(nz.order),
        "innovation_std": nz.innovation_std,
        "std": nz.stationary_std,
        "converged": nz.converged,
    }


def _num(x):
    x = float(x)
    return x if math.isfinite(x) else None


def load_result(path) -> dict:
    """A saved fit result as a dict, after checking its format and version (:func:`gyrojax.protocol.check`; the
    0.2 files tagged ``gyrojax-fit-1`` are version 1); :class:`~gyrojax.errors.FormatError` naming the file and the
    key otherwise, and naming an imu-triad fit as such."""
    d = protocol.read_json_file(path, FormatError, "a gyrojax fit result")
    if fit_kind(d) == "triad":
        raise FormatError(
            f"{path}: an imu-triad fit (format {d.get('format')!r}), not a turntable fit result; read it with "
            "gyrojax.inference.triad_result.load_triad_fit"
        )
    d = protocol.check(d, RESULT_FORMAT, RESULT_VERSION, str(path), legacy={LEGACY_FORMAT: (RESULT_FORMAT, 1)})
    protocol.require(d, ("terms", "theta", "cov", "records", "n_samples"), str(path))
    return d


def result_from_json(d: dict, where: str = "fit result") -> FitResult:
    """Rebuild a :class:`FitResult` from the dict of a saved result (:func:`load_result`): everything but the
    residuals and labels. Files before version 2 kept each noise model only as its summary (``records[i]
    .noise_model``): white + Gauss–Markov comes back from it, an AR model with unknown (NaN) coefficients.
    ``where`` names the source in error messages."""
    try:
        model = Model(tuple(d["terms"]), d.get("instrument", fx.SDF))
        theta = protocol.floats(d["theta"])
        cov = protocol.floats(d["cov"])
        records = d["records"]
        names = d.get("record_names", [r["name"] for r in records])
        paths = d.get("record_paths", [r.get("path") for r in records])
        noises = (
            [NoiseSpec.from_json(n, f"{where}: key 'noise_models'") for n in d["noise_models"]]
            if "noise_models" in d
            else [_noise_of_summary(r.get("noise_model", {})) for r in records]
        )
    except (KeyError, TypeError, ValueError) as e:
        raise FormatError(f"{where}: cannot rebuild the fit ({type(e).__name__}: {e})") from None
    if theta.shape != (model.size,) or cov.shape != (model.size, model.size):
        raise FormatError(
            f"{where}: keys 'theta' {list(theta.shape)} and 'cov' {list(cov.shape)} do not match the "
            f"{model.size} coefficients of {list(model.terms)}"
        )
    fit_stats = d.get("fit", {})
    report = dict(d.get("identifiability", {}))
    if "condition" in report and report["condition"] is None:
        report["condition"] = math.inf  # a singular plan's condition number, saved as null
    return FitResult(
        model,
        theta,
        cov,
        [],
        [],
        list(names),
        list(paths),
        noises,
        report,
        d["n_samples"],
        iterations=int(fit_stats.get("iterations", 1)),
        converged=bool(fit_stats.get("converged", True)),
        convergence_note=str(fit_stats.get("reason", "")),
        chi2_whitened=float("nan") if fit_stats.get("chi2_whitened") is None else float(fit_stats["chi2_whitened"]),
        dof=int(fit_stats.get("dof", 0)),
        inputs=d.get("inputs", []),
        dof_eff=_dof_eff_of(d),
    )


def _noise_of_summary(s: dict) -> NoiseSpec:
    """A noise model from its summary in a file before version 2 (:func:`_noise_json`): per-sample variances, the
    sample interval not kept (taken as 1 s, so N here is the per-sample std / 60), AR coefficients unknown (NaN)."""
    if s.get("kind") == "white+gauss_markov":
        gm = [(float(s["gauss_markov_std"]) ** 2, float(s["tau_s"]))]
        q = float(s.get("readout_std", 0.0)) ** 2  # a servo readout's noise, when the file has one
        return NoiseSpec.from_sample_variances(float(s["white_std"]) ** 2, 1.0, gm, method="reml", readout_var=q)
    ar = (math.nan,) * int(s["ar_order"])
    return NoiseSpec.from_sample_variances(float(s["innovation_std"]) ** 2, 1.0, ar=ar, method="ar")


def _dof_eff_of(d: dict):
    """The Satterthwaite ν of each coefficient (``null`` is ∞), or ``None`` when the fit estimated none."""
    if "dof_eff" in d:
        return None if d["dof_eff"] is None else np.array([np.inf if v is None else v for v in d["dof_eff"]], float)
    nus = [d["coefficients"].get(c, {}).get("dof_eff") for c in d.get("coefficients", {})]
    return None if not nus or any(v is None for v in nus) else np.array(nus, dtype=float)
