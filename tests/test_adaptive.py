"""The campaign loop (:mod:`gyrojax.adaptive`): its error budget, the requirements' σ, the refusals, and a short
campaign on a simulated laboratory through the command line (``gyrojax campaign``, ``gyrojax next``).

The laboratory: an SDF gyro whose lab knows D_F, D_I, D_S, with a hidden output-axis unbalance D_O. The first test is
a single-mount polar tumble (Hu 3-12 to 3-21, OA along the polar axis, not flipped): a_O = g·sin φ is constant in it,
so D_O reads as D_F and the tumble cannot see it (its σ, were it added, is infinite). The loop must design a test on
the two-axis table that makes it visible, add it, and bring every σ to target.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from gyrojax.adaptive import requirements as rq
from gyrojax.adaptive.goal import Goal, look_alpha, noncentrality_for_power
from gyrojax.adaptive.lab import Lab
from gyrojax.adaptive.step import next_test
from gyrojax.cli.app import main
from gyrojax.data import plans
from gyrojax.data.planfile import load_plan, save_plan
from gyrojax.inference.identify import fit
from gyrojax.physics.model import Model
from gyrojax.simulation.simulator import simulate

TRUTH = {"coefficients": {"D_F": 0.4, "D_I": 0.6, "D_S": -0.3, "D_O": 0.2}, "noise": {"white": 0.005}}
TARGET = 0.02
FAST = ["--table", "two-axis", "--no-turn", "--mountings", "1", "--positions", "8"]
SEARCH = ["--starts", "1", "--steps", "120"]


def first_plan():
    return plans.tumble(revolutions=2.0, earth_rates=20.0, dt_s=60.0, flip=False, both_directions=False)


@pytest.fixture(scope="module")
def lab_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("lab")
    (d / "truth.json").write_text(json.dumps(TRUTH), encoding="utf-8")
    save_plan(first_plan(), d / "first.json")
    return d


@pytest.fixture(scope="module")
def campaign(lab_files):
    """One short campaign on the command line: its JSON and the directory it wrote."""
    import contextlib
    import io

    out = lab_files / "run"
    argv = ["campaign", "--simulate", str(lab_files / "truth.json"), "--first", str(lab_files / "first.json")]
    argv += ["--terms", "D_F,D_I,D_S", "--target-sigma", str(TARGET), "--seed", "4", "--json", "--out", str(out)]
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(argv + FAST + SEARCH) == 0
    return json.loads(buf.getvalue()), out


def test_alpha_spending_sums_to_the_campaign_rate():
    # α/(j(j+1)) telescopes: the first J looks spend α(1 − 1/(J+1)), never more than α
    for j in (1, 2, 5, 40):
        assert sum(look_alpha(k, 0.05) for k in range(1, j + 1)) == pytest.approx(0.05 * (1 - 1 / (j + 1)), rel=1e-12)
    with pytest.raises(Exception, match="from 1"):
        look_alpha(0)


@pytest.mark.parametrize("alpha", [0.05, 0.01, 1e-3])
def test_noncentrality_for_power_against_the_normal_closed_form(alpha):
    # a χ²₁ test is |Z + √λ| > z_{α/2}: its power Φ(√λ − z) + Φ(−√λ − z), no noncentral χ² involved
    lam = noncentrality_for_power(alpha, 0.9)
    z = stats.norm.isf(alpha / 2)
    power = stats.norm.cdf(math.sqrt(lam) - z) + stats.norm.cdf(-math.sqrt(lam) - z)
    assert power == pytest.approx(0.9, abs=1e-8)


def test_sub_model_sigma_closed_form():
    # F = [[a, c], [c, b]]: σ₁ alone 1/√a, in the pair √(b/(ab − c²)); a null direction gives ∞ in the pair only
    a, b, c = 4.0, 9.0, 5.0
    uni = Model(("D_F", "D_I"))
    reqs = [
        rq.Requirement("sigma", "D_F", ("D_F",), 1.0, "deg/h"),
        rq.Requirement("sigma", "D_F", ("D_F", "D_I"), 1.0, ""),
    ]
    f = np.array([[a, c], [c, b]])
    want = [1 / math.sqrt(a), math.sqrt(b / (a * b - c * c))]
    assert rq.sigmas(f, reqs, uni) == pytest.approx(want, rel=1e-12)
    masks, index, _ = rq.arrays(reqs, uni)
    assert np.sqrt(np.asarray(rq.variances(f, masks, index))) == pytest.approx(want, rel=1e-9)
    s = rq.sigmas(np.array([[1.0, 2.0], [2.0, 4.0]]), reqs, uni)
    assert s[0] == pytest.approx(1.0) and math.isinf(s[1])


@pytest.fixture(scope="module")
def first_records():
    return simulate(first_plan(), TRUTH, seed=1)


def fast_lab(records, **kw):
    return Lab.from_records(records, axes=plans.TWO_AXIS, turn_case=False, mountings_per_test=1, positions=8, **kw)


def test_the_tumble_cannot_see_d_o_and_the_d_oo_goal_is_refused(first_records):
    goal = Goal(sigma=TARGET)
    # D_OO beside D_F, D_II, D_SS: a_I² + a_O² + a_S² = 1 at every orientation on the ground (Hu 2-45)
    nt = next_test(first_records, ["D_F", "D_I", "D_S", "D_II", "D_SS", "D_OO"], goal, fast_lab(first_records))
    assert nt.status == "unreachable"
    assert "D_OO" in nt.reason and "centrifuge" in nt.reason
    rows = {(r["kind"], r["coefficient"]): r for r in nt.requirement_rows()}
    # OA along the polar axis: a_O constant, D_O reads as D_F
    assert rows[("detect", "D_O")]["sigma_now"] is None


def test_designed_sigma_matches_the_fit_that_follows():
    """A model that holds every effect of the truth: the Fisher prediction of the designed test (position means,
    white noise) against the GLS fit of the records simulated from it — independent paths, agreeing to the σ
    estimate's own scatter (relative ≈ 1/√(2·dof), a few %) and the rounding of dwells to whole samples.

    The test is capped at one hour (the goal needs several), so it is shaped for the model that holds D_O, a
    candidate the tumble never excites (OA along the polar axis holds a_O at s = g·sin φ: it measures D_F + s·D_O
    and nothing of D_O beyond D_F), at its σ target, not for D_O's detection alone. Closed form: samples of total
    time H with |a_O| ≤ g add at most H·(g + s)²/N² of information on D_O beyond D_F + s·D_O, so in any model that
    holds D_F and D_O, σ_O ≥ N/((g + s)·√H) whatever the test; the fit after the shaped test comes within 2× of it
    (a test shaped for detection alone: 2.5×), never below it beyond the white-noise estimate's own scatter (a few
    % over some hundred samples)."""
    truth = {"coefficients": {"D_F": 0.4, "D_I": 0.6, "D_S": -0.3}, "noise": {"white": 0.005}}
    records = simulate(first_plan(), truth, seed=1)
    lab = fast_lab(records, hours_per_test=1.0)
    nt = next_test(records, ["D_F", "D_I", "D_S"], Goal(sigma=0.003), lab, starts=1, steps=120)
    assert nt.status == "test" and "D_O could hide" in nt.reason
    assert nt.design.hours_needed > 2.0 and nt.design.dwell_hours == pytest.approx(1.0, rel=1e-6)
    shaped = [n.split("(not seen by the records so far)")[0] for n in nt.notes if "not seen by the records" in n]
    assert shaped and "D_O" in shaped[0].split(": ")[-1].split(", ")
    start = float(records[0].time_s[-1]) + lab.settle_s
    new = simulate(nt.plan, truth, seed=2, start_s=start)
    predicted = {(r.kind, r.coefficient): x for r, x in zip(nt.requirements, nt.sigma_after)}
    model = fit(records + new, ["D_F", "D_I", "D_S"]).stds
    for c in ("D_F", "D_I", "D_S"):
        assert model[c] == pytest.approx(predicted[("sigma", c)], rel=0.15)
    # a candidate the tumble could not see: its σ were it added, read in the fit with it
    sigma_o = fit(records + new, ["D_F", "D_I", "D_S", "D_O"]).stds["D_O"]
    assert sigma_o == pytest.approx(predicted[("detect", "D_O")], rel=0.15)
    site = records[0].meta["site"]
    g = site["gravity_mps2"] / 9.80665  # standard g, the unit of a_O
    s = g * math.sin(math.radians(site["latitude_deg"]))
    hours = sum(r.n * float(np.median(np.diff(r.time_s))) for r in new) / 3600.0
    closed = truth["noise"]["white"] / ((g + s) * math.sqrt(hours))
    assert 0.9 * closed <= sigma_o <= 2.0 * closed


def test_a_pair_this_table_cannot_separate_is_refused_naming_the_table_that_would(first_records):
    # the records' single-axis table, the case not turned: OA stays along the polar axis in every position, a_O =
    # sin φ is constant, so D_O reads as D_F whatever the table does (Hu 3-12); the case turned on its faces on the
    # same table (OA off the axis) separates them, and so would a two-axis table, but remounting is the lesser change
    lab = Lab.from_records(first_records, turn_case=False, mountings_per_test=1, positions=8)
    nt = next_test(first_records, ["D_F", "D_I", "D_S", "D_O"], Goal(sigma=TARGET), lab)
    assert nt.status == "unreachable" and nt.plan is None
    assert "no orientation of this table separates D_O" in nt.reason
    assert "the case turned on its faces on this table" in nt.reason
    # the invisible combination is D_F·sin φ + D_O·(−1)·…: the ratio of its coefficients is sin φ of the site
    text = nt.reason.split("separates D_O: ")[1].split(" is invisible")[0]
    parts = dict(reversed(t.strip().split("·")) for t in text.split(" + "))
    lat = math.radians(first_records[0].meta["site"]["latitude_deg"])
    assert abs(float(parts["D_F"]) / float(parts["D_O"])) == pytest.approx(math.sin(lat), abs=2e-3)


def test_a_goal_beyond_the_budget_is_refused_with_the_hours_it_needs(first_records):
    # 1 h left for σ = 0.0015 at N = 0.005 deg/√h. Independent bound: D_F is a constant, so whatever the other
    # terms, 1/σ_F² ≤ (T_rec + T)/N² (the mean of white noise over T hours): the goal needs T ≥ (N/(m·S))² − T_rec
    # of dwell, and with the 1 h left σ_F ≥ N/√(T_rec + 1) at best
    target, white, left = 0.0015, TRUTH["noise"]["white"], 1.0
    lab = fast_lab(first_records, budget_hours=3.0)
    nt = next_test(first_records, ["D_F", "D_I", "D_S"], Goal(sigma=target), lab, hours_spent=2.0, starts=1, steps=120)
    assert nt.status == "unreachable" and nt.plan is None
    assert "budget leaves 1 h" in nt.reason
    t_rec = float(first_records[0].time_s[-1] - first_records[0].time_s[0]) / 3600.0
    need = float(nt.reason.split("the goal needs about ")[1].split(" h")[0])
    assert need >= (white / (0.95 * target)) ** 2 - t_rec
    factor = float(nt.reason.split("targets ")[1].split(" times larger")[0])
    assert factor >= white / math.sqrt(t_rec + left) / target
    assert f"A campaign budget of at least {2.0 + need:.3g} h" in nt.reason


def test_campaign_json_keys(campaign):
    j, _ = campaign
    for key in ("goal_met", "table_hours", "classical_table_hours", "terms", "verdict", "steps"):
        assert key in j
    for step in j["steps"]:
        assert {"plan", "hours", "reason"} <= set(step)
    assert j["table_hours"] == pytest.approx(sum(s["hours"] for s in j["steps"]))
    assert j["steps"][0]["reason"] == "the lab's first test"


def test_campaign_meets_the_goal_with_the_hidden_effect_and_honest_sigma(campaign):
    j, _ = campaign
    assert j["goal_met"] and j["verdict"] == "adequate"
    assert set(j["terms"]) == set(TRUTH["coefficients"])  # D_O found, nothing false added
    for name, c in j["coefficients"].items():
        assert c["std"] <= TARGET
        assert abs(c["value"] - TRUTH["coefficients"][name]) <= 3 * c["std"]


def test_classical_sequence_reaches_the_same_sigma(campaign):
    j, _ = campaign
    cl = j["classical"]
    assert cl["hours"] > 0 and cl["scale"] > 0
    assert set(cl["sigma"]) == set(j["coefficients"])
    assert all(v <= TARGET * (1 + 1e-9) for v in cl["sigma"].values())
    assert [p["test"] for p in cl["path"]] == ["multi-position", "tumble", "servo"]


def test_campaign_writes_plans_records_and_figure(campaign):
    j, out = campaign
    assert (out / "campaign.png").stat().st_size > 1000
    for step in j["steps"]:
        load_plan(step["plan"])
    assert json.loads((out / "campaign.json").read_text(encoding="utf-8"))["goal_met"] == j["goal_met"]


def test_next_on_the_campaign_records(campaign, tmp_path, capsys):
    j, out = campaign
    records = out / "records"
    first = sorted(records.glob("ccw-up.json"))
    # the first test alone: a test is designed and written; it runs in the simulator
    argv = ["next", str(first[0]), "--terms", "D_F,D_I,D_S", "--target-sigma", str(TARGET), "--json"]
    assert main(argv + ["--out", str(tmp_path / "next.json")] + FAST + SEARCH) == 0
    nt = json.loads(capsys.readouterr().out)
    assert nt["status"] == "test" and nt["plan_file"]
    assert any(r["coefficient"] == "D_O" and r["sigma_after"] for r in nt["requirements"])
    # the stated power is the look's for a lone missing candidate among its m tests, Holm's first step at α/m
    # (scipy's noncentral χ²), not that of one test at α: m is the diagnosis' family of candidates and shapes
    m = nt["holm_family"]
    assert m > 1
    crit = stats.chi2.isf(nt["alpha_next_look"] / m, 1)
    detect = [r for r in nt["requirements"] if r["kind"] == "detect" and r["sigma_after"]]
    assert detect
    for r in detect:
        lam = (r["size_that_matters"] / r["sigma_after"]) ** 2
        assert r["power_after"] == pytest.approx(stats.ncx2.sf(crit, 1, lam), rel=1e-9, abs=1e-12)
    assert simulate(load_plan(tmp_path / "next.json"), TRUTH, seed=2)
    # every record: the goal is met, nothing is written
    argv = ["next", str(records), "--terms", ",".join(j["terms"]), "--target-sigma", str(TARGET), "--json"]
    assert main(argv + ["--looks", str(j["looks"]), "--out", str(tmp_path / "none.json")] + FAST + SEARCH) == 0
    assert json.loads(capsys.readouterr().out)["goal_met"]
    assert not (tmp_path / "none.json").exists()


def _error(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err
    return err


@pytest.mark.parametrize(
    "change, says",
    [
        (["--target-sigma", "-1"], "--target-sigma"),
        (["--first", "no-such-plan"], "no-such-plan"),
        (["--terms", "D_F,D_NOPE"], "D_NOPE"),
        (["--mountings", "5"], "--mountings: lab: key 'mountings_per_test'"),
        (["--hours", "-1"], "--hours: lab: key 'hours_per_test'"),
        (["--positions", "1"], "--positions"),
        (["--table", "two-axis", "--angle-limit", "outer=10:5"], "no table axis 'outer'"),
    ],
)
def test_campaign_bad_input_exit_2_naming_it(lab_files, tmp_path, capsys, change, says):
    argv = ["campaign", "--simulate", str(lab_files / "truth.json"), "--first", str(lab_files / "first.json")]
    argv += ["--terms", "D_F,D_I,D_S", "--target-sigma", "0.02", "--json"]
    for i in range(0, len(change), 2):
        if change[i] in argv:
            argv[argv.index(change[i]) + 1] = change[i + 1]
        else:
            argv += change[i : i + 2]
    assert says in _error(capsys, argv)


def test_bad_truth_file_names_the_key(tmp_path, lab_files, capsys):
    bad = tmp_path / "truth.json"
    bad.write_text(json.dumps({"coefficients": {"D_XX": 1.0}}), encoding="utf-8")
    argv = ["campaign", "--simulate", str(bad), "--first", str(lab_files / "first.json"), "--terms", "D_F"]
    assert "D_XX" in _error(capsys, argv + ["--target-sigma", "0.02"])


def test_next_refuses_to_overwrite_and_names_a_missing_goal(tmp_path, lab_files, capsys):
    out = tmp_path / "p.json"
    out.write_text("{}", encoding="utf-8")
    argv = ["next", str(lab_files), "--out", str(out), "--target-sigma", "0.01"]
    assert "--force" in _error(capsys, argv)
    assert "--target-sigma" in _error(capsys, ["next", str(lab_files), "--out", str(tmp_path / "q.json")])


def test_classical_hours_beyond_any_test_are_said_not_printed():
    """A σ target the classical sequence would need more than MAX_CLASSICAL_HOURS for (here 1e-7 deg/h on D_F in
    N = 0.005 deg/√h: σ ∝ N/√T, so T ~ (0.005/1e-7)² h beyond 1e9 h) is reported as no hours with the coefficient
    that asks for them, never as a number; a target within reach gives hours."""
    from gyrojax.adaptive.classical import MAX_CLASSICAL_HOURS, classical_hours

    far = classical_hours(TRUTH, ["D_F", "D_I", "D_S"], Goal(targets={"D_F": 1e-7, "D_I": 1.0, "D_S": 1.0}), "sdf-gyro")
    assert far.hours is None and far.scale is None
    assert "D_F" in far.reason and f"{MAX_CLASSICAL_HOURS:g} h" in far.reason
    need = float(far.reason.split("would need ")[1].split(" ")[0])
    assert need > MAX_CLASSICAL_HOURS


def test_classical_hours_of_a_noiseless_truth_are_refused_with_the_reason():
    """A truth that draws no noise has σ = 0 at any length: no hours are defined, and the reason names the noise
    (no placeholder noise invented to give a number); a noise with no white or Gauss–Markov part (a random walk
    alone), which the sequence's information is not computed for, is said too."""
    from gyrojax.adaptive.classical import classical_hours

    quiet = {**TRUTH, "noise": {}}
    c = classical_hours(quiet, ["D_F", "D_I", "D_S"], Goal(sigma=0.01), "sdf-gyro")
    assert c.hours is None and c.scale is None and "no noise (noise is 0)" in c.reason
    walk = classical_hours({**TRUTH, "noise": {"random_walk": 0.01}}, ["D_F"], Goal(sigma=0.01), "sdf-gyro")
    assert walk.hours is None and "no white or Gauss–Markov part" in walk.reason


def test_classical_hours_short_of_the_target_after_the_last_check_say_so(monkeypatch):
    """A fit whose σ stays at twice the target however long the sequence (every check rescales by 4 and misses
    again): the hours after the last check are stated with the reason that they fall short, never as the sequence's
    answer; the same sequence and goal with the fit as it is (the truth's whole model) have no such reason."""
    from gyrojax.adaptive import classical

    goal, terms = Goal(sigma=0.01), ["D_F", "D_I", "D_S", "D_O"]
    good = classical.classical_hours(TRUTH, terms, goal, "sdf-gyro")
    assert good.hours and not good.reason

    class Stuck:
        def __init__(self, res):
            self.res = res

        def __getattr__(self, name):
            return getattr(self.res, name)

        @property
        def stds(self):
            return {c: 0.02 for c in self.res.stds}

    real = classical.fit
    monkeypatch.setattr(classical, "fit", lambda *a, **k: Stuck(real(*a, **k)))
    short = classical.classical_hours(TRUTH, terms, goal, "sdf-gyro")
    assert short.hours > good.hours and set(short.sigma.values()) == {0.02}
    assert short.reason.startswith(f"after {classical.CHECKS} rescalings") and "σ 2 × its target" in short.reason


def test_dwell_lower_bound_against_the_mean_of_white_noise(first_records):
    """The fewest hours any static design needs for D_F and D_I to σ ≤ S (no records before): D_I's row is a_I, at
    most g, so 1/σ_I² ≤ H·g²/N² whatever the design (the mean of white noise over H hours); half the
    dwell with IA up and half with IA down gives σ_F = N/√H and σ_I = N/(g√H) (a_I = ±g, the site's gravity in
    standard g), so (N/(g·S))² is the minimum. The bound and the design it certifies must bracket it tightly."""
    from gyrojax.adaptive.bound import dwell_lower_bound, grid_rows

    white, target = 0.005, 0.001
    lab = Lab.from_records(first_records, axes=plans.TWO_AXIS, turn_case=False)
    model = Model(("D_F", "D_I"), "sdf-gyro")
    h = grid_rows(model, lab)
    g = first_records[0].meta["site"]["gravity_mps2"] / 9.80665  # a_I with IA vertical, in standard g
    assert np.abs(h[:, 0, 1]).max() == pytest.approx(g, abs=1e-9)  # the grid holds IA vertical
    low, up = dwell_lower_bound(np.zeros((2, 2)), h, white, [target, target])
    closed = (white / target) ** 2 / g**2  # D_I binds: σ_I² = N²/(H·g²)
    assert low <= closed * (1 + 1e-3) and up >= closed * (1 - 1e-3)
    assert low == pytest.approx(closed, rel=0.01) and up == pytest.approx(closed, rel=0.01)


def test_dwell_lower_bound_of_a_detection_reads_its_sub_model(first_records):
    """A requirement read in a sub-model (detect D_I beside D_F, :mod:`gyrojax.adaptive.requirements`) in a
    universe that also holds D_S: the sub-model's σ_I alone binds, so the bound is the two-coefficient closed form
    (N/(g·S))² of the test above, whatever D_S's column; read in the whole universe (D_S estimated beside it) it
    needs at least as much."""
    from gyrojax.adaptive.bound import dwell_lower_bound, grid_rows
    from gyrojax.adaptive.requirements import Requirement, arrays

    white, target = 0.005, 0.001
    lab = Lab.from_records(first_records, axes=plans.TWO_AXIS, turn_case=False)
    uni = Model(("D_F", "D_I", "D_S"), "sdf-gyro")
    h, f0 = grid_rows(uni, lab), np.zeros((3, 3))
    g = first_records[0].meta["site"]["gravity_mps2"] / 9.80665
    closed = (white / target) ** 2 / g**2
    detect = Requirement("detect", "D_I", ("D_F", "D_I"), target, "deg/h/g")
    low, up = dwell_lower_bound(f0, h, white, arrays([detect], uni))
    assert low <= closed * (1 + 1e-3) and up >= closed * (1 - 1e-3)
    assert low == pytest.approx(closed, rel=0.01) and up == pytest.approx(closed, rel=0.01)
    whole = Requirement("sigma", "D_I", uni.terms, target, "deg/h/g")
    assert dwell_lower_bound(f0, h, white, arrays([whole], uni))[1] >= low


def test_dwell_lower_bound_reads_both_channels_of_a_tdf_position():
    """A TDF gyro reads its X and Y channels together at every position: for DX_F and DY_F alone each position adds
    H/N² to both, so σ² = N²/H for each and (N/S)² is the fewest hours — not twice that, as it would be were each
    channel's row a position of its own. No position of the grid reads DX_XY's a_X·a_Y beside an unseen DX_F in a
    model that holds it and no row: a singular design, infinite hours, no error."""
    from gyrojax.adaptive.bound import dwell_lower_bound, grid_rows

    white, target = 0.005, 0.001
    lab = Lab(plans.TWO_AXIS, plans.tdf_mount((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)), 39.98, turn_case=False)
    h = grid_rows(Model(("DX_F", "DY_F"), "tdf-gyro"), lab)
    assert h.shape[1:] == (2, 2)
    np.testing.assert_array_equal(h[:, 0], np.tile([1.0, 0.0], (len(h), 1)))  # channel X reads DX_F only
    low, up = dwell_lower_bound(np.zeros((2, 2)), h, white, [target, target])
    closed = (white / target) ** 2
    assert low == pytest.approx(closed, rel=0.01) and up == pytest.approx(closed, rel=0.01)
    one_axis = replace(lab, axes=(("base", (0.0, 0.0, 1.0)),))  # turning about Up: a_X·a_Y stays 0
    rows = grid_rows(Model(("DX_F", "DX_XY"), "tdf-gyro"), one_axis)
    assert dwell_lower_bound(np.zeros((2, 2)), rows, white, [target, target])[1] == math.inf


def test_a_slow_drift_the_records_cannot_resolve_does_not_set_the_hours(first_records):
    """A Gauss–Markov term whose τ the records hold fewer than ten times in their longest continuous segment (the
    tumble: one segment of its whole duration) is left out of the designed test's noise and said; one they resolve
    is kept."""
    from types import SimpleNamespace

    from gyrojax.adaptive.information import RESOLVED_CORRELATION_TIMES, test_noise
    from gyrojax.noise.spec import NoiseSpec

    span = float(first_plan().duration_s)
    for tau, kept in ((span / 4.5, False), (span / (2 * RESOLVED_CORRELATION_TIMES), True)):
        fake = SimpleNamespace(noise=[NoiseSpec(white=0.005, gauss_markov=((0.016, tau),))])
        noise, unresolved = test_noise(fake, first_records)
        assert noise.white == pytest.approx(0.005)
        assert bool(noise.gauss_markov) is kept and bool(unresolved) is not kept


def test_no_test_holds_its_positions_for_less_than_the_settle_time(first_records):
    """Requirements the records already meet by their information: the design is the shortest test worth moving the
    table for — every position held the lab's settle time (or its fewest samples) on average — never one of near-zero
    dwell."""
    from gyrojax.adaptive.design import design_test
    from gyrojax.noise.spec import NoiseSpec

    goal = Goal(sigma=TARGET)
    lab = fast_lab(first_records)
    terms = ("D_F", "D_I", "D_S")
    reqs = [r for r in rq.build(terms, goal, lab.kind, 0.01) if r.kind == "sigma"]
    uni = rq.universe(terms, goal, lab.kind)
    test = design_test(
        uni, rq.arrays(reqs, uni), 1e12 * np.eye(uni.size), lab, NoiseSpec(white=0.005), 8.0, 0.0, 0.95, steps=20
    )
    # the settle time, or the four samples a position keeps at least (here 4 × 60 s)
    shortest = max(lab.settle_s, 4 * lab.dt_s)
    assert test.dwell_hours == pytest.approx(lab.positions * shortest / 3600.0, rel=1e-6)


def tumble_then(truth, positions, seed):
    """The study's records of a campaign seed: its first test (the polar tumble, 30 s samples) and then static
    ``positions`` ((outer, inner) deg, dwell s) on its two-axis table, noise keys as the campaign draws them; and
    that lab."""
    import jax

    first = plans.tumble(revolutions=2.0, earth_rates=20.0, dt_s=30.0, flip=False, both_directions=False)
    key = jax.random.PRNGKey(seed)
    records = simulate(first, truth, key=jax.random.fold_in(key, 0))
    lab = Lab.from_records(records, axes=plans.TWO_AXIS, turn_case=False, mountings_per_test=1)
    ang = np.array([[a for a, _ in positions]], dtype=float)
    dwell = np.array([[d for _, d in positions]], dtype=float)
    plan = lab.plan("test-2", lab.triad[None], ang, dwell, "the loop's second test")
    clock = float(records[0].time_s[-1]) + lab.settle_s
    return records + simulate(plan, truth, key=jax.random.fold_in(key, 1), start_s=clock), lab


# the study's truth 10 (benchmarks/study_campaign.py): D_SS and D_O hidden from the first test (a polar tumble), and
# the 12 static positions the loop designed next: (outer, inner) deg and dwell s
RIVAL_TRUTH = {
    "coefficients": {"D_F": -0.2848, "D_I": -0.6555, "D_S": 0.6518, "D_SS": -0.04697, "D_O": -0.04129},
    "noise": {"white": 0.005},
}
RIVAL_POSITIONS = [
    ((154.039022, 36.051893), 780), ((94.380441, 62.306726), 1170), ((78.661723, 125.156316), 720),
    ((71.886967, 134.021443), 1920), ((23.168092, 199.540404), 1170), ((75.251028, 230.647591), 1110),
    ((104.630586, 309.201392), 1170), ((155.143996, 329.148631), 2790), ((235.623457, 264.873743), 2310),
    ((287.787421, 313.542941), 840), ((299.220975, 21.985256), 1740), ((258.865372, 75.991891), 2700),
]  # fmt: skip


@pytest.mark.slow
def test_two_missing_effects_that_look_like_a_third_are_not_named_by_it():
    """After the tumble and those positions, one-at-a-time score tests rank a scale-factor asymmetry E_A·|ω_I| (at
    Earth rate, it follows a_O and a_S² across the positions) above D_O and D_SS, the effects the truth holds; the
    asymmetry is not significant beside them, so the step must not add it (a false effect) but name the group the
    next test separates, the truth's effects among it."""
    records, lab = tumble_then(RIVAL_TRUTH, RIVAL_POSITIONS, 10)
    nt = next_test(records, ["D_F", "D_I", "D_S"], Goal(sigma=0.003), lab, looks=1, hours_spent=lab.budget_hours)
    assert "budget" in nt.reason  # the model updated, no test designed: the budget is spent
    assert "sf_asymmetry" not in nt.terms
    assert {"D_O", "D_SS"} <= set(nt.terms) | set(nt.alias)


# the study's truth 31: D_SS and D_O hidden from the tumble, and 12 static positions shaped for the models the records
# may hold (D_II or D_SS, with D_O, D_IO or D_OS): they tell D_II from D_SS only in part
PARTIAL_TRUTH = {
    "coefficients": {"D_F": -0.39259, "D_I": -0.70578, "D_S": -0.3851, "D_SS": -0.11034, "D_O": 0.0706},
    "noise": {"white": 0.005},
}
PARTIAL_POSITIONS = [
    ((54.536076, 0.603286), 4134), ((223.900531, 180.61951), 2202), ((120.257234, 137.95298), 4118),
    ((89.74798, 274.140619), 2597), ((274.539613, 263.484812), 2411), ((12.623712, 262.359451), 1231),
    ((321.621738, 337.853924), 1279), ((236.881792, 33.972372), 2096), ((280.366787, 4.150676), 3317),
    ((183.175933, 114.942567), 1709), ((123.830244, 221.693506), 2093), ((160.232581, 158.664445), 1612),
]  # fmt: skip


def test_a_watched_effect_that_holds_only_for_a_missing_one_is_not_added():
    """After those positions D_II, alone beside the model, takes D_SS's signal through their correlation and is the
    strongest proposal (≈ +0.09 ± 0.01 deg/h/g², the truth 0); beside D_SS and D_O, the significant watched
    candidates, it is nothing, and they hold beside it: the step adds D_SS and D_O and never D_II (a false effect
    no later look removes)."""
    records, lab = tumble_then(PARTIAL_TRUTH, PARTIAL_POSITIONS, 31)
    nt = next_test(records, ["D_F", "D_I", "D_S"], Goal(sigma=0.003), lab, looks=1, hours_spent=lab.budget_hours)
    assert "budget" in nt.reason  # the model updated, no test designed: the budget is spent
    assert "D_II" not in nt.terms
    assert {"D_SS", "D_O"} <= set(nt.terms)
