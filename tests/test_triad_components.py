"""Honest σ of a hand session the white-noise model misfits: a per-move angle noise and a per-pose bias scatter as
variance components (REML), checked by Monte Carlo against the planted truth and the planted sizes; the segments
that drive χ² named; the fit file's version 2 (components, per-segment residuals) and version 1 read back."""

import copy
import json

import numpy as np
import pytest
from scipy import stats

from gyrojax.data.record import Record
from gyrojax.inference.triad import fit_triad
from gyrojax.inference.triad_result import load_triad_fit
from gyrojax.montecarlo.triad import mems_truth
from gyrojax.report.text import fit_table
from gyrojax.simulation.triad import simulate_multiposition

from .roundtrip import assert_same, strict_json

TRUTH = mems_truth(7)
MOVE_DEG, STEP_DPH = 0.5, 30.0  # planted: hand-move angle error per axis, bias level per pose
DRAWS = 6
LO, HI = stats.binom.ppf([0.0005, 0.9995], DRAWS * 21, 0.9545) / (DRAWS * 21)  # 99.9 % interval of honest σ


def session(seed, move_deg=0.0, step_dph=0.0):
    return simulate_multiposition(
        TRUTH,
        poses=20,
        seed=seed,
        latitude_deg=48.1,
        fit_latitude=True,
        move_error_deg=move_deg,
        bias_step_dph=step_dph,
    )


def inside(res):
    return [abs(res.values[k] - v) <= 2 * res.stds[k] for k, v in TRUTH.items()]


@pytest.fixture(scope="module")
def misfit():
    return [fit_triad(session(200 + s, MOVE_DEG, STEP_DPH)) for s in range(DRAWS)]


def test_sigma_honest_with_move_errors_and_bias_steps(misfit):
    """0.5° per move and 30 deg/h bias steps: χ² is far off (white noise explains ~0.007° per move), yet ±2σ
    covers the planted truth at the honest rate, and the components find the planted sizes."""
    assert all(stats.chi2.sf(r.chi2, r.dof) < 1e-6 for r in misfit)
    cover = np.mean([inside(r) for r in misfit])
    assert LO <= cover <= HI, (cover, LO, HI)
    tau_m = np.mean([r.variance_components["move_angle_noise_deg"] for r in misfit])
    tau_b = np.mean([r.variance_components["pose_bias_scatter_deg_per_h"] for r in misfit])
    # 19 moves × 2 components and 20 poses × 3 channels per session: τ̂ within ~12 % (1σ) each, 6 pooled
    assert 0.4 < tau_m < 0.6 and 22.0 < tau_b < 38.0, (tau_m, tau_b)
    without = [fit_triad(session(200 + s, MOVE_DEG, STEP_DPH), components=False) for s in range(2)]
    assert np.mean([inside(r) for r in without]) < 0.5  # the white-noise σ alone are far too small


def test_sigma_not_inflated_without_misfit():
    """No move error, no bias step: coverage stays honest and the components stay near zero (the white noise
    alone gives ~0.007° per move and ~9 deg/h per pose mean; the planted sizes above are 70× and 3× those)."""
    fits = [fit_triad(session(300 + s)) for s in range(DRAWS)]
    cover = np.mean([inside(r) for r in fits])
    assert LO <= cover <= HI, (cover, LO, HI)
    for r in fits:
        assert r.variance_components["move_angle_noise_deg"] < 0.02
        assert r.variance_components["pose_bias_scatter_deg_per_h"] < 10.0


def test_segments_that_drive_chi2_are_named(tmp_path):
    """One move given a 3° rate error spread over it (≈ 1° in the final attitude, the body turning under it): it
    carries most of χ², the text and the JSON say so; the file is version 2 and loads back whole, and a version-1
    file (no components, no per-segment residuals) still loads."""
    rec = session(7)
    seg = np.asarray(rec.columns["segment"])
    sel = seg == 9  # move-4-5
    cols = dict(rec.columns)
    cols["gyro_x_dps"] = np.asarray(cols["gyro_x_dps"]) + np.where(sel, 3.0 / (sel.sum() * 0.01), 0.0)
    res = fit_triad(Record(copy.deepcopy(rec.meta), cols))
    name, share = res.chi2_drivers()[0]
    assert name == "move-4-5" and share > 0.5
    assert "chi2 driven by: move-4-5" in fit_table(res)
    rows = {r["name"]: r for r in res.to_json()["segment_residuals"]}
    assert rows["move-4-5"]["kind"] == "move" and 0.5 < rows["move-4-5"]["angle_deg"] < 3.0
    assert rows["pose-0"]["unit"] == "deg/h" and len(rows["pose-0"]["whitened"]) == 3
    assert sum(r["chi2"] for r in rows.values()) == pytest.approx(res.chi2, rel=1e-9)
    path = res.save(tmp_path / "v2.json")
    d = strict_json(path.read_text())
    assert d["format_version"] == 2 and d["variance_components"] == res.variance_components
    assert_same(load_triad_fit(path), res, skip=("segments",))
    for key in ("variance_components", "segment_residuals"):
        del d[key]
    d["format_version"] = 1
    (tmp_path / "v1.json").write_text(json.dumps(d))
    old = load_triad_fit(tmp_path / "v1.json")
    assert old.variance_components == {} and old.segment_residuals == []
    np.testing.assert_array_equal(old.theta, res.theta)


def test_a_component_search_that_stops_short_makes_the_fit_not_converged(monkeypatch):
    """The REML search's status reaches the fit: a search that stopped short gives converged false, the reason
    and a ConvergenceWarning, never calm numbers."""
    from gyrojax.errors import ConvergenceWarning
    from gyrojax.inference import triad_components as tc

    monkeypatch.setattr(tc, "MAX_STEPS", 1)
    with pytest.warns(ConvergenceWarning, match="variance components' REML search stopped"):
        res = fit_triad(session(400, MOVE_DEG, STEP_DPH))
    assert not res.converged and "iteration limit" in res.convergence_note
