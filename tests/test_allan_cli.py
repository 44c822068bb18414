"""``gyrojax noise``: JSON schema, the fit on a simulated static record, the plot, and input errors (exit 2)."""

import json

import pytest

from gyrojax import plans
from gyrojax.cli import main
from gyrojax.records import save_record
from gyrojax.simulate import simulate


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
    assert list(out) == ["taus_s", "adev_deg_per_h", "adev_low", "adev_high", "terms"]
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
