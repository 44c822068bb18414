"""``gyrojax noise``: JSON schema, the fit on a simulated static record, the plot, and input errors (exit 2)."""

import json

import pytest

from gyrojax.cli.app import main
from gyrojax.data import plans
from gyrojax.data.records import save_record
from gyrojax.simulation.simulator import simulate


@pytest.fixture(scope="module")
def static_record(tmp_path_factory):
    d = tmp_path_factory.mktemp("noise")
    recs = simulate(plans.fixed_position(hours=3.0), {"coefficients": {"D_F": 0.4}, "noise": {"white": 0.002}}, seed=4)
    return str(save_record(recs[0], d)), d


def test_noise_json_and_plot(static_record, capsys):
    path, d = static_record
    png = d / "allan.png"
    assert main(["noise", path, "--json", "--plot", str(png)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert list(out)[:5] == ["taus_s", "adev_deg_per_h", "adev_low", "adev_high", "terms"]
    assert {"adev_model_deg_per_h", "adequacy", "derived", "model", "method"} <= set(out)
    assert list(out["terms"]) == ["white", "bias_instability", "random_walk", "quantization", "gauss_markov"]
    n = len(out["taus_s"])
    assert n > 10 and all(len(out[k]) == n for k in ("adev_deg_per_h", "adev_low", "adev_high"))
    assert all(
        lo <= a <= hi for lo, a, hi in zip(out["adev_low"], out["adev_deg_per_h"], out["adev_high"], strict=True)
    )
    # 3 h of white drift, N = 0.002 deg/√h: ADEV(1 s) = 0.12 deg/h; the fit keeps white alone, within 5 %
    # (10 800 samples: the white-FM EDF of the pooled fit is in the thousands, so 5 % is > 5σ)
    assert out["terms"]["white"] == {"value": pytest.approx(0.002, rel=0.05), "unit": "deg/sqrt(h)"}
    assert out["terms"]["random_walk"]["unit"] == "deg/h/sqrt(h)"
    assert out["terms"]["quantization"]["unit"] == "arcsec"
    assert out["terms"]["bias_instability"]["unit"] == "deg/h"
    assert out["adev_deg_per_h"][0] == pytest.approx(0.12, rel=0.05)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the plot is not overwritten without --force
    assert main(["noise", path, "--plot", str(png)]) == 2
    assert main(["noise", path, "--plot", str(png), "--force"]) == 0


def test_noise_rejects_moving_and_missing_records(tmp_path, capsys):
    recs = simulate(plans.tumble(revolutions=0.05, dt_s=10.0), {}, seed=0)
    p = save_record(recs[0], tmp_path)
    assert main(["noise", str(p), "--json"]) == 2
    assert "static" in capsys.readouterr().err
    assert main(["noise", str(tmp_path / "nothing.json")]) == 2


def test_noise_pools_records(tmp_path, capsys):
    """Two static records of one campaign are pooled: the 1 s ADEV of the pool matches the direct pooled
    estimate of their indicated rates (Σ S_j / 2τ² Σ M_j, from allantools' per-record values)."""
    import dataclasses
    import math

    import allantools
    import numpy as np

    from gyrojax.data.records import load_records

    p = plans.fixed_position(hours=0.5)
    p = dataclasses.replace(p, runs=(p.runs[0], dataclasses.replace(p.runs[0], name="fixed-b")))
    for r in simulate(p, {"noise": {"white": 0.003}}, seed=2):
        save_record(r, tmp_path)
    assert main(["noise", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    num = den = 0.0
    for r in load_records([tmp_path]):
        _, d, _, ns = allantools.oadev(r.indicated, rate=1.0, data_type="freq", taus=np.array([1.0]))
        num, den = num + d[0] ** 2 * ns[0], den + ns[0]
    assert out["adev_deg_per_h"][0] == pytest.approx(math.sqrt(num / den), rel=1e-9)
    assert out["terms"]["white"]["value"] == pytest.approx(0.003, rel=0.1)
    assert np.isfinite(out["adev_high"]).all()
