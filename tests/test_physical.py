"""The physical model (Hu 2-12 to 2-27) against Hu 2-24 transcribed, and the map to conventions §6 coefficients."""

import numpy as np
import pytest

from gyrojax import units
from gyrojax.physics import effects as fx
from gyrojax.seeds.physical import G0_CGS, PhysicalSDF, drift_coefficients, physical_from_drift

RNG = np.random.default_rng(0)


def _gyro(symmetric=False):
    q = RNG.normal(size=(3, 3)) * 1e-9
    if symmetric:
        q = 0.5 * (q + q.T)
    return PhysicalSDF(H=2.0e5, m=50.0, l=tuple(RNG.normal(size=3) * 1e-6), q=tuple(map(tuple, q)), M_F0=0.3)


def hu_2_24(p: PhysicalSDF, sf):
    """Hu 2-24 as printed: torque about the output axis y; x = input, z = spin; SF toward the ground (dyn·cm)."""
    (kxx, kxy, kxz), (_kyx, _kyy, _kyz), (kzx, kzy, kzz) = p.q
    lx, _ly, lz = p.l
    sx, sy, sz = sf
    m = p.m
    return (
        p.M_F0
        - m * lx * sz
        + m * lz * sx
        + m**2 * kzy * sx * sy
        - m**2 * kxy * sy * sz
        + m**2 * (kzz - kxx) * sx * sz
        + m**2 * kzx * sx**2
        - m**2 * kxz * sz**2
    )


def test_vector_form_matches_hu_2_24():
    p = _gyro()
    for a in RNG.normal(size=(20, 3)):
        assert p.torque(a)[1] == pytest.approx(hu_2_24(p, -G0_CGS * a), rel=1e-12, abs=1e-18)


def test_coefficients_reproduce_the_physical_drift():
    """Σ D·(inputs) with the conventions §6 effects equals −M_O/H from the vector torques, at random specific forces."""
    p = _gyro()
    d = drift_coefficients(p)
    for a in RNG.normal(size=(20, 3)):
        x = {"a_I": a[0], "a_O": a[1], "a_S": a[2]}
        total = sum(float(fx.get(n).contribution(x, np.array([v]))) for n, v in d.items())
        assert total == pytest.approx(float(p.drift(a)), rel=1e-10)


def test_no_physical_output_axis_terms_and_symmetric_compliance():
    """D_O and D_OO have no physical cause (torque about OA from SF_O alone vanishes); a symmetric compliance
    tensor gives D_II = −D_SS."""
    p = _gyro(symmetric=True)
    d = drift_coefficients(p)
    assert "D_O" not in d and "D_OO" not in d
    assert p.drift(np.array([0.0, 1.0, 0.0])) == pytest.approx(d["D_F"], rel=1e-12)
    assert d["D_II"] == pytest.approx(-d["D_SS"], rel=1e-12)


def test_round_trip_and_magnitudes():
    d = {"D_F": 0.4, "D_I": 0.6, "D_S": -0.3, "D_II": 0.02, "D_SS": -0.01, "D_IS": 0.05, "D_IO": 0.003, "D_OS": -0.004}
    p = physical_from_drift(d, H=2.0e5, m=50.0)
    back = drift_coefficients(p)
    for k, v in d.items():
        assert back[k] == pytest.approx(v, rel=1e-12)
    # 0.6 deg/h/g with H = 2e5 g·cm²/s and m = 50 g is a centre-of-mass offset of about a tenth of a micrometre
    assert p.l[2] == pytest.approx(0.6 * units.DEG_PER_H * 2.0e5 / (50.0 * G0_CGS))
    assert 1e-6 < abs(p.l[2]) < 1e-4
    with pytest.raises(ValueError, match="D_O"):
        physical_from_drift({"D_O": 0.1}, H=2.0e5, m=50.0)
