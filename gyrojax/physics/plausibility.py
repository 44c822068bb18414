"""Plausible sizes of the named effects: what real instruments and test sets have (overridable).

The diagnosis compares the size a candidate would need to explain a residual with these limits: a best candidate
that needs an encoder error of 4,000″ (Inductosyn and optical encoders of rate tables err by a few arcseconds)
explains structure the library has no name for, and is flagged instead of proposed (:mod:`gyrojax.inference.adequacy`).

Limits are generous upper bounds on |coefficient| in report units — about ten times the worst values of the
instruments and tables the seeds describe — so that only the physically absurd is flagged:

* floated SDF rate-integrating gyros (Hu ch. 2, 2-45; IEEE 517): acceleration-insensitive drift up to ~10 deg/h,
  mass unbalance up to ~10 deg/h/g, anisoelasticity up to ~1 deg/h/g²;
* torquer scale factor (Hu ch. 3; IEEE 528, Titterton §8.5.2): error up to ~1 %, asymmetry ~0.1 %, mounting
  misalignment of the input axis a few arcminutes;
* rate and position tables: base levelled and surveyed to arcseconds or tens of arcseconds; angle readout
  (Inductosyn, Hu 5-51) errors of arcseconds;
* pendulous accelerometers (Hu 3-38): bias ~10 mg, nonlinearity ~10⁻³ g/g².

Override per coefficient (or per effect, applied to each of its coefficients) with ``diagnose(...,
plausible={"encoder_harmonic": 300.0})``; expression effects take ``max`` from their effects file
(:data:`gyrojax.physics.expression.PLAUSIBLE_MAX`), and have no limit otherwise.
"""

from __future__ import annotations

from gyrojax.physics import effects as fx

PLAUSIBLE_MAX = {
    # SDF / optical gyro drift terms (deg/h, deg/h/g, deg/h/g²)
    "D_F": 100.0,
    "D_I": 100.0,
    "D_O": 100.0,
    "D_S": 100.0,
    "D_II": 10.0,
    "D_OO": 10.0,
    "D_SS": 10.0,
    "D_IO": 10.0,
    "D_IS": 10.0,
    "D_OS": 10.0,
    # scale factor (ppm, ppm/(deg/s)) and input-axis misalignment (arcsec)
    "E_SF": 1e5,
    "E_A": 1e4,
    "E_2": 1e3,
    "M_O": 3600.0,
    "M_S": 3600.0,
    # time and temperature (deg/h/h, deg/h/°C)
    "D_T": 10.0,
    "D_TEMP": 10.0,
    "D_HINGE": 10.0,  # half the change of slope at the knee: a temperature sensitivity
    "T_KNEE": 150.0,  # °C: a knee inside the operating range of inertial instruments (−55 … 125 °C)
    # test set (arcsec): base tilt, azimuth set-up, angle readout harmonics
    "delta_E": 600.0,
    "delta_N": 600.0,
    "delta_U": 1800.0,
    "c1": 60.0,
    "s1": 60.0,
    "c2": 60.0,
    "s2": 60.0,
    # pendulous accelerometer (g, g/g, g/g², g/g³)
    "K_0": 0.1,
    "K_1": 2.0,
    "K_2": 0.01,
    "K_3": 0.01,
    "K_IP": 0.01,
    "K_IO": 0.01,
}
"""Plausible |coefficient| (report units) by coefficient name; TDF terms follow their SDF counterparts."""

MEMS_PLAUSIBLE_MAX = {
    # MEMS gyro triads (consumer to tactical; IEEE 1431-like datasheets): turn-on bias up to a few deg/s, g-sensitivity
    # up to ~0.1 deg/s/g, scale factor within ~10 %, axes misaligned by up to a degree or two, bias drift over a hand
    # session of deg/h per minute, temperature sensitivity ~0.05 deg/s/°C; about ten times those values
    "D_F": 1e5,
    "D_I": 1e4,
    "D_O": 1e4,
    "D_S": 1e4,
    "D_II": 1e3,
    "D_OO": 1e3,
    "D_SS": 1e3,
    "D_IO": 1e3,
    "D_IS": 1e3,
    "D_OS": 1e3,
    "E_SF": 2e5,
    "E_A": 2e4,
    "E_2": 100.0,
    "M_O": 36000.0,
    "M_S": 36000.0,
    "D_T": 1e5,
    "D_TEMP": 2e3,
    "D_HINGE": 2e3,
    "T_KNEE": 150.0,
    "D_F_step": 1e5,
    "dt_acc": 0.1,
}
"""Plausible |coefficient| of the ``imu-triad`` kind (report units: deg/h, deg/h/g, ppm, arcsec, deg/h/h, s)."""
KIND_LIMITS = {"imu-triad": MEMS_PLAUSIBLE_MAX}


def limit(coefficient: str, overrides: dict | None = None, kind: str | None = None) -> float | None:
    """Plausible |value| of ``coefficient`` in its report unit (None: no limit is known); ``kind`` ``"imu-triad"``
    takes the MEMS limits (:data:`MEMS_PLAUSIBLE_MAX`; ``D_F_step_<k>`` as ``D_F_step``)."""
    from gyrojax.physics import expression

    overrides = overrides or {}
    effect = fx.effect_of_coefficient(coefficient) if coefficient in fx.coefficient_index() else None
    for key in (coefficient, effect):
        if key is not None and key in overrides:
            return float(overrides[key])
    table = KIND_LIMITS.get(kind, PLAUSIBLE_MAX)
    base = coefficient.rsplit("_", 1)[0] if coefficient.startswith("D_F_step_") else coefficient
    if base in table:
        return table[base]
    if effect in expression.PLAUSIBLE_MAX:
        return expression.PLAUSIBLE_MAX[effect]
    if coefficient.startswith(("DX_", "DY_")):  # TDF: as the SDF term of the same order
        term = coefficient.split("_", 1)[1]
        return 100.0 if len(term) == 1 else 10.0
    return None


def implausible(estimate: dict, overrides: dict | None = None, kind: str | None = None) -> str | None:
    """A sentence naming the coefficients of ``estimate`` (name -> {"value", "unit"}) beyond their plausible size,
    or None when all are plausible (or have no known limit); ``kind`` as in :func:`limit`."""
    bad = []
    for name, e in estimate.items():
        lim = limit(name, overrides, kind)
        v = e.get("value") if isinstance(e, dict) else e
        if lim is not None and v is not None and abs(v) > lim:
            unit = e.get("unit", "") if isinstance(e, dict) else ""
            bad.append(f"{name} = {v:.4g} {unit} (real instruments and test sets: |{name}| ≤ {lim:g} {unit})")
    return "; ".join(bad) if bad else None
