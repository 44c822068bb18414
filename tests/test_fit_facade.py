"""The one public ``fit``: it dispatches by instrument kind, honours every option the chosen fit can honour and
refuses the others with one ModelError naming them (never a silent drop)."""

import copy

import numpy as np
import pytest

from gyrojax import load_record
from gyrojax.data.records import Record
from gyrojax.errors import ModelError
from gyrojax.inference.identify import fit, fit_per_instrument
from gyrojax.inference.result import FitResult
from gyrojax.inference.triad_result import TriadFit
from gyrojax.montecarlo.triad import mems_truth
from gyrojax.noise.spec import NoiseSpec
from gyrojax.simulation.triad import simulate_ferraris

from .conftest import EXAMPLES

TRUTH = mems_truth(7)


@pytest.fixture(scope="module")
def triad():
    return simulate_ferraris(TRUTH, seed=5)


@pytest.fixture(scope="module")
def turntable(example_campaigns):
    return [load_record(EXAMPLES / f"{n}.json") for n in example_campaigns[1]["records"]]


def _GivenNoise():  # noqa: N802 — a known turntable noise model (refused for a triad before it is used)
    return NoiseSpec(white=0.5)


@pytest.mark.parametrize(
    "options, named",
    [
        ({"noise": "ar"}, "noise='ar'"),
        ({"noise": "white"}, "noise='white'"),
        ({"noise": _GivenNoise()}, "noise="),
        ({"theta0": np.zeros(24)}, "theta0"),
        ({"kind": "sdf"}, "kind='sdf'"),
    ],
)
def test_triad_refuses_what_it_cannot_honour(triad, options, named):
    with pytest.raises(ModelError, match="imu-triad records cannot honour") as e:
        fit(triad, **options)
    assert named in str(e.value)


def test_triad_refusal_names_every_refused_option_at_once(triad):
    with pytest.raises(ModelError) as e:
        fit(triad, noise="ar", theta0=[0.0], kind="sdf")
    msg = str(e.value)
    assert "noise='ar'" in msg and "theta0" in msg and "kind='sdf'" in msg


def test_triad_noise_is_honoured_as_channel_variances():
    """With the Earth rate off and exact angles every segment's covariance is diag(q)/n, so GLS with 4q leaves θ̂
    unchanged and doubles every σ (cov θ = (Jᵀ W J)⁻¹ with W ∝ 1/q)."""
    rec = simulate_ferraris(TRUTH, seed=6)
    q = np.array([4.0, 9.0, 16.0])
    one = fit(rec, earth_rate=False, noise=q)
    four = fit(rec, earth_rate=False, noise=4 * q)
    assert isinstance(one, TriadFit)
    assert np.array_equal(one.noise_q, q) and one.earth_mode == "off"
    assert np.allclose(four.theta, one.theta, rtol=1e-9, atol=1e-12)
    assert np.allclose(four.std, 2.0 * one.std, rtol=1e-9)


def test_triad_noise_must_be_three_positive_variances(triad):
    for bad in ([1.0, 2.0], [1.0, -2.0, 3.0], [1.0, np.nan, 3.0]):
        with pytest.raises(ModelError, match="long-run variance of each channel"):
            fit(triad, noise=bad)


def test_triad_allow_aliases_and_terms_are_honoured(triad):
    res = fit(triad, ["D_F", "D_I"], allow_aliases=True)
    assert res.model.terms == ("D_F", "D_I")
    assert set(res.names) == {f"{c}[{ch}]" for c in ("D_F", "D_I") for ch in "xyz"}


def test_turntable_refuses_earth_rate(turntable):
    with pytest.raises(ModelError, match="earth_rate applies to imu-triad records"):
        fit(turntable, earth_rate=False)


def test_turntable_noise_default_is_the_ar_fit(turntable):
    """``noise=None`` is the documented default, the GLS fit with the REML noise model (``noise="ar"``)."""
    by_default = fit(turntable, ["D_F", "D_I", "D_O", "D_S"])
    explicit = fit(turntable, ["D_F", "D_I", "D_O", "D_S"], noise="ar")
    white = fit(turntable, ["D_F", "D_I", "D_O", "D_S"], noise="white")
    assert isinstance(by_default, FitResult)
    assert np.array_equal(by_default.theta, explicit.theta) and np.array_equal(by_default.cov, explicit.cov)
    assert not np.array_equal(by_default.cov, white.cov)  # the option reaches the fit


def test_per_instrument_fits_go_through_the_facade(triad):
    """Two IMUs in one list: one triad fit each, never pooled (instrument.id decides)."""
    meta = copy.deepcopy(triad.meta)
    meta["instrument"]["id"] = "imu-2"
    fits = fit_per_instrument([triad, Record(meta, dict(triad.columns))])
    assert len(fits) == 2 and all(isinstance(f, TriadFit) for f in fits.values())
    assert all(f.record_names == [triad.name] for f in fits.values())
