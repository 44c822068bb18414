"""A three-axis gyro triad (MEMS IMU) as three SDF-like rate gyros, one per body axis (docs/conventions.md, triad).

Channel c ∈ {x, y, z} senses the body axis e_c: its input axis IA = e_c, and its output and spin axes follow
cyclically, so that IA × OA = SA as for an SDF gyro (conventions §4):

    x: (IA, OA, SA) = (x, y, z)      y: (y, z, x)      z: (z, x, y)

Each channel obeys the SDF balance equation with its own coefficients (Hu 2-45; conventions §4, §6),

    ω_ind,c = ω_I + E_SF ω_I + M_O ω_O + M_S ω_S + D_F + D_I a_I + D_O a_O + D_S a_S + …   (deg/h; a in g)

evaluated by the same :func:`gyrojax.physics.model.indicated_output` and the same named effects as an SDF gyro, so
every effect that needs no turntable applies (bias, g- and g²-sensitivity, scale factor and its asymmetry and
nonlinearity, IA misalignment, trend, temperature). Stacked over the channels the linear part is the familiar
matrix form of IMU calibration (imucal, Kalibr, imu_tk):

    ω_ind = S ω + G a + b,   S = I + [E_SF on the diagonal, M_O and M_S off it],  G (deg/h/g),  b (deg/h)

with row c of S holding 1 + E_SF at column c, M_O (rad) at column OA(c) and M_S at column SA(c), and G likewise
D_I, D_O, D_S. :func:`matrices` and the imucal / Kalibr forms below convert between the two.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.errors import ModelError
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model, indicated_output

CHANNELS = ("x", "y", "z")
FRAMES = ((0, 1, 2), (1, 2, 0), (2, 0, 1))
"""Body-axis indices of (IA, OA, SA) for channels x, y, z."""
TURNTABLE_ONLY = ("table_tilt", "table_azimuth", "encoder_harmonic")


def channel_name(coefficient: str, channel: str) -> str:
    """``D_F`` and ``x`` → ``D_F[x]``: the per-channel coefficient name of the triad JSON."""
    return f"{coefficient}[{channel}]"


def split_channel_name(name: str) -> tuple[str, str]:
    """``D_F[x]`` → (``D_F``, ``x``); :class:`ModelError` for a name without a channel."""
    if name.endswith("]") and "[" in name:
        base, ch = name[:-1].split("[", 1)
        if ch in CHANNELS:
            return base, ch
    raise ModelError(f"{name!r} is not a per-channel coefficient name such as 'D_F[x]'")


def channel_model(terms) -> Model:
    """The SDF model of one channel; refuses effects that need a turntable (there is none)."""
    model = Model.of(terms, fx.SDF)
    bad = [t for t in model.terms if t in TURNTABLE_ONLY]
    if bad:
        raise ModelError(f"effects {bad} describe a turntable; a hand-moved IMU triad has none")
    return model


def channel_inputs(w_body, a_body, t_h, temperature_C, c: int) -> dict:
    """SDF inputs of channel ``c`` from body-frame rates ``w_body`` (n, 3) deg/h and specific force ``a_body``
    (n, 3) g: w_I, w_O, w_S, a_I, a_O, a_S by the cyclic frames (module doc); t_h in h, temperature in °C."""
    i, o, s = FRAMES[c]
    return {
        "w_I": w_body[:, i],
        "w_O": w_body[:, o],
        "w_S": w_body[:, s],
        "a_I": a_body[:, i],
        "a_O": a_body[:, o],
        "a_S": a_body[:, s],
        "t_h": t_h,
        "temperature_C": temperature_C,
    }


def triad_output(model: Model, theta, w_body, a_body, t_h, temperature_C):
    """Indicated rates (n, 3) deg/h of the three channels; ``theta`` (3, p) holds each channel's coefficients in
    report units (rows x, y, z), ``w_body`` (n, 3) deg/h, ``a_body`` (n, 3) g, ``t_h`` (n,) h, temperature (n,) °C."""
    outs = [
        indicated_output(model, theta[c], channel_inputs(w_body, a_body, t_h, temperature_C, c), fx.SDF)
        for c in range(3)
    ]
    return jnp.stack(outs, axis=1)


# ---- matrix forms ----------------------------------------------------------------------------------------------


def matrices(values: dict) -> dict:
    """Bias b (deg/h), scale-and-misalignment S (dimensionless) and g-sensitivity G (deg/h/g) of ω_ind = S ω + G a + b
    (module doc) from per-channel coefficients ``{"D_F[x]": …, "E_SF[y]": … (ppm), "M_O[z]": … (arcsec)}``.

    Absent coefficients are zero. Returns numpy arrays under ``b``, ``S``, ``G``."""
    b, s, g = np.zeros(3), np.eye(3), np.zeros((3, 3))
    for c, ch in enumerate(CHANNELS):
        i, o, sa = FRAMES[c]

        def v(name, _ch=ch):
            return float(values.get(channel_name(name, _ch), 0.0))

        b[c] = v("D_F")
        s[c, i] += v("E_SF") * units.PPM
        s[c, o] += v("M_O") * units.ARCSEC
        s[c, sa] += v("M_S") * units.ARCSEC
        g[c, i], g[c, o], g[c, sa] = v("D_I"), v("D_O"), v("D_S")
    return {"b": b, "S": s, "G": g}


def imucal_form(m: dict, counts_per_dps: float = 1.0, rotation_sign: float = 1.0, grav_mps2: float = 9.81) -> dict:
    """The gyro part of imucal's Ferraris calibration, ``raw = K_g R_g ω + K_ga a + b_g`` (ω in deg/s, a in m/s²,
    raw in counts; K_g diagonal, rows of R_g unit vectors), from :func:`matrices`.

    ``counts_per_dps``: the nominal scale the indicated rates were divided by (1 for records in deg/s).
    ``rotation_sign``: imucal's ``expected_angle`` sign (−1 for its default −360°, taken as clockwise): its R_g
    then carries the sign of the rotation convention. ``grav_mps2``: imucal's ``grav`` (its 1 g).
    """
    k = counts_per_dps
    kr = rotation_sign * k * m["S"]
    kg = np.sqrt((kr * kr).sum(axis=1))
    return {
        "K_g": np.diag(kg),
        "R_g": kr / kg[:, None],
        "b_g": k * m["b"] / units.SECONDS_PER_HOUR,
        "K_ga": k * m["G"] / units.SECONDS_PER_HOUR / grav_mps2,
        "gyr_unit": "deg/s",
        "acc_unit": "m/s^2",
    }


def kalibr_form(m: dict) -> dict:
    """Kalibr's ``scale-misalignment`` gyro intrinsics, ``ω_m = C_gyro_i · M · ω + A · a + b`` (rad/s, a in m/s²):
    S = C·M by a QR decomposition (C a rotation, M upper triangular with a positive diagonal), A = G in rad/s per
    m/s², b in rad/s. The full S is returned too, for tools that take it directly."""
    q, r = np.linalg.qr(m["S"])
    d = np.sign(np.diag(r))
    d[d == 0] = 1.0
    q, r = q * d, (r.T * d).T
    if np.linalg.det(q) < 0:  # keep C a proper rotation (a reflection would mean a left-handed triad)
        raise ModelError("the fitted scale-and-misalignment matrix has a negative determinant (left-handed axes?)")
    return {
        "C_gyro_i": q,
        "M": r,
        "A": m["G"] * units.DEG_PER_H / units.G0,
        "b": m["b"] * units.DEG_PER_H,
        "S": m["S"],
        "units": {"M": "-", "A": "rad/s per m/s^2", "b": "rad/s"},
    }
