"""The result of a triad fit: per-channel coefficients with their covariance, the matrix forms (b, S, G; imucal's
and Kalibr's), the calibration of records by the fitted model, and the saved file it is read back from
(:mod:`gyrojax.protocol`, format :data:`~gyrojax.inference.formats.TRIAD_FORMAT`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyrojax import protocol, tails, units
from gyrojax.data.records import Record
from gyrojax.data.triad import TRIAD_KIND, acc_g, gyro_dph
from gyrojax.errors import FormatError, ModelError
from gyrojax.inference.formats import LEGACY_FORMAT, TRIAD_FORMAT, TRIAD_VERSION, fit_kind
from gyrojax.inference.result import Estimates
from gyrojax.inference.scoring import ALPHA
from gyrojax.inference.triad_turn_on import BIAS, STEP, TURN_ON, is_step, split_terms
from gyrojax.noise.spec import SessionNoise
from gyrojax.physics import triad as tp


@dataclass
class TriadFit(Estimates):
    """Per-channel coefficients of a gyro triad with their covariance, the matrix forms and fit statistics."""

    model: object
    names: list
    theta: np.ndarray
    cov: np.ndarray
    segments: list
    residuals: np.ndarray  # (m,) raw residual of each segment mean, deg/h
    noise_q: np.ndarray
    chi2: float
    dof: int
    earth_mode: str
    record_names: list
    not_excited: list
    counts_per_dps: float | None = None
    notes: list = field(default_factory=list)
    iterations: int = 1  # evaluations of the moves' Levenberg–Marquardt fit (1: no moves, one linear solve)
    converged: bool = True
    convergence_note: str = ""  # why the moves' fit did not converge ("" when it did)
    variance_components: dict = field(default_factory=dict)  # REML: pose bias scatter deg/h, move angle noise deg
    segment_residuals: list = field(default_factory=list)  # per pose/rotation/move: whitened, natural, chi2
    accelerometer: dict | None = None  # imu_tk's 9 parameters with σ (inference.triad_accel.accelerometer_json)
    dt_s: float | None = None  # the records' sample interval, s (None: a file that did not keep it)

    def chi2_drivers(self, top: int = 3) -> list:
        """The segments with the largest share of χ² (white-noise model): [(name, share)], largest first."""
        rows = sorted(self.segment_residuals, key=lambda r: -r["chi2"])[:top]
        total = sum(r["chi2"] for r in self.segment_residuals) or 1.0
        return [(r["name"], r["chi2"] / total) for r in rows]

    @property
    def coefficient_names(self) -> list:
        """Per-channel coefficient names ``D_F[x]`` … in θ order (the keys of :attr:`values`, :attr:`stds`), then
        the power-ups' bias steps ``D_F_step_<k>[x]`` … of ``bias_turn_on`` (:mod:`gyrojax.inference.triad_turn_on`)."""
        return self.names

    @property
    def terms(self) -> tuple:
        """The effect names of the fit: the channel model's, and ``bias_turn_on`` when power-ups' steps are fitted."""
        return tuple(self.model.terms) + ((TURN_ON,) if self.power_ups > 1 else ())

    @property
    def power_ups(self) -> int:
        """Power-ups with a bias of their own (1: no ``bias_turn_on``)."""
        return 1 + sum(map(is_step, self.names)) // 3

    @property
    def channel_theta(self) -> np.ndarray:
        """The channel model's coefficients (3p,), report units: θ without the power-ups' steps."""
        return np.asarray(self.theta, dtype=float)[: 3 * self.model.size]

    def units(self) -> dict:
        """Coefficient name → report unit."""
        u = self.model.coefficient_units
        out = {tp.channel_name(c, ch): uu for ch in tp.CHANNELS for c, uu in zip(self.model.coefficient_names, u)}
        return out | {n: "deg/h" for n in self.names if is_step(n)}

    @property
    def residual_rms(self) -> float:
        """RMS of the segment-mean residuals, deg/h."""
        return float(np.sqrt(np.mean(self.residuals**2))) if self.residuals.size else float("nan")

    @property
    def noise_floor(self) -> float:
        """RMS of the per-sample noise of the channels, deg/h (√ of the mean long-run variance q)."""
        return float(np.sqrt(np.mean(self.noise_q)))

    @property
    def noise(self) -> SessionNoise | None:
        """The session's noise (:class:`~gyrojax.noise.spec.SessionNoise`): each channel's long-run variance as its
        white term at :attr:`dt_s`, and the variance components between segments (None without ``dt_s``)."""
        if not self.dt_s:
            return None
        comp = self.variance_components
        pose, move = comp.get("pose_bias_scatter_deg_per_h", 0.0), comp.get("move_angle_noise_deg", 0.0)
        walk = comp.get("bias_walk_deg_per_h_per_sqrt_pose", 0.0)  # where the fit's σ carry a walk
        return SessionNoise.of_sample_variances(
            self.noise_q, self.dt_s, pose_bias_scatter=pose, move_angle_noise=move, bias_walk=walk
        )

    @property
    def chi2_p_value(self) -> float:
        """P(χ²_dof > χ²) of the white-noise model (NaN without degrees of freedom)."""
        return float(tails.chi2_sf(self.chi2, self.dof)) if self.dof > 0 else float("nan")

    def matrices(self) -> dict:
        """b (deg/h), S, G (deg/h/g) of ω_ind = S ω + G a + b (:func:`gyrojax.physics.triad.matrices`)."""
        return tp.matrices(self.values)

    def misalignment_angles(self) -> dict:
        """The misalignments as angles between each sensing axis and the body frame, arcsec, with σ: independent of
        the nominal scale (:func:`gyrojax.physics.triad.misalignment_angles`); ``M_O[c]``, ``M_S[c]`` toward the
        channel's output and spin axes, ``psi[c]`` in all."""
        angles = tp.misalignment_angles(self.values, self.cov, self.names)
        out = {"definition": "atan(M / (1 + E_SF)): the rows of S normalised, independent of the nominal scale"}
        for k, v in angles.items():
            out[k] = {**v, "std": protocol.strict(v["std"])}
        return out

    def apply(self, record: Record) -> np.ndarray:
        """Calibrated body rates (n, 3) deg/h of a triad record: the model the fit used solved for ω
        (:func:`gyrojax.physics.triad.body_rates`: ω = S⁻¹ (ω_ind − b − G a) for the linear model; g²-terms, E_A,
        E_2, trend (at the record's ``time_s``) and temperature (its ``temperature_C`` column) included). The Earth
        rate is part of ω, as a navigator wants it. Refuses a record without the accelerometer columns when the
        model has g-terms, without ``temperature_C`` when it has ``bias_temperature``, and an inversion that does
        not reproduce the indicated rates (to 1e-9 of their size). With ``bias_turn_on``, a record of a fitted
        power-up (by name) is calibrated with its own bias, any other with the first power-up's."""
        theta = self.channel_theta.copy()
        if record.name in self.record_names[1:] and self.power_ups > 1:
            k = self.record_names.index(record.name)
            for c, ch in enumerate(tp.CHANNELS):
                i = c * self.model.size + self.model.coefficient_names.index(BIAS)
                theta[i] += self.values[tp.channel_name(f"{STEP}_{k}", ch)]
        return calibrated_rates(self.model, theta, record, self.accelerometer)

    def specific_force(self, record: Record) -> np.ndarray | None:
        """Calibrated specific force (n, 3) g of a triad record by the fitted accelerometer model (imu_tk's
        a_cal = T K (a − b)); the record's own when the fit has no accelerometer model (fewer than 9 poses, whose
        |a| the fit then checked against g); None without accelerometer columns."""
        return _specific_force(record, self.accelerometer)

    def to_json(self) -> dict:
        """The fit JSON (conventions §7 shape, per-channel names ``D_F[x]``), with the matrix forms."""
        from gyrojax import __version__

        coeffs = {}
        unit = self.units()
        for n, v, s in zip(self.names, self.theta, self.std):
            coeffs[n] = {"value": float(v), "std": protocol.strict(s), "unit": unit[n]}
        m = self.matrices()
        k = self.counts_per_dps or 1.0
        ic = tp.imucal_form(m, k, rotation_sign=-1.0)
        kal = tp.kalibr_form(m)
        p = self.chi2_p_value
        return {
            "terms": list(self.terms),
            "instrument": TRIAD_KIND,
            "channels": list(tp.CHANNELS),
            "coefficients": coeffs,
            "residual_rms_deg_per_h": self.residual_rms,
            "n_samples": int(sum(s.n for s in self.segments)),
            "records": [{"name": n} for n in self.record_names],
            "not_excited": list(self.not_excited),
            "matrices": {
                "model": "omega_ind = S omega + G a + b (deg/h, a in g)",
                "b_deg_per_h": m["b"].tolist(),
                "S": m["S"].tolist(),
                "G_deg_per_h_per_g": m["G"].tolist(),
                "imucal": {
                    "model": "raw = K_g R_g omega + K_ga a + b_g (omega deg/s, a m/s^2 with grav "
                    f"{tp.IMUCAL_GRAVITY:g}, raw counts); "
                    "R_g for imucal's default expected_angle -360",
                    "counts_per_dps": k,
                    **{key: np.asarray(v).tolist() for key, v in ic.items() if key.startswith(("K", "R", "b"))},
                },
                "kalibr": {
                    "model": "omega_m = C_gyro_i M omega + A a + b (rad/s, a m/s^2)",
                    **{key: np.asarray(v).tolist() for key, v in kal.items() if key in ("C_gyro_i", "M", "A", "b")},
                },
            },
            **({"misalignment_angles": self.misalignment_angles()} if "ia_misalignment" in self.model.terms else {}),
            "earth_rate": {"mode": self.earth_mode, "rate_deg_per_h": units.OMEGA_IE_DEG_PER_H},
            "noise": {
                ch: {"long_run_std_deg_per_h_sqrt_sample": float(np.sqrt(q))}
                for ch, q in zip(tp.CHANNELS, self.noise_q)
            },
            "segments": [
                {"name": s.name, "kind": s.kind, "n": s.n, "residual_deg_per_h": r.tolist(), **_jsonable(s.info)}
                for s, r in zip(self.segments, self.residuals.reshape(-1, 3))
            ],
            "variance_components": dict(self.variance_components),
            **({"noise_model": self.noise.to_json()} if self.dt_s else {}),
            "segment_residuals": [dict(r) for r in self.segment_residuals],
            "fit": {
                "chi2": self.chi2,
                "dof": self.dof,
                "p_value": protocol.strict(p),
                "iterations": self.iterations,
                "converged": self.converged,
                **({"reason": self.convergence_note} if not self.converged else {}),
            },
            "notes": list(self.notes),
            "alpha": ALPHA,
            **({"accelerometer": self.accelerometer} if self.accelerometer else {}),
            "gyrojax_version": __version__,
        }

    def save(self, path, force: bool = False) -> Path:
        """Write :meth:`to_json` plus what :func:`load_triad_fit` needs to rebuild the fit (``names``, ``theta``,
        ``cov``, the residuals, the noise variances q, the counts scale) to ``path`` atomically as strict JSON,
        tagged :data:`~gyrojax.inference.formats.TRIAD_FORMAT` version
        :data:`~gyrojax.inference.formats.TRIAD_VERSION`; an existing file is an error unless ``force``. The
        segments' sample arrays are not stored (their summary is, in ``segments``). Returns the path."""
        d = self.to_json()
        d.update(
            names=list(self.names),
            theta=self.theta,
            cov=self.cov,
            residuals=self.residuals,
            noise_q=self.noise_q,
            counts_per_dps=self.counts_per_dps,
            dt_s=self.dt_s,
        )
        return protocol.save(path, d, TRIAD_FORMAT, TRIAD_VERSION, force=force)


G_TERMS = ("D_I", "D_O", "D_S", "D_II", "D_OO", "D_SS", "D_IO", "D_IS", "D_OS")
INVERSION_RTOL = 1e-9  # relative residual of the indicated rates above which apply's inversion has failed


def _specific_force(record: Record, accelerometer: dict | None):
    from gyrojax.data.segments import imutk_acc_model

    a = acc_g(record)
    if a is None or not accelerometer:
        return a
    return imutk_acc_model(np.asarray(accelerometer["params"], dtype=float), a)


def calibrated_rates(model, theta, record: Record, accelerometer: dict | None = None) -> np.ndarray:
    """Body rates (n, 3) deg/h of a triad ``record`` under the channel ``model`` at ``theta`` (3p,), report units
    (:meth:`TriadFit.apply`); the g-terms at the specific force as the fit saw it (calibrated by ``accelerometer``
    when the fit calibrated it before the gyro fit). The inversion is checked against the forward model, never
    returned unchecked."""
    g = gyro_dph(record)
    a = _specific_force(
        record, accelerometer if accelerometer and accelerometer.get("calibrated_before_gyro_fit") else None
    )
    th = np.asarray(theta, dtype=float).reshape(3, model.size)
    if a is None:
        uses_g = [n for n, v in zip(model.coefficient_names, th.T) if n in G_TERMS and np.any(v != 0)]
        if uses_g:
            raise ModelError(f"{record.name}: the fit has g-sensitivity {uses_g} but no acc_<c>_g columns")
        a = np.zeros_like(g)
    t_h = np.asarray(record.time_s, dtype=float) / units.SECONDS_PER_HOUR
    temp = record.columns.get("temperature_C")
    if temp is None:
        if "bias_temperature" in model.terms:
            raise ModelError(f"{record.name}: the fit has bias_temperature but the record has no temperature_C column")
        temp = np.full(len(g), 20.0)
    temp = np.asarray(temp, dtype=float)
    w = np.asarray(tp.body_rates(model, th, g, a, t_h, temp))
    back = np.asarray(tp.triad_output(model, th, w, a, t_h, temp))
    err = float(np.max(np.abs(back - g))) if len(g) else 0.0
    if not np.isfinite(err) or err > INVERSION_RTOL * max(float(np.max(np.abs(g))), 1.0):
        raise ModelError(
            f"{record.name}: the fitted model cannot be inverted for the body rate at every sample (largest "
            f"indicated-rate mismatch {err:.3g} deg/h): its rate-nonlinear terms are too large for these rates"
        )
    return w


def _jsonable(d: dict) -> dict:
    return {k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v) for k, v in d.items()}


def load_triad_fit(path) -> TriadFit:
    """A triad fit saved by :meth:`TriadFit.save` (or by 0.2, format ``gyrojax-fit-1``), equal to the saved one
    but for its segments, whose sample arrays are not stored (:attr:`TriadFit.segments` is empty). Raises
    :class:`~gyrojax.errors.FormatError` naming the file and the key, and naming a turntable fit as such."""
    p = Path(path)
    try:
        d = protocol.read_json_file(p, FormatError, "a saved imu-triad fit")
    except FormatError as e:
        raise FormatError(f"cannot read a fit result: {e}") from None
    kind = fit_kind(d)
    if kind == "turntable":
        raise FormatError(
            f"{p}: a turntable fit result (format {d.get('format')!r}), not an imu-triad fit; read it with "
            "gyrojax.inference.result.FitResult.load"
        )
    if kind is None or "theta" not in d:
        raise FormatError(f"{p}: not a saved imu-triad fit (save one with `gyrojax fit RECORDS --save FIT.json`)")
    if d.get("format") != LEGACY_FORMAT:
        d = protocol.check(d, TRIAD_FORMAT, TRIAD_VERSION, str(p))
    try:
        return _triad_fit_of(d)
    except (KeyError, TypeError, ValueError, IndexError) as e:
        raise FormatError(
            f"{p}: a damaged imu-triad fit ({type(e).__name__}: {e}); save it again with `fit --save`"
        ) from None


def _triad_fit_of(d: dict) -> TriadFit:
    """The :class:`TriadFit` of a saved file's dict. 0.2's files kept the noise only as its square root per
    channel and the residuals only per segment: both come back from there."""
    model = tp.channel_model(split_terms(d["terms"])[0])
    if "noise_q" in d:
        q = protocol.floats(d["noise_q"])
    else:
        q = np.array([d["noise"][ch]["long_run_std_deg_per_h_sqrt_sample"] ** 2 for ch in tp.CHANNELS])
    if "residuals" in d:
        res = protocol.floats(d["residuals"])
    else:
        res = protocol.floats([x for s in d.get("segments", []) for x in s["residual_deg_per_h"]])
    return TriadFit(
        model,
        list(d["names"]),
        protocol.floats(d["theta"]),
        protocol.floats(d["cov"]),
        [],
        res,
        q,
        float(d["fit"]["chi2"]),
        int(d["fit"]["dof"]),
        d["earth_rate"]["mode"],
        [r["name"] for r in d["records"]],
        list(d.get("not_excited", [])),
        counts_per_dps=d.get("counts_per_dps", d["matrices"]["imucal"].get("counts_per_dps")),
        notes=list(d.get("notes", [])),
        iterations=int(d["fit"].get("iterations", 1)),
        converged=bool(d["fit"].get("converged", True)),
        convergence_note=str(d["fit"].get("reason", "")),
        variance_components={k: float(v) for k, v in d.get("variance_components", {}).items()},  # version 2
        segment_residuals=[dict(r) for r in d.get("segment_residuals", [])],
        accelerometer=d.get("accelerometer"),  # absent in files before the accelerometer was fitted
        dt_s=d.get("dt_s"),
    )
