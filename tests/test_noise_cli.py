"""``gyrojax noise`` with GMWM: --taus, the model ADEV and adequacy in the JSON, timestamp jitter, and the noise
model fed to ``fit``, ``design`` and ``mc`` (--noise-model)."""

import json

import numpy as np
import pandas as pd
import pytest

from gyrojax.cli.app import main
from gyrojax.data import plans
from gyrojax.data.records import save_record
from gyrojax.noise import gmwm_model as gmwm
from gyrojax.simulation.simulator import simulate

NOISE = {"white": 0.003, "gauss_markov": [0.02, 60.0]}


@pytest.fixture(scope="module")
def static(tmp_path_factory):
    d = tmp_path_factory.mktemp("gmwmcli")
    recs = simulate(plans.fixed_position(hours=2.0, dt_s=0.5), {"coefficients": {"D_F": 0.4}, "noise": NOISE}, seed=9)
    return save_record(recs[0], d), d


def _run(capsys, args):
    rc = main(args)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def test_json_carries_model_adequacy_and_derived(static, capsys):
    path, d = static
    rc, out, _ = _run(capsys, ["noise", str(path), "--json", "--model", "white+gm", "--plot", str(d / "n.png")])
    assert rc == 0
    o = json.loads(out)
    n = len(o["taus_s"])
    assert len(o["adev_model_deg_per_h"]) == n and len(o["adequacy"]["inside"]) == n
    assert o["adequacy"]["n_outside"] <= 2, o["adequacy"]["verdict"]
    assert o["adequacy"]["verdict"].startswith(("model inside", "fit:"))
    p = o["model"]["parameters"]
    assert abs(p["white"]["value"] - 0.003) < 3 * p["white"]["std"]
    assert abs(p["gm1_sigma"]["value"] - 0.02) < 3 * p["gm1_sigma"]["std"]
    assert o["derived"]["arw"]["value"] == pytest.approx(0.003, rel=0.1)
    assert (d / "n.png").read_bytes()[:4] == b"\x89PNG"
    # the text output ends with the one-line verdict
    rc, text, _ = _run(capsys, ["noise", str(path), "--model", "white+gm"])
    assert rc == 0 and text.strip().splitlines()[-1] == o["adequacy"]["verdict"]


def test_taus_exact_list_octave_decade(static, capsys):
    path, _ = static
    rc, out, _ = _run(capsys, ["noise", str(path), "--json", "--taus", "0.5,1.5,4,100"])
    assert rc == 0
    assert json.loads(out)["taus_s"] == [0.5, 1.5, 4.0, 100.0]
    rc, out, _ = _run(capsys, ["noise", str(path), "--json", "--taus", "octave"])
    t = np.array(json.loads(out)["taus_s"])
    np.testing.assert_allclose(t, 0.5 * 2 ** np.arange(len(t)))
    assert t[-1] * 2 > 7200 / 2 / 2  # up to half the record
    rc, out, _ = _run(capsys, ["noise", str(path), "--json", "--taus", "decade"])
    assert json.loads(out)["taus_s"][:6] == [0.5, 1.0, 2.0, 5.0, 10.0, 20.0]


@pytest.mark.parametrize(
    "taus, msg",
    [("0.75", "not a multiple"), ("1,abc", "comma-separated"), ("5000", "longer than half"), ("-1", "positive")],
)
def test_bad_taus_exit_2(static, capsys, taus, msg):
    path, _ = static
    rc, _, err = _run(capsys, ["noise", str(path), "--taus", taus])
    assert rc == 2 and msg in err and len(err.strip().splitlines()) == 1


def test_timestamp_jitter(static, capsys, tmp_path):
    """Small jitter: the mean interval is used and the output says so; large jitter is refused."""
    path, _ = static
    csv = path if str(path).endswith(".csv") else next(path.parent.glob(f"{path.stem}*.csv"))
    df = pd.read_csv(csv, comment="#")
    rng = np.random.default_rng(0)
    lines = csv.read_text().splitlines(keepends=True)
    head = [ln for ln in lines if ln.startswith("#")]
    for name, amp, rc_want in (("small", 0.01, 0), ("large", 0.3, 2)):
        d = df.copy()
        d["time_s"] = d["time_s"] + rng.uniform(-amp, amp, len(d)) * 0.5
        out = tmp_path / name
        out.mkdir()
        for f in csv.parent.glob(f"{csv.stem}.*"):
            if f.suffix != ".csv":
                (out / f.name).write_bytes(f.read_bytes())
        (out / csv.name).write_text("".join(head) + d.to_csv(index=False))
        rc, o, err = _run(capsys, ["noise", str(out / csv.name), "--json", "--model", "white+gm"])
        assert rc == rc_want, err
        if rc == 0:
            assert any("jitter" in n and "mean interval" in n for n in json.loads(o)["notes"])
        else:
            assert "jitter" in err and "non-uniform" in err


def test_fit_design_mc_take_the_noise_model(static, capsys, tmp_path):
    path, d = static
    rc, out, _ = _run(capsys, ["noise", str(path), "--json", "--model", "white+gm"])
    nj = tmp_path / "noise.json"
    nj.write_text(out)
    # fit: GLS with the given model, not re-estimated — the same as fit(noise=the model)
    rc, out, err = _run(capsys, ["fit", str(path), "--terms", "D_F", "--json", "--noise-model", str(nj)])
    assert rc == 0, err
    res = json.loads(out)
    from gyrojax.data.records import load_records
    from gyrojax.inference.identify import fit

    model = gmwm.load_noise_model(nj)
    direct = fit(load_records([path]), ["D_F"], noise=model)
    assert res["coefficients"]["D_F"]["value"] == pytest.approx(float(direct.theta[0]), rel=1e-9)
    # under GM drift the std of a 2 h mean is set by the GM: σ²·f(T/τ) ≈ 2σ²τ/T
    expect = np.sqrt(0.02**2 * 2 * 60 / 7200 + (60 * 0.003) ** 2 / 7200)
    assert res["coefficients"]["D_F"]["std"] == pytest.approx(expect, rel=0.35)
    # a model with a random walk cannot be whitened: one clear line, exit 2
    rc, out, _ = _run(capsys, ["noise", str(path), "--json", "--model", "white+gm+rw"])
    rw = tmp_path / "rw.json"
    rw.write_text(out)
    rc, _, err = _run(capsys, ["fit", str(path), "--terms", "D_F", "--noise-model", str(rw)])
    assert rc == 2 and "random_walk" in err
    # mc: the study's noise replaced by the model's noise dict (saved with the study)
    study = {
        "plan": "multiposition",
        "plan_options": {"n": 8, "minutes": 1, "dt_s": 5},
        "terms": ["D_F", "D_I"],
        "priors": {"D_F": {"normal": [0, 1]}, "D_I": {"normal": [0, 1]}},
        "noise": {"white": 0.01},
        "draws": 10,
        "seed": 1,
    }
    sp = tmp_path / "study.json"
    sp.write_text(json.dumps(study))
    rc, _, err = _run(capsys, ["mc", str(sp), "--out", str(tmp_path / "mc"), "--noise-model", str(nj), "--json"])
    assert rc == 0, err
    saved = json.loads((tmp_path / "mc" / "study.json").read_text())["noise"]
    nd = model.to_truth()
    assert saved["white"] == pytest.approx(nd["white"]) and saved["gauss_markov"] == pytest.approx(nd["gauss_markov"])
    # design: the model's ARW and GM as the noise of the plan
    rc, out, err = _run(
        capsys,
        [
            "design",
            "--terms",
            "D_F,D_I,D_O",
            "--positions",
            "6",
            "--hours",
            "1",
            "--out",
            str(tmp_path / "p.json"),
            "--json",
            "--starts",
            "1",
            "--adam-steps",
            "20",
            "--lbfgs-steps",
            "0",
            "--dt",
            "30",
            "--noise-model",
            str(nj),
        ],
    )
    assert rc == 0, err
    # a random walk enters the design through the full covariance of the position means (noise.meancov)
    quick = ["--terms", "D_F,D_I,D_O", "--starts", "1", "--adam-steps", "5", "--lbfgs-steps", "0", "--json"]
    rc, _, err = _run(
        capsys, ["design", "--positions", "6", "--out", str(tmp_path / "q.json"), "--noise-model", str(rw), *quick]
    )
    assert rc == 0 and (tmp_path / "q.json").exists(), err


def test_json_carries_the_spectral_line_search(static, capsys):
    path, _ = static
    rc, out, _ = _run(capsys, ["noise", str(path), "--json", "--model", "white+gm"])
    o = json.loads(out)
    assert rc == 0 and o["spectral_lines"] == []  # a simulated record of white + Gauss–Markov noise has none
    s = o["spectral_line_search"]
    assert s["searched"] and s["level"] == 0.01 and s["bins_tested"] > 50 and s["band_hz"][1] < 1.0 / (2 * 0.5)
