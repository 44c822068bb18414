"""The built-in named effects (conventions §6), registered on import: the SDF gyro's ten-term drift model and
scale-factor terms (Hu 2-45, IEEE 517), the test-set errors (table tilt and azimuth, encoder harmonics; Hu ch. 5),
the TDF gyro's two channels (Hu 3-94), the pendulous accelerometer (Hu 3-38) and the optical gyros' terms (IEEE
952/647, Titterton ch. 5). The registry itself (:class:`Effect`, :func:`register`, :func:`get`, …) is
:mod:`gyrojax.physics.registry`, re-exported here.
"""

from __future__ import annotations

import jax.numpy as jnp

from gyrojax import units
from gyrojax.kinds import ACCEL, FOG, INSTRUMENT_KINDS, RLG, SDF, TDF
from gyrojax.physics import registry
from gyrojax.physics.registry import (
    Effect,
    coefficient_index,
    effect_of_coefficient,
    get,
    names,
    register,
)

__all__ = [
    "ACCEL",
    "FOG",
    "INSTRUMENT_KINDS",
    "RLG",
    "SDF",
    "TDF",
    "Effect",
    "coefficient_index",
    "effect_of_coefficient",
    "get",
    "names",
    "register",
    "TEMPERATURE_EFFECTS",
]


# --------------------------------------------------------------------------------------------------------------
# SDF gyro: the ten-term drift model (Hu 2-45 mathematical model; conventions §4) and the scale-factor terms.

_AXIS_WORDS = {"I": "input", "O": "output", "S": "spin"}


def _g_term(axis: str) -> Effect:
    key = f"a_{axis}"
    return Effect(
        name=f"D_{axis}",
        coefficients=(f"D_{axis}",),
        units=("deg/h/g",),
        kinds=(SDF,),
        contribution=lambda x, c: c[0] * x[key],
        description=f"mass unbalance: drift proportional to specific force along the {_AXIS_WORDS[axis]} axis",
        reference="Hu 2-12 to 2-20, 2-45; IEEE 517",
    )


def _g2_term(p: str, q: str) -> Effect:
    kp, kq = f"a_{p}", f"a_{q}"
    kind = "anisoelasticity" if p != q else "unequal compliance"
    return Effect(
        name=f"D_{p}{q}",
        coefficients=(f"D_{p}{q}",),
        units=("deg/h/g²",),
        kinds=(SDF,),
        contribution=lambda x, c: c[0] * x[kp] * x[kq],
        description=f"{kind}: drift proportional to a_{p}·a_{q}",
        reference="Hu 2-21 to 2-34, 2-45; IEEE 517",
    )


register(
    Effect(
        name="D_F",
        coefficients=("D_F",),
        units=("deg/h",),
        kinds=(SDF, FOG, RLG),
        contribution=lambda x, c: c[0] + 0.0 * x["a_I"],
        description="acceleration-insensitive drift (flex leads, pickoff and torquer reaction torques)",
        reference="Hu 2-6 to 2-11, 2-45",
    )
)
for _a in "IOS":
    register(_g_term(_a))
for _p, _q in (("I", "I"), ("O", "O"), ("S", "S"), ("I", "O"), ("I", "S"), ("O", "S")):
    register(_g2_term(_p, _q))

register(
    Effect(
        name="sf_error",
        coefficients=("E_SF",),
        units=("ppm",),
        kinds=(SDF, FOG, RLG),
        contribution=lambda x, c: c[0] * units.PPM * x["w_I"],
        description="torquer scale-factor error: indicated rate too large by E_SF·ω_I",
        reference="Hu 3-1 to 3-11, ch. 3 appendix 1; Titterton §8.5.2; IEEE 528 (scale factor)",
    )
)
register(
    Effect(
        name="sf_asymmetry",
        coefficients=("E_A",),
        units=("ppm",),
        kinds=(SDF, FOG, RLG),
        contribution=lambda x, c: c[0] * units.PPM * jnp.abs(x["w_I"]),
        description="scale-factor asymmetry: + and − torquer currents scale differently",
        reference="Hu ch. 3 appendix 1; Titterton §8.5.2; IEEE 528 (scale-factor asymmetry)",
        linear_in_rate=False,
    )
)
register(
    Effect(
        name="sf_quadratic",
        coefficients=("E_2",),
        units=("ppm/(deg/s)",),
        kinds=(SDF, FOG, RLG),
        contribution=lambda x, c: c[0] * units.PPM * x["w_I"] * (x["w_I"] / units.SECONDS_PER_HOUR),
        description="second-order scale-factor nonlinearity: E_2·ω_I·(ω_I in deg/s)",
        reference="Titterton §8.5.2 (rate transfer test); IEEE 528 (nonlinearity)",
        linear_in_rate=False,
    )
)
register(
    Effect(
        name="ia_misalignment",
        coefficients=("M_O", "M_S"),
        units=("arcsec", "arcsec"),
        kinds=(SDF, FOG, RLG),
        contribution=lambda x, c: units.ARCSEC * (c[0] * x["w_O"] + c[1] * x["w_S"]),
        description="input-axis misalignment: the IA leans toward OA by M_O and toward SA by M_S",
        reference="Titterton §8.5.2 (several mountings); IEEE 517 (input-axis misalignment)",
    )
)

# Time and temperature: for every gyro kind (the TDF applies them to both channels).
register(
    Effect(
        name="bias_trend",
        coefficients=("D_T",),
        units=("deg/h/h",),
        kinds=(SDF, TDF, FOG, RLG),
        contribution=lambda x, c: c[0] * x["t_h"],
        description="bias drifting linearly with time since the campaign clock's zero",
        reference="Hu 4-64 onwards (regression with trend); IEEE 528 (drift rate trend)",
    )
)
register(
    Effect(
        name="bias_temperature",
        coefficients=("D_TEMP",),
        units=("deg/h/°C",),
        kinds=(SDF, TDF, FOG, RLG),
        contribution=lambda x, c: c[0] * (x["temperature_C"] - 20.0),
        description="bias sensitivity to instrument temperature, referred to 20 °C",
        reference="seed 001 (temperature compensation); IEEE 528 (temperature sensitivity)",
    )
)

register(
    Effect(
        name="temperature_hinge",
        coefficients=("D_HINGE", "T_KNEE"),
        units=("deg/h/°C", "°C"),
        kinds=(SDF, TDF, FOG, RLG),
        contribution=lambda x, c: c[0] * jnp.abs(x["temperature_C"] - c[1]),
        description="two-slope temperature bias (a hinge): beside bias_temperature the slopes are D_TEMP + D_HINGE "
        "above the knee T_KNEE and D_TEMP − D_HINGE below it; aliases D_F and bias_temperature when the knee lies "
        "outside the recorded temperatures, and a temperature quadratic when they span little",
        reference="seed 001 §5.1 steps 1)–4) (l.73–81): k = e + K_tx1 τ hot, e + K_tx2 τ cold, τ = T − 20 °C, "
        "so D_TEMP = (K_tx1 + K_tx2)/2, D_HINGE = (K_tx1 − K_tx2)/2, T_KNEE = 20 °C; IEEE 528 (temperature "
        "sensitivity)",
        linear=False,
        knee="temperature_C",
    )
)
TEMPERATURE_EFFECTS = ("bias_temperature", "temperature_hinge")
"""The effects that read ``temperature_C``: a record without a varying temperature cannot carry them."""

# Setup (test-set) effects: applied to the kinematics by the measurement model.
register(
    Effect(
        name="table_tilt",
        coefficients=("delta_E", "delta_N"),
        units=("arcsec", "arcsec"),
        kinds=(SDF, TDF, ACCEL, FOG, RLG),
        contribution=None,
        description="table base tilted by the small rotation (δ_E, δ_N, 0): the Earth-rate and g projections move",
        reference="Hu ch. 5 (table axis tilt: Δω = (n ± 1) Ω sin δ); digest §3",
        setup=True,
        linear=False,
    )
)
register(
    Effect(
        name="table_azimuth",
        coefficients=("delta_U",),
        units=("arcsec",),
        kinds=(SDF, TDF, ACCEL, FOG, RLG),
        contribution=None,
        description="table base turned by δ_U about Up (azimuth set-up error)",
        reference="Hu ch. 5 (azimuth error of the table reference); digest §3",
        setup=True,
        linear=False,
    )
)
register(
    Effect(
        name="encoder_harmonic",
        coefficients=("c1", "s1", "c2", "s2"),
        units=("arcsec",) * 4,
        kinds=(SDF, TDF, ACCEL, FOG, RLG),
        contribution=None,
        description="angle readout error, once and twice per revolution, on the servo (or last) table axis",
        reference="Hu 5-51 (Inductosyn zero and electrical errors); digest §3",
        setup=True,
        linear=False,
    )
)

# --------------------------------------------------------------------------------------------------------------
# TDF gyro: a ten-term set per sensing channel (Hu 2-45/2-46 per channel, 3-95; conventions §4).

_TDF_TERMS = ("F", "X", "Y", "Z", "XX", "YY", "ZZ", "XY", "XZ", "YZ")


def _tdf_term(channel: str, term: str) -> Effect:
    if term == "F":
        f = lambda x, c: c[0] + 0.0 * x["a_X"]  # noqa: E731
        unit, what = "deg/h", "acceleration-insensitive drift"
    elif len(term) == 1:
        k = f"a_{term}"
        f = lambda x, c: c[0] * x[k]  # noqa: E731
        unit, what = "deg/h/g", f"drift proportional to a_{term}"
    else:
        k1, k2 = f"a_{term[0]}", f"a_{term[1]}"
        f = lambda x, c: c[0] * x[k1] * x[k2]  # noqa: E731
        unit, what = "deg/h/g²", f"drift proportional to a_{term[0]}·a_{term[1]}"
    return Effect(
        name=f"D{channel}_{term}",
        coefficients=(f"D{channel}_{term}",),
        units=(unit,),
        kinds=(TDF,),
        contribution=lambda x, c, _f=f, _ch=channel: _f(x, c) * x[f"channel_is_{_ch}"],
        description=f"TDF channel {channel}: {what}",
        reference="Hu 2-45/2-46 per channel, 3-22 to 3-37, 3-95",
    )


for _ch in "XY":
    for _t in _TDF_TERMS:
        register(_tdf_term(_ch, _t))

# --------------------------------------------------------------------------------------------------------------
# Pendulous accelerometer (Hu 3-38 in the conventions' axis names): S_nom·i = K_0 + K_1 a_I + K_2 a_I² + …

_ACCEL_TERMS = (
    ("K_0", "g", "bias", lambda x, c: c[0] + 0.0 * x["a_I"]),
    ("K_1", "g/g", "scale factor", lambda x, c: c[0] * x["a_I"]),
    ("K_2", "g/g²", "second-order nonlinearity", lambda x, c: c[0] * x["a_I"] ** 2),
    ("K_3", "g/g³", "third-order nonlinearity", lambda x, c: c[0] * x["a_I"] ** 3),
    ("K_IP", "g/g²", "cross-coupling a_I·a_P", lambda x, c: c[0] * x["a_I"] * x["a_P"]),
    ("K_IO", "g/g²", "cross-coupling a_I·a_O", lambda x, c: c[0] * x["a_I"] * x["a_O"]),
)
for _name, _unit, _what, _f in _ACCEL_TERMS:
    register(
        Effect(
            name=_name,
            coefficients=(_name,),
            units=(_unit,),
            kinds=(ACCEL,),
            contribution=_f,
            description=f"pendulous accelerometer {_what}",
            reference="Hu 3-38 to 3-46",
        )
    )


# ---- optical gyros (Titterton ch. 5) ------------------------------------------------------------------------


def lockin_output(rate, lock_rate):
    """Mean RLG output with lock-in: sign(Ω)√(Ω² − Ω_L²) above the lock-in rate, 0 inside it (Adler equation).

    Gradient-safe: the square root never sees a negative argument, and the derivative inside the band is 0.
    ``rate`` and ``lock_rate`` in any one rate unit (deg/h in the effect library); the output in the same units.
    """
    rate = jnp.asarray(rate, jnp.float64)
    d = rate**2 - jnp.asarray(lock_rate, jnp.float64) ** 2
    outside = d > 0
    return jnp.where(outside, jnp.sign(rate) * jnp.sqrt(jnp.where(outside, d, 1.0)), 0.0)


register(
    Effect(
        name="lock_in",
        coefficients=("Omega_L",),
        units=("deg/h",),
        kinds=(RLG,),
        contribution=lambda x, c: lockin_output(x["w_I"], c[0]) - x["w_I"],
        description="ring-laser lock-in: no output below Ω_L, sign(ω)√(ω² − Ω_L²) above (Adler equation)",
        reference="Titterton §5.1.3.4, Fig. 5.2; Aronowitz (Titterton ch. 5 ref. [6])",
        linear=False,
        linear_in_rate=False,
    )
)

registry.BUILTIN.update(names())  # everything registered so far is built in (cannot be unregistered)
