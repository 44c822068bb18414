"""Model adequacy beyond the library (issue 19): physics no named effect holds is reported as unexplained structure
against the right input and shape, never hidden behind an implausible or unfittable named candidate; modelled with an
expression effect it is recovered and the verdict turns adequate; statistically indistinguishable candidates are named
together with what would separate them; diagnose and fit report one residual."""

import numpy as np
import pytest

import gyrojax as gj
from gyrojax.inference.campaign import Campaign
from gyrojax.inference.diagnose import diagnose
from gyrojax.inference.identify import fit
from gyrojax.inference.scoring import holm_log10
from gyrojax.physics import effects as fx
from gyrojax.physics import expression as ex
from gyrojax.report import diagnosis_text

from . import power as pw

BASE = {"D_F": 0.4, "D_I": 0.6, "D_O": -0.2, "D_S": 0.3}
DRIFT4 = ("D_F", "D_I", "D_O", "D_S")
TUMBLE_TRUTH = {"D_F": 0.35, "D_I": 0.55, "D_S": -0.42, "D_O": 0.03}
FAMILY = 60  # a bound on the diagnosis' family of tests (named candidates + shapes), checked where power is used


def _assert_decidable(recs, model, hidden, truth, white):
    """The one campaign decides the test: the score test's power for ``hidden`` at its size is ≥ 0.999 at the
    first Holm step (tests/power.py, the noncentrality from the conventions' regressors and scipy's ncx2)."""
    lam = pw.noncentrality(recs, model, hidden, truth, white)
    power = pw.power(lam, len(pw.COEFFICIENTS[hidden]), 0.01, FAMILY, pw.margin(hidden))
    assert power >= 0.999, f"power {power:.4f} for {hidden} (λ = {lam:.1f}): one campaign cannot decide this test"


@pytest.fixture(scope="module")
def cubic_tumble():
    """A polar tumble whose truth holds a bias ∝ a_I³ (0.05 deg/h/g³), simulated with the effect registered only
    while simulating: the library the diagnosis sees has no such effect."""
    truth = {"coefficients": {**TUMBLE_TRUTH, "T_cube": 0.05}, "noise": {"white": 0.0006}}
    with ex.defined("T_cube=a_I**3"):
        recs = gj.simulate(gj.plans.tumble(revolutions=1, dt_s=10), truth, seed=7)
    assert "T_cube" not in fx.names()
    return recs


def test_out_of_library_effect_is_unexplained_structure_with_input_and_shape(cubic_tumble):
    d = diagnose(cubic_tumble, DRIFT4)
    assert d.verdict == "missing-effect"
    top = d.unexplained[0]
    assert (top.versus, top.shape, top.expression) == ("a_I", "cubic", "a_I**3"), [s.to_json() for s in d.unexplained]
    assert abs(top.estimate - 0.05) < 3 * top.std
    j = d.to_json()
    assert j["unexplained"][0]["versus"] == "a_I" and j["unexplained"][0]["shape"] == "cubic"
    assert {"versus", "shape", "statistic", "p_value"} <= set(j["unexplained"][0])
    assert "residual structure vs a_I that no named effect explains: cubic" in diagnosis_text(d)
    # what fit refuses is never proposed (encoder_harmonic: not excited when fitted from zero)
    for c in d.candidates:
        if c.refused:
            assert c.name != d.proposal
            with pytest.raises(gj.ModelError):
                fit(cubic_tumble, DRIFT4 + (c.name,))
    if d.proposal is not None:
        fit(cubic_tumble, DRIFT4 + (d.proposal,))


def test_expression_effect_recovers_it_and_the_verdict_turns_adequate(cubic_tumble):
    with ex.defined("U_a_I_3=a_I**3") as (name,):
        res = fit(cubic_tumble, DRIFT4 + (name,))
        est, std = res.values[name], res.stds[name]
        assert abs(est - 0.05) < std, (est, std)
        assert res.residual_rms <= 1.10 * res.noise_floor
        d = diagnose(cubic_tumble, DRIFT4 + (name,), result=res)
        assert d.verdict == "adequate", (d.to_json()["unexplained"], [(c.name, c.p_adjusted) for c in d.candidates[:3]])
        assert d.unexplained == []


def test_implausible_candidate_is_flagged_and_shown_beside_the_unexplained_structure():
    """A hidden D_O (0.2 deg/h/g) with a plausibility limit of 0.01 deg/h/g: D_O is significant but implausible, so
    it is not proposed, and the structure it would have explained is reported as unexplained beside it."""
    recs = gj.simulate(
        gj.plans.multiposition(24, minutes=3, dt_s=2), {"coefficients": BASE, "noise": {"white": 0.0008}}, seed=11
    )
    _assert_decidable(recs, ("D_F", "D_I", "D_S"), "D_O", BASE, 0.0008)
    d = diagnose(recs, ("D_F", "D_I", "D_S"), plausible={"D_O": 0.01})
    assert d.tests <= FAMILY
    c = next(c for c in d.candidates if c.name == "D_O")
    assert c.p_adjusted < d.alpha and c.implausible and "D_O" in c.implausible
    assert d.proposal != "D_O"
    assert d.unexplained and d.verdict == "missing-effect"
    text = diagnosis_text(d)
    assert "not proposed: D_O" in text and "no named effect explains" in text
    assert diagnose(recs, ("D_F", "D_I", "D_S"), suggest_tests=False).proposal == "D_O"


def test_tilt_and_azimuth_are_named_indistinguishable_with_what_separates_them():
    truth = {"coefficients": BASE, "noise": {"white": 0.0003}, "setup": {"table_tilt": [0.0, 90.0]}}
    recs = gj.simulate(gj.plans.multiposition(24, minutes=3, dt_s=2), truth, seed=11)
    _assert_decidable(recs, DRIFT4, "table_tilt", {**BASE, "delta_E": 0.0, "delta_N": 90.0}, 0.0003)
    d = diagnose(recs, DRIFT4)
    assert d.tests <= FAMILY
    by = {c.name: c for c in d.candidates}
    assert "table_tilt" in by["table_azimuth"].indistinguishable
    assert "table_azimuth" in by["table_tilt"].indistinguishable
    for n in ("table_tilt", "table_azimuth"):
        assert by[n].separated_by, n
        assert by[n].to_json()["indistinguishable"]
    assert "indistinguishable" in diagnosis_text(d)


@pytest.mark.parametrize("rates", [True, False], ids=["rate-columns", "rates-derived"])
def test_diagnose_and_fit_report_one_residual(rates):
    truth = {"coefficients": {**BASE, "D_IS": 0.05}, "noise": {"white": 0.0008}}
    recs = gj.simulate(gj.plans.multiposition(24, minutes=3, dt_s=2), truth, seed=3)
    if not rates:
        cols = {k: v for k, v in recs[0].columns.items() if not k.startswith("rate_")}
        recs = [gj.Record(recs[0].meta, cols)]
        assert recs[0].rates_derived
    d = diagnose(recs, DRIFT4)
    f = fit(recs, DRIFT4)
    assert d.residual_rms == pytest.approx(f.residual_rms, rel=1e-12)
    assert d.to_json()["residual_rms_deg_per_h"] == pytest.approx(f.to_json()["residual_rms_deg_per_h"], rel=1e-12)
    top = next(c for c in d.candidates if c.name == d.proposal)
    assert top.name == "D_IS" and top.rms_after_refit
    assert top.rms_after == pytest.approx(fit(recs, DRIFT4 + ("D_IS",)).residual_rms, rel=1e-12)


def test_joint_holm_in_logs_matches_holm():
    p = np.array([0.01, 0.04, 0.03, 0.005, 1e-300 * 1e-10, 0.9])
    # Holm by hand: sorted p × (m − rank) = 6e-310, 0.025, 0.04, 0.09, 0.08, 0.9; running maximum; original order
    ref = np.array([0.04, 0.09, 0.09, 0.025, 6e-310, 0.9])
    got = 10.0 ** holm_log10(np.log10(np.where(p > 0, p, 1e-320)))
    np.testing.assert_allclose(got[p > 0], ref[p > 0], rtol=1e-12)
    assert holm_log10([-400.0, -3.0])[0] == pytest.approx(-400.0 + np.log10(2))


def test_shapes_cover_every_input_the_records_carry():
    from gyrojax.inference.adequacy import shapes

    plan = gj.plans.multiposition(24, minutes=0.5, dt_s=2)
    run = plan.runs[0]
    warm = gj.plans.Plan(
        plan.name,
        (gj.plans.Run(run.name, run.axes, run.instrument, run.segments, temperature_C=(22.0, 4.0, 5400.0)),),
        plan.latitude_deg,
    )
    recs = gj.simulate(warm, {"coefficients": BASE}, seed=1)
    lib = shapes(Campaign.of(recs))
    versus = {s[0] for s in lib}
    assert {"a_I", "a_O", "a_S", "w_I", "time", "temperature_C", "position"} <= versus
    assert any(v.startswith("table angle") for v in versus)
    n = len(recs[0].time_s)
    for _, _, _, _, blocks in lib:
        assert blocks[0].shape[0] == n and np.all(np.isfinite(blocks[0]))
