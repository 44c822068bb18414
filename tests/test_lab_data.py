"""Lab-data details that used to fail silently (issue 17): records of different instruments pooled into one fit,
noise groups split by the last digits of the timestamps, logger jitter refused by the Allan analysis, and
estimates of regressors that are only floating-point residue (D_IO = −1.8e17)."""

import copy
import json

import numpy as np
import pytest

from gyrojax import simulate
from gyrojax.cli.app import main
from gyrojax.data import plans
from gyrojax.data.record import Record
from gyrojax.data.records import save_record
from gyrojax.data.timebase import interval_key, uniform_interval
from gyrojax.errors import ModelError, RecordError
from gyrojax.inference.campaign import Campaign
from gyrojax.inference.diagnose import diagnose
from gyrojax.inference.identify import fit, fit_per_instrument
from gyrojax.inference.noisefit import noise_groups


def _with_meta(rec: Record, name: str, **inst) -> Record:
    meta = copy.deepcopy(rec.meta)
    meta["name"] = name
    meta["instrument"].update(inst)
    return Record(meta, dict(rec.columns))


@pytest.fixture(scope="module")
def three_channels():
    """Three gyros (channels x, y, z) with very different biases, one 8-position plan each."""
    plan = plans.multiposition(8, minutes=1, dt_s=2)
    out = []
    for i, (ch, d_f) in enumerate((("x", 4.31), ("y", -9.82), ("z", -7.98))):
        (rec,) = simulate(plan, {"coefficients": {"D_F": d_f, "D_I": 0.5}, "noise": {"white": 0.002}}, seed=i)
        out.append((_with_meta(rec, f"imu-{ch}", id="imu-7", channel=ch), d_f))
    return out


def test_records_of_different_channels_are_never_pooled(three_channels):
    recs = [r for r, _ in three_channels]
    with pytest.raises(ModelError, match=r"3 different instruments/channels.*imu-7\[x\].*--per-instrument"):
        fit(recs, ["D_F", "D_I"])
    res = fit_per_instrument(recs, ["D_F", "D_I"])
    assert list(res) == ["imu-7[x]", "imu-7[y]", "imu-7[z]"]
    for (_, d_f), r in zip(three_channels, res.values()):
        assert abs(r.values["D_F"] - d_f) < 5 * r.stds["D_F"] + 1e-3


def test_cli_fit_refuses_mixed_channels_and_fits_per_instrument(three_channels, tmp_path, capsys):
    for r, _ in three_channels:
        save_record(r, tmp_path)
    assert main(["fit", str(tmp_path), "--terms", "D_F,D_I", "--json"]) == 2
    err = capsys.readouterr().err
    assert "different instruments/channels" in err and len(err.strip().splitlines()) == 1
    assert main(["fit", str(tmp_path), "--terms", "D_F,D_I", "--json", "--per-instrument"]) == 0
    out = json.loads(capsys.readouterr().out)
    got = {k: v["coefficients"]["D_F"]["value"] for k, v in out["instruments"].items()}
    want = {f"imu-7[{c}]": d for c, d in zip("xyz", (4.31, -9.82, -7.98))}
    assert got.keys() == want.keys() and all(abs(got[k] - want[k]) < 0.05 for k in got)


def test_noise_groups_ignore_the_last_digits_of_the_timestamps():
    plan = plans.multiposition(8, minutes=1, dt_s=1 / 204.8)
    recs = simulate(plan, {"coefficients": {"D_F": 0.4}, "noise": {"white": 0.01}}, seed=3)
    rec = recs[0]
    # the same run written twice: once with full precision, once with 7 significant digits (a logger's format)
    a = _with_meta(rec, "full")
    t7 = np.array([float(f"{x:.7g}") for x in rec.time_s])
    b = _with_meta(rec.with_columns(time_s=t7), "seven-digits")
    assert np.median(np.diff(a.time_s)) != np.median(np.diff(b.time_s))  # the old key, round(dt, 9), split them
    assert noise_groups(Campaign.of([a, b])) == [[0, 1]]
    # a genuinely different rate is a different group; the user's key decides when given
    plan2 = plans.multiposition(8, minutes=1, dt_s=0.01)
    (c,) = simulate(plan2, {"noise": {"white": 0.01}}, seed=4)
    c = _with_meta(c, "100Hz")
    assert noise_groups(Campaign.of([a, b, c])) == [[0, 1], [2]]
    c.meta["noise_group"] = "g"
    a.meta["noise_group"] = "g"
    assert noise_groups(Campaign.of([a, b, c])) == [[0, 2], [1]]
    assert interval_key(1 / 204.8) == interval_key(float(f"{1 / 204.8:.7g}")) == 0.00488


def test_uniform_interval_accepts_jitter_and_refuses_gaps():
    # an exact 204.8 Hz clock written with 10 significant digits
    t = np.array([float(f"{x:.10g}") for x in 1234.5 + np.arange(2000) / 204.8])
    dt, jitter = uniform_interval(t)
    assert dt == pytest.approx(1 / 204.8, rel=1e-7) and 1e-6 < jitter < 1e-3
    rng = np.random.default_rng(0)
    t2 = np.cumsum(rng.uniform(0.0099, 0.01005, 500))  # a logger's 9.9–10.05 ms steps
    dt2, jitter2 = uniform_interval(t2)
    assert dt2 == pytest.approx(np.diff(t2).mean()) and jitter2 < 0.02
    with pytest.raises(RecordError, match=r"step 3 is .* a gap or a change of sample rate"):
        uniform_interval(np.array([0.0, 0.01, 0.02, 0.05, 0.06]))


def test_cli_noise_tolerates_logger_jitter_and_says_so(tmp_path, capsys):
    plan = plans.fixed_position(hours=0.05, dt_s=0.01)
    (rec,) = simulate(plan, {"noise": {"white": 0.01}}, seed=5)
    rng = np.random.default_rng(1)
    t = rec.time_s + rng.uniform(-5e-5, 5e-5, rec.n)  # ±0.5 % stamp jitter
    save_record(rec.with_columns(time_s=t), tmp_path)
    assert main(["noise", str(tmp_path), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert any("jitter" in n and "mean interval" in n for n in res["notes"]), res["notes"]
    assert res["terms"]["white"]["value"] == pytest.approx(0.01, rel=0.15)  # the simulated ARW, deg/√h


@pytest.fixture(scope="module")
def residue_campaign():
    """A two-axis plan whose inner angle is only ever 90° or 270°: a_O is cos 90° = 6e-17 (times a), not 0."""
    positions = [(a, b) for a in (0, 90, 180, 270, 45, 135) for b in (90, 270)]
    plan = plans.multiposition(positions=positions, minutes=1, dt_s=2, mount=plans.sdf_mount((1, 0, 0), (0, 1, 0)))
    return simulate(plan, {"coefficients": {"D_F": 0.4, "D_I": 0.3}, "noise": {"white": 0.001}}, seed=1)


def test_fit_suppresses_residue_regressors(residue_campaign):
    with pytest.raises(ModelError, match="not excited by this plan: D_O, D_IO"):
        fit(residue_campaign, ["D_F", "D_I", "D_O", "D_IO"])
    res = fit(residue_campaign, ["D_F", "D_I", "D_O", "D_IO"], allow_aliases=True)
    assert res.values["D_IO"] == 0.0 and res.values["D_O"] == 0.0
    assert np.isnan(res.stds["D_IO"]) and np.isnan(res.stds["D_O"])
    assert abs(res.values["D_I"] - 0.3) < 5 * res.stds["D_I"]
    assert res.to_json()["not_excited"] == ["D_O", "D_IO"]


def test_diagnose_lists_residue_regressors_as_not_excited(residue_campaign):
    d = diagnose(residue_campaign, ["D_F", "D_I"])
    out = d.to_json()
    for name in ("D_O", "D_OO", "D_IO", "D_OS"):
        assert name in out["not_excited"]
    assert all(c["name"] not in out["not_excited"] for c in out["candidates"])
    for c in out["candidates"]:
        for v in c["estimate"].values():
            assert abs(v["value"]) < 1e6, c
