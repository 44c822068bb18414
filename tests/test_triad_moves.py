"""Triad sessions with gravity-to-gravity moves: χ² and σ independent of the nominal scale given at import, the
Earth rate known, unknown or off (Monte Carlo coverage against the planted truth), and a fit of the moves that
diverges or stops short never returned as an answer."""

import copy
import math

import numpy as np
import pytest
from scipy import stats

from gyrojax.cli.app import main
from gyrojax.data.record import Record
from gyrojax.data.records import save_record
from gyrojax.errors import ConvergenceWarning, ModelError
from gyrojax.inference import triad as triad_fit
from gyrojax.inference.triad import fit_triad
from gyrojax.montecarlo.triad import mems_truth
from gyrojax.optimize import Solution, Status
from gyrojax.simulation.triad import simulate_multiposition

from .triad_coverage import EARTH_MODES, multiposition_coverage

TRUTH = mems_truth(7)
# the noise passes stop when S changes by < 1e-10 relative (NOISE_PASS_TOL) and Levenberg–Marquardt's xtol is
# 1e-12: the weights are then right to ~1e-10, χ² (stationary at the optimum) and σ (∝ weights) to the same order;
# 1e-7 leaves three orders for the rank-cut SVD's rounding
RTOL = 1e-7
# with the REML components the σ also carry τ̂, found by L-BFGS-B on the exact gradient of −2ℓ_R
# (gyrojax.inference.triad_components; log τ² to ~1e-5 where −2ℓ_R is flat): σ to ~1e-6; measured 2e-7
RTOL_COMPONENTS = 1e-5


def rescaled(rec: Record, k: float) -> Record:
    """``rec`` as imported with a nominal scale 1/k of the one used: every gyro column times k."""
    cols = dict(rec.columns)
    for c in "xyz":
        cols[f"gyro_{c}_dps"] = np.asarray(rec.columns[f"gyro_{c}_dps"]) * k
    return Record(copy.deepcopy(rec.meta), cols)


@pytest.mark.parametrize("earth", ["latitude known", "latitude unknown"])
def test_chi2_and_sigma_do_not_depend_on_the_nominal_scale(earth):
    """A nominal scale off by k multiplies the true S, b, G by k (ω_ind = k(S ω + G a + b)): the same session
    must give the same χ², values (1 + E_SF)/k, M/k, D/k and σ/k, for k from 0.7 to 1.4."""
    rec = simulate_multiposition(
        TRUTH, poses=14, seed=3, latitude_deg=48.1, fit_latitude=earth == "latitude known", gyro_noise_dps=0.05
    )
    for comp, tol in ((False, RTOL), (True, RTOL_COMPONENTS)):
        fits = {k: fit_triad(rescaled(rec, k), components=comp) for k in (0.7, 1.0, 1.4)}
        _same_up_to_scale(fits, tol)


def _same_up_to_scale(fits, tol):
    ref = fits[1.0]
    assert stats.chi2.sf(ref.chi2, ref.dof) > 1e-3  # the model is right: χ² consistent with its dof
    for k, res in fits.items():
        assert res.converged and res.dof == ref.dof
        assert res.chi2 == pytest.approx(ref.chi2, rel=tol), k
        for name in ref.values:
            base = name.split("[")[0]
            if base == "E_SF":  # 1 + E' = k (1 + E), ppm
                assert (1e6 + res.values[name]) / k == pytest.approx(1e6 + ref.values[name], rel=tol), name
            else:
                assert res.values[name] / k == pytest.approx(ref.values[name], rel=10 * tol, abs=1e-6), name
            assert res.stds[name] / k == pytest.approx(ref.stds[name], rel=tol), (k, name)


def test_known_latitude_session_with_moves_fits_the_truth():
    """The case the static-only start broke (negative determinant or χ² ~1e8): 22 poses, latitude 48.1° given."""
    rec = simulate_multiposition(TRUTH, poses=22, seed=11, latitude_deg=48.1, fit_latitude=True)
    assert rec.meta["site"]["latitude_deg"] == 48.1
    res = fit_triad(rec)
    assert res.converged and stats.chi2.sf(res.chi2, res.dof) > 1e-3
    z = np.array([(res.values[k] - v) / res.stds[k] for k, v in TRUTH.items()])
    assert np.max(np.abs(z)) < 4.5, z  # 21 normal deviates: P(max |z| > 4.5) ≈ 1.4e-4


@pytest.mark.slow
def test_coverage_with_moves_in_every_earth_rate_mode():
    """±2σ coverage of 21 coefficients × 6 sessions (20 poses) in each Earth-rate mode, against the planted truth:
    inside the two-sided 99.9 % binomial interval of an honest σ (p = 0.9545); benchmarks/bench_triad.py runs more."""
    n = 6 * 21
    lo, hi = stats.binom.ppf([0.0005, 0.9995], n, 0.9545) / n
    for earth in EARTH_MODES:
        h = multiposition_coverage(6, poses=20, truth=TRUTH, earth=earth, first_seed=100)
        assert lo <= h.mean() <= hi, (earth, h.mean(), lo, hi)


def test_diverged_fit_is_refused_not_returned(tmp_path, capsys):
    """Left-handed gyro axes (one channel's sign flipped) cannot be an S near I: the fit says it diverged, the API
    raises and the CLI exits non-zero with one line."""
    rec = simulate_multiposition(TRUTH, poses=12, seed=4)
    cols = dict(rec.columns)
    cols["gyro_y_dps"] = -np.asarray(cols["gyro_y_dps"])
    bad = Record(copy.deepcopy(rec.meta), cols)
    with pytest.raises(ModelError, match="diverged"):
        fit_triad(bad)
    save_record(bad, tmp_path)
    assert main(["fit", str(tmp_path)]) != 0
    err = capsys.readouterr().err.strip()
    assert "diverged" in err and len(err.splitlines()) == 1


def test_cut_short_fit_is_marked_and_the_cli_fails(tmp_path, capsys, monkeypatch):
    """A fit of the moves stopped before convergence: the API warns and marks it; the CLI exits non-zero."""
    rec = simulate_multiposition(TRUTH, poses=10, seed=5)
    with pytest.warns(ConvergenceWarning, match="did not converge"):
        res = fit_triad(rec, max_iter=2)
    assert not res.converged
    save_record(rec, tmp_path)

    def stop(system, theta0, max_nfev):
        planted = "Levenberg–Marquardt stopped after 1 evaluations: planted"
        return Solution(np.asarray(theta0, dtype=float), 0.0, Status.ITERATION_LIMIT, 1, planted)

    monkeypatch.setattr(triad_fit, "least_squares", stop)
    assert main(["fit", str(tmp_path)]) != 0
    err = capsys.readouterr().err.strip()
    assert "did not converge" in err and len(err.splitlines()) == 1
    assert math.isfinite(res.chi2)
