"""The one noise description: its Allan variance against the PSD integrals of IEEE 952 annex C, the sampled forms
against the continuous ones, the simulator against allantools, the variance of a mean against the double integral of
the autocovariance, the AR stationary variance against its closed form, truth dicts and saved files round trips."""

import json
import math
from dataclasses import replace

import allantools
import jax
import numpy as np
import pytest
from scipy import integrate

from gyrojax.errors import TruthError
from gyrojax.noise.processes import simulate
from gyrojax.noise.spec import BI_FACTOR, NoiseModelError, NoiseSpec


def _psd_avar(psd, tau):
    """σ²(τ) = 4 ∫₀^∞ S(f) sin⁴(πfτ)/(πfτ)² df (IEEE 952 C.1) for a one-sided rate PSD S in (deg/h)²/Hz."""

    def g(lx):  # in x = πfτ on a log scale, f = x/(πτ), df = x dlx/(πτ)
        x = math.exp(lx)
        return psd(x / (math.pi * tau)) * math.sin(x) ** 4 / x**2 * x / (math.pi * tau)

    val, _ = integrate.quad(g, math.log(1e-6), math.log(2e3), limit=2000)
    return 4.0 * val


@pytest.mark.parametrize("tau", [1.0, 30.0, 1000.0])
def test_adev_closed_forms_against_psd_integrals(tau):
    """White N: S = (60N)²; random walk K: S = (K/60)²/(2πf)²; bias instability B: S = B²/(2πf) between edges far
    outside τ (its floor (2 ln 2/π)B² = (BI_FACTOR·B)²); each term alone and their sum."""
    n, k, b = 0.01, 0.3, 0.05
    psds = {
        "white": lambda f: (60 * n) ** 2,
        "random_walk": lambda f: (k / 60) ** 2 / (2 * math.pi * f) ** 2,
        "bias_instability": lambda f: b**2 / (2 * math.pi * f),
    }
    spec = NoiseSpec(white=n, random_walk=k, bias_instability=b)
    terms = spec.term_avar(np.array([tau]))
    for name, psd in psds.items():
        assert terms[name][0] == pytest.approx(_psd_avar(psd, tau), rel=2e-3), name
    assert BI_FACTOR == pytest.approx(0.6643, abs=1e-4)
    assert spec.avar(np.array([tau]))[0] == pytest.approx(sum(v[0] for v in terms.values()), rel=1e-12)


def test_rate_ramp_and_quantization_from_their_definitions():
    """Rate ramp R: the overlapping Allan variance of y = R·t/3600 is R²τ²/(2·3600²) exactly (allantools);
    quantization Q: second differences of independent angle errors of std Q give 6Q²/(2τ²) = 3Q²/τ²."""
    r, dt, m = 2.0, 0.5, np.array([1, 4, 16])
    y = r * np.arange(4000) * dt / 3600.0
    _, ad, _, _ = allantools.oadev(y, rate=1 / dt, data_type="freq", taus=m * dt)
    np.testing.assert_allclose(NoiseSpec(rate_ramp=r).avar(m * dt), ad**2, rtol=1e-6)
    assert NoiseSpec(quantization=0.7).avar(np.array([3.0]))[0] == pytest.approx(6 * 0.7**2 / (2 * 9.0))


def test_sampled_forms_tend_to_the_continuous_ones():
    """A spec with a sample interval has the exact Allan variance of the sampled processes; at τ ≫ Δt it is the
    continuous closed form (the random walk's discrete correction is Δt/(2τ) relative, the GM's smaller)."""
    cont = NoiseSpec(white=0.01, random_walk=0.2, gauss_markov=((0.05, 40.0),), quantization=0.3, rate_ramp=0.5)
    samp = replace(cont, dt_s=0.01)
    taus = np.array([10.0, 100.0, 1000.0])
    np.testing.assert_allclose(samp.avar(taus), cont.avar(taus), rtol=2e-3)
    assert (
        set(samp.term_avar(taus))
        == set(cont.term_avar(taus))
        == {
            "white",
            "quantization",
            "random_walk",
            "rate_ramp",
            "gm1",
        }
    )


def test_simulated_drift_has_the_model_adev():
    """200 draws of the one simulator (white + GM + RW + quantization at 2 Hz): the mean of allantools' oadev² is the
    spec's Allan variance within 4 standard errors at every octave τ."""
    dt, n, draws = 0.5, 4096, 200
    spec = NoiseSpec(white=0.02, quantization=2.0, random_walk=1.5, gauss_markov=((3.0, 40.0),))
    t = np.arange(n) * dt
    gen = jax.jit(lambda k: simulate(spec, k, t, dt_white=dt))
    m = 2 ** np.arange(9)
    avs = []
    for d in range(draws):
        _, ad, _, _ = allantools.oadev(
            np.asarray(gen(jax.random.PRNGKey(d))), rate=1 / dt, data_type="freq", taus=m * dt
        )
        avs.append(ad**2)
    avs = np.array(avs)
    se = avs.std(axis=0, ddof=1) / math.sqrt(draws)
    want = replace(spec, dt_s=dt).avar(m * dt)
    assert np.all(np.abs(avs.mean(axis=0) - want) < 4 * se), avs.mean(axis=0) / want


def test_mean_variance_against_the_autocovariance_integral():
    """Var(mean over T) = (1/T²)∫∫ C(t − s) ds dt: white (60N)²/T, Gauss–Markov by scipy's quad of σ²e^{−|t−s|/τ};
    terms without a stationary mean variance are refused by name."""
    n, s, tau, span = 0.003, 0.02, 60.0, 300.0
    # ∫∫ C(t − s) over the square = 2 ∫₀^T (T − u) C(u) du (the lag u = |t − s| has density 2(T − u))
    gm, _ = integrate.quad(lambda u: 2 * (span - u) * s * s * math.exp(-u / tau), 0, span, epsabs=0, epsrel=1e-13)
    spec = NoiseSpec(white=n, gauss_markov=((s, tau),))
    assert float(spec.mean_variance(span)) == pytest.approx((60 * n) ** 2 / span + gm / span**2, rel=1e-10)
    with pytest.raises(NoiseModelError, match="random_walk"):
        NoiseSpec(white=n, random_walk=0.1).mean_variance(span)


def test_ar_stationary_variance_and_innovation():
    """AR(2) φ = (0.75, −0.5), innovation variance s²: γ0 = s²(1 − φ2)/((1 + φ2)((1 − φ2)² − φ1²)) (Box–Jenkins)."""
    p1, p2, s2 = 0.75, -0.5, 2.0
    spec = NoiseSpec.from_sample_variances(s2, 1.0, ar=(p1, p2), method="ar")
    gamma0 = s2 * (1 - p2) / ((1 + p2) * ((1 - p2) ** 2 - p1**2))
    assert spec.stationary_std**2 == pytest.approx(gamma0, rel=1e-12)
    assert spec.innovation_std**2 == pytest.approx(s2, rel=1e-12) and spec.order == 2
    assert spec.variance_ratio == pytest.approx(gamma0 / s2, rel=1e-12)
    with pytest.raises(NoiseModelError, match="AR"):
        spec.avar(np.array([1.0]))


def test_truth_dict_round_trip_and_errors():
    """The truth file's noise dict of conventions §8 reads into a spec and writes back unchanged."""
    d = {"white": 0.0015, "gauss_markov": [0.004, 900.0], "random_walk": 0.01, "quantization": 0.2}
    spec = NoiseSpec.from_truth(d)
    assert spec.white == 0.0015 and spec.gauss_markov == ((0.004, 900.0),) and spec.to_truth() == d
    bi = {"white": 0.001, "bias_instability": [0.05, 1.0, 1e5]}
    assert NoiseSpec.from_truth(bi).to_truth() == bi
    with pytest.raises(TruthError, match="'pink'"):
        NoiseSpec.from_truth({"pink": 1.0}, "truth.json: noise")
    with pytest.raises(TruthError, match=r"truth.json: noise.white"):
        NoiseSpec.from_truth({"white": -1.0}, "truth.json: noise")
    with pytest.raises(TruthError, match="gauss_markov"):
        NoiseSpec.from_truth({"gauss_markov": [0.1]})
    with pytest.raises(NoiseModelError, match="truth file"):
        NoiseSpec(white=0.1, gauss_markov=((0.1, 1.0), (0.2, 10.0))).to_truth()


def test_saved_spec_loads_back_whole(tmp_path):
    """Every field, a pinned (infinite-variance) parameter, the status and the info table survive save → load; the
    file is strict JSON with the format tag and integer version first."""
    spec = NoiseSpec(
        white=0.01,
        random_walk=0.3,
        gauss_markov=((0.05, 30.0), (0.02, 900.0)),
        dt_s=0.1,
        method="gmwm",
        cov=[[1e-8, 0, 0], [0, math.inf, 0], [0, 0, 4.0]],
        cov_names=("white", "random_walk", "gm1_tau"),
        converged=False,
        reason="Levenberg-Marquardt stopped at its iteration limit (80) before converging",
        info={"model": "white+2gm+rw", "p_value": None, "selection": [{"model": "white", "wic": 3.5}]},
        readout_var=0.0027,
    )
    p = spec.save(tmp_path / "n.json")
    text = p.read_text()
    assert "Infinity" not in text and "NaN" not in text
    doc = json.loads(text)
    assert list(doc)[:2] == ["format", "format_version"] and doc["format"] == "gyrojax-noise-model"
    back = NoiseSpec.load(p)
    assert back == spec
    assert back.std("random_walk") == math.inf and back.parameters()["random_walk"]["std"] is None
    assert back.std("gm1_tau") == 2.0 and math.isnan(back.std("gm1_sigma"))
    with pytest.raises(Exception, match="exists"):
        spec.save(p)
    assert doc["readout_var"] == 0.0027
    old = {k: v for k, v in doc.items() if k != "readout_var"}  # a file written before the servo readout term
    assert NoiseSpec.from_json(old) == replace(spec, readout_var=0.0)
    doc["format_version"] = 7
    (tmp_path / "bad.json").write_text(json.dumps(doc))
    with pytest.raises(NoiseModelError, match="format_version"):
        NoiseSpec.load(tmp_path / "bad.json")


def test_bad_specs_are_refused_naming_the_field():
    with pytest.raises(NoiseModelError, match="white"):
        NoiseSpec(white=-0.1)
    with pytest.raises(NoiseModelError, match=r"gauss_markov\[0\] tau"):
        NoiseSpec(gauss_markov=((0.1, 0.0),))
    with pytest.raises(NoiseModelError, match="method"):
        NoiseSpec(method="magic")
    with pytest.raises(NoiseModelError, match="cov"):
        NoiseSpec(cov=[[1.0]], cov_names=("white", "quantization"))
    with pytest.raises(NoiseModelError, match="dt_s"):
        NoiseSpec(ar=(0.5,))
    with pytest.raises(NoiseModelError, match="random_walk"):
        NoiseSpec(white=0.1, random_walk=0.1, dt_s=1.0).whitening_theta()
    with pytest.raises(NoiseModelError, match="readout_var"):
        NoiseSpec(readout_var=-1e-3)


def test_whitening_parameters():
    """(T, σ_g², σ_w²) of the filter: σ_w² = (60N)²/Δt at the spec's interval or at one given."""
    spec = NoiseSpec(white=0.01, gauss_markov=((0.3, 200.0),), dt_s=0.1)
    t, g, w = spec.whitening_theta()
    assert (t, g) == pytest.approx((200.0, 0.09)) and w == pytest.approx(0.36 / 0.1)
    assert spec.whitening_theta(2.0)[2] == pytest.approx(0.36 / 2.0)
