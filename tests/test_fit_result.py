"""The fit result's promises: it saves and loads symmetrically with a checked format version; a fit that did not
converge warns and says so in its JSON; nonlinear set-up terms are fitted by a damped method that converges where
undamped Gauss–Newton overshoots; p-values use the same Student-t degrees of freedom as the widened σ."""

import dataclasses
import json
import warnings

import numpy as np
import pytest
from scipy import stats

from gyrojax.data import plans
from gyrojax.data.records import save_record
from gyrojax.errors import ConvergenceWarning, FormatError
from gyrojax.inference.campaign import Campaign, linearize
from gyrojax.inference.identify import fit
from gyrojax.inference.noisefit import INTERVAL_LEVEL
from gyrojax.inference.result import RESULT_VERSION, FitResult, result_from_json
from gyrojax.inference.triad_result import load_triad_fit
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics.model import Model
from gyrojax.simulation.simulator import simulate

from .roundtrip import assert_same, strict_json

LOCK_IN = 300.0  # deg/h
LADDER_DPS = (0.1, 0.2, 0.5, 1.0)  # highest rate 3600 deg/h


def _as_kind(plan, kind):
    runs = tuple(dataclasses.replace(r, instrument={**r.instrument, "kind": kind}) for r in plan.runs)
    return dataclasses.replace(plan, runs=runs)


@pytest.fixture(scope="module")
def rlg_ladder():
    """A ring-laser gyro on a rate ladder about Up (IA up), lock-in 300 deg/h, white noise 0.5 deg/h."""
    plan = _as_kind(plans.rate_ladder(rates_dps=LADDER_DPS, seconds=10, dt_s=0.5, mountings=("axial",)), "rlg")
    return simulate(plan, {"coefficients": {"D_F": 0.2, "Omega_L": LOCK_IN}, "noise": {"white": 0.5}}, seed=3)


def test_damped_fit_converges_where_gauss_newton_overshoots(rlg_ladder):
    """From Ω_L = 5 deg/h the lock-in output √(ω² − Ω_L²) is nearly flat in Ω_L, so the undamped Gauss–Newton step
    leaps past every rate of the ladder into the dead band, where the Jacobian vanishes and it stays. The
    Levenberg–Marquardt fit comes back to the truth."""
    theta0 = np.array([0.0, 5.0])
    model = Model(("D_F", "lock_in"), "rlg")
    lin = linearize(model, theta0, Campaign.of(rlg_ladder))
    r, j = lin[0][0], lin[0][1]
    gn = theta0 + np.linalg.lstsq(j, r, rcond=None)[0]
    assert gn[1] > max(LADDER_DPS) * 3600.0  # the undamped step lands in the dead band of every rate
    dead = linearize(model, gn, Campaign.of(rlg_ladder))[0][1]
    assert np.abs(dead[:, 1]).max() == 0.0  # and there the lock-in column is zero: Gauss–Newton cannot return
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        res = fit(rlg_ladder, ["D_F", "lock_in"], noise="white", theta0=theta0)
    assert res.converged and res.to_json()["fit"]["converged"] is True
    assert abs(res.values["Omega_L"] - LOCK_IN) < 4 * res.stds["Omega_L"]
    assert abs(res.values["D_F"] - 0.2) < 4 * res.stds["D_F"]
    # the optimum does not depend on the start
    again = fit(rlg_ladder, ["D_F", "lock_in"], noise="white", theta0=[0.0, 1000.0])
    np.testing.assert_allclose(again.theta, res.theta, rtol=1e-6)


def test_unconverged_fit_warns_and_says_so(rlg_ladder, tmp_path):
    with pytest.warns(ConvergenceWarning, match="did not converge"):
        res = fit(rlg_ladder, ["D_F", "lock_in"], noise="white", theta0=[0.0, 5.0], max_iter=1)
    assert not res.converged and "Levenberg–Marquardt" in res.convergence_note
    j = res.to_json()["fit"]
    assert j["converged"] is False and "evaluations" in j["reason"]
    back = FitResult.load(res.save(tmp_path / "bad.json"))
    assert back.converged is False and back.convergence_note == res.convergence_note


def test_save_load_round_trip(rlg_ladder, tmp_path):
    res = fit(rlg_ladder, ["D_F", "lock_in"], noise="ar", theta0=[0.0, 250.0])
    path = res.save(tmp_path / "fit.json")
    with pytest.raises(Exception, match="exists"):
        res.save(path)
    res.save(path, force=True)
    back = FitResult.load(path)
    np.testing.assert_array_equal(back.theta, res.theta)
    np.testing.assert_array_equal(back.cov, res.cov)
    assert back.model == res.model and back.dof == res.dof and back.record_names == res.record_names
    assert back.inputs == res.inputs and back.iterations == res.iterations
    np.testing.assert_array_equal(back.p_values, res.p_values)
    # what load gives back saves to the same file, except what is not stored (residuals)
    second = back.save(tmp_path / "again.json")
    a, b = json.loads(path.read_text()), json.loads(second.read_text())
    for key in ("terms", "theta", "cov", "coefficients", "fit", "format", "format_version", "inputs", "instrument"):
        assert a[key] == b[key], key
    # Satterthwaite degrees of freedom travel with the coefficients
    res.dof_eff = np.array([7.0, 12.5])
    back = FitResult.load(res.save(tmp_path / "nu.json"))
    np.testing.assert_array_equal(back.dof_eff, res.dof_eff)


@pytest.mark.parametrize(
    "edit, key",
    [
        (lambda d: d.update(format="imucal"), "'format'"),
        (lambda d: d.pop("format"), "'format'"),
        (lambda d: d.update(format_version=RESULT_VERSION + 1), "'format_version'"),
        (lambda d: d.update(format_version="1"), "'format_version'"),
        (lambda d: d.pop("cov"), "'cov'"),
        (lambda d: d.update(theta=[1.0]), "'theta'"),
    ],
)
def test_load_refuses_other_formats_naming_file_and_key(rlg_ladder, tmp_path, edit, key):
    res = fit(rlg_ladder, ["D_F", "sf_error"], noise="white")
    d = json.loads(res.save(tmp_path / "fit.json").read_text())
    edit(d)
    bad = tmp_path / "edited.json"
    bad.write_text(json.dumps(d))
    with pytest.raises(FormatError) as e:
        FitResult.load(bad)
    assert str(bad) in str(e.value) and key in str(e.value)
    assert "np.float64" not in str(e.value)


def test_load_reads_the_0_2_format(rlg_ladder, tmp_path):
    res = fit(rlg_ladder, ["D_F", "sf_error"], noise="white")
    d = json.loads(res.save(tmp_path / "fit.json").read_text())
    d["format"] = "gyrojax-fit-1"
    del d["format_version"]
    old = tmp_path / "old.json"
    old.write_text(json.dumps(d))
    np.testing.assert_array_equal(FitResult.load(old).theta, res.theta)
    np.testing.assert_array_equal(result_from_json(d).cov, res.cov)


def test_p_values_use_the_t_widening_of_the_standard_errors():
    """θ̂ ± 2σ is the t_ν interval at one-sided level 0.97725 (the σ is widened by t_ν/z), so a coefficient at
    exactly 2σ has p = 2·(1 − Φ(2)) = 0.0455 whatever ν; without estimated ν the residual dof are used."""
    model = Model(("D_F", "D_I", "D_O"))
    nu = np.array([3.0, 12.0, np.inf])
    theta = np.array([2.0, -2.0, 2.0])
    res = FitResult(model, theta, np.eye(3), [], [], [], [], [], {}, 100, dof=40, dof_eff=nu)
    np.testing.assert_allclose(res.p_values, 2 * stats.norm.sf(2.0), rtol=1e-5)  # L = 0.97725 ≈ Φ(2)
    # the plain statistic referred to Student's t at ν (scipy), by hand
    z = stats.norm.ppf(INTERVAL_LEVEL)
    plain = 2.0 * stats.t.ppf(INTERVAL_LEVEL, 3.0) / z
    assert res.p_values[0] == pytest.approx(2 * stats.t.sf(plain, 3.0), rel=1e-12)
    # no Satterthwaite ν: σ is not widened and the p-value is Student's t at the residual dof
    res = FitResult(model, theta, np.eye(3), [], [], [], [], [], {}, 100, dof=5)
    np.testing.assert_allclose(res.p_values, 2 * stats.t.sf(2.0, 5), rtol=1e-12)
    assert res.p_values[0] > 2 * stats.norm.sf(2.0)


def test_error_messages_print_plain_numbers(rlg_ladder, tmp_path):
    """Messages show numbers as a person writes them (27.3, nan), never as ``np.float64(27.3)``."""
    rec = rlg_ladder[0]
    cur = rec.columns["current_mA"].copy()
    cur[3] = np.nan
    msgs = []
    with pytest.raises(Exception) as e:
        fit([rec.with_columns(current_mA=cur)], ["D_F"])
    msgs.append(str(e.value))
    t = rec.columns["time_s"].copy()
    t[5] = t[4]
    with pytest.raises(Exception) as e:
        save_record(rec.with_columns(time_s=t), tmp_path)
    msgs.append(str(e.value))
    assert "holds nan" in msgs[0] and "previous row's 2.0 (got 2.0)" in msgs[1]
    for m in msgs:
        assert "np.float64" not in m and "np.int64" not in m, m


def _synthetic_result() -> FitResult:
    """A result holding every kind of value a file must carry: three noise models (AR(2), white + Gauss–Markov,
    white), an unseen direction (NaN covariance, infinite condition number), ν = ∞ beside a finite ν."""
    model = Model(("D_F", "D_I"))
    noise = [
        NoiseSpec.from_sample_variances(0.09, 2.0, ar=(0.5, -0.2), method="ar"),
        NoiseSpec.from_sample_variances(0.25, 2.0, [(0.04, 120.0)], method="reml").with_status(False, "cut short"),
        NoiseSpec.from_sample_variances(0.25, 2.0, method="ar"),
    ]
    cov = np.array([[0.01, np.nan], [np.nan, np.nan]])
    report = {
        "rank": 1,
        "size": 2,
        "condition": np.inf,
        "aliases": [["D_F", "D_I"]],
        "unexcited": [],
        "singular_values": [1.4, 0.0],
    }
    inputs = [{"name": f"r{i}", "path": f"/data/r{i}.json", "sha256": "0" * 64} for i in range(3)]
    return FitResult(
        model,
        np.array([0.42, -1e-3]),
        cov,
        [],
        [],
        ["r0", "r1", "r2"],
        ["/data/r0.json", None, "/data/r2.json"],
        noise,
        report,
        300,
        iterations=4,
        converged=False,
        convergence_note="stopped",
        chi2_whitened=297.5,
        dof=298,
        inputs=inputs,
        dof_eff=np.array([7.5, np.inf]),
    )


def test_saved_fit_loads_back_whole_noise_models_included(rlg_ladder, tmp_path):
    """Everything but the residuals and labels (documented as not stored) comes back equal, field by field."""
    for i, res in enumerate(
        (fit(rlg_ladder, ["D_F", "lock_in"], noise="ar", theta0=[0.0, 250.0]), _synthetic_result())
    ):
        back = FitResult.load(res.save(tmp_path / f"fit{i}.json"))
        assert back.residuals == [] and back.labels == []
        assert_same(back, res, skip=("residuals", "labels"))
        # and what was loaded saves to the same numbers again
        again = FitResult.load(back.save(tmp_path / f"again{i}.json"))
        assert_same(again, res, skip=("residuals", "labels"))


def test_saved_fit_is_strict_json(tmp_path):
    text = _synthetic_result().save(tmp_path / "fit.json").read_text()
    d = strict_json(text)  # raises on the bare NaN / Infinity tokens
    assert d["format"] == "gyrojax-fit" and d["format_version"] == RESULT_VERSION
    assert d["cov"][1] == [None, None] and d["identifiability"]["condition"] is None and d["dof_eff"] == [7.5, None]


def test_version_1_files_keep_their_noise_summaries(tmp_path):
    """Version 1 stored each noise model as its summary: white + Gauss–Markov comes back from its σs, an AR model
    with its order but unknown (NaN) coefficients; ν per coefficient."""
    res = _synthetic_result()
    d = json.loads(res.save(tmp_path / "fit.json").read_text())
    for key in ("noise_models", "record_names", "record_paths", "dof_eff"):
        del d[key]
    d["format_version"] = 1
    old = tmp_path / "v1.json"
    old.write_text(json.dumps(d))
    back = FitResult.load(old)
    ar, gm, white = back.noise
    assert ar.order == 2 and np.isnan(ar.ar).all() and ar.innovation_std == pytest.approx(0.3, rel=1e-14)
    assert gm.gm_tau == 120.0 and gm.gm_variance == pytest.approx(0.04, rel=1e-14)
    assert gm.white_variance == pytest.approx(0.25, rel=1e-14)
    # white: its per-sample variance from its summary (v1 kept no sample interval)
    assert white.order == 0 and white.whitening_theta()[2] == pytest.approx(res.noise[2].white_variance, rel=1e-14)
    assert back.dof_eff is None  # v1 wrote ν = ∞ as null, so a fit with an infinite ν lost all of them


def test_fit_and_triad_fit_readers_name_each_others_files(rlg_ladder, tmp_path):
    from gyrojax.inference.triad import fit_triad
    from gyrojax.montecarlo.triad import mems_truth
    from gyrojax.simulation.triad import simulate_ferraris

    turntable = fit(rlg_ladder, ["D_F", "sf_error"], noise="white").save(tmp_path / "fit.json")
    triad = fit_triad(simulate_ferraris(mems_truth(7), seed=2)).save(tmp_path / "triad.json")
    with pytest.raises(FormatError, match="an imu-triad fit .*load_triad_fit") as e:
        FitResult.load(triad)
    assert str(triad) in str(e.value)
    with pytest.raises(FormatError, match="a turntable fit result .*FitResult.load") as e:
        load_triad_fit(turntable)
    assert str(turntable) in str(e.value)
    # 0.2 wrote both kinds as gyrojax-fit-1: the instrument tells them apart
    d = json.loads(triad.read_text())
    d["format"] = "gyrojax-fit-1"
    del d["format_version"]
    legacy = tmp_path / "legacy_triad.json"
    legacy.write_text(json.dumps(d))
    with pytest.raises(FormatError, match="an imu-triad fit"):
        FitResult.load(legacy)


def _KnownNoise():  # noqa: N802 — a given noise model (as gyrojax noise makes one): white 0.5 deg/√h
    return NoiseSpec(white=0.5)


def test_known_noise_fit_is_damped_and_reports_its_status(rlg_ladder):
    """The known-noise GLS pass uses the one damped method too: from Ω_L = 5 deg/h it reaches the lock-in (the
    undamped step lands in the dead band, test above), and stopped after one iteration it says so."""
    res = fit(rlg_ladder, ["D_F", "lock_in"], noise=_KnownNoise(), theta0=[0.0, 5.0])
    assert res.converged and abs(res.values["Omega_L"] - LOCK_IN) < 4 * res.stds["Omega_L"]
    with pytest.warns(ConvergenceWarning, match="did not converge"):
        stopped = fit(rlg_ladder, ["D_F", "lock_in"], noise=_KnownNoise(), theta0=[0.0, 5.0], max_iter=1)
    assert not stopped.converged and "Levenberg–Marquardt stopped" in stopped.convergence_note
