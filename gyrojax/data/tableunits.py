"""The units of a turntable data system's columns and the nominal scale of its output: the tables of the units each
column may take, their factors to the record's units (conventions §1, §5), and a nominal scale written as a data sheet
writes it (``0.02 V/(deg/s)``, ``17.171 deg/h/mA``, ``1 arcsec/pulse``, ``1000 mA/g``) in the record's units per base
unit of the output. Used by the set-up (:mod:`gyrojax.data.tablesetup`) and the import (:mod:`gyrojax.data.tablelog`).
"""

from __future__ import annotations

import math

import numpy as np

from gyrojax import units
from gyrojax.errors import RecordError
from gyrojax.kinds import ACCEL


def _err(where: str, msg: str) -> RecordError:
    return RecordError(f"{where}: {msg}")


TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9, "iso": None}
ANGLE_UNITS = {"deg": 1.0, "rad": 180.0 / math.pi, "arcsec": 1.0 / 3600.0, "counts": None}
RATE_UNITS = {"deg/s": 1.0, "rad/s": 180.0 / math.pi, "deg/h": 1.0 / 3600.0, "rpm": 6.0}
TEMPERATURE_UNITS = ("C", "K", "F")
OUTPUT_UNITS = {
    # unit: (quantity, factor to the quantity's base unit, base unit)
    "mA": ("current", 1.0, "mA"),
    "A": ("current", 1e3, "mA"),
    "uA": ("current", 1e-3, "mA"),
    "V": ("voltage", 1.0, "V"),
    "mV": ("voltage", 1e-3, "V"),
    "pulses": ("pulses", 1.0, "pulse/s"),
    "deg/h": ("rate", 1.0, "deg/h"),
    "deg/s": ("rate", 3600.0, "deg/h"),
    "rad/s": ("rate", 3600.0 * 180.0 / math.pi, "deg/h"),
    "g": ("acceleration", 1.0, "g"),
    "m/s^2": ("acceleration", 1.0 / units.G0, "g"),
}
"""The output units, by the quantity they measure and the factor to its base unit (the unit the record keeps)."""
INPUT_UNITS = {
    # what a nominal scale relates the output to: rates (to deg/h), accelerations (to g), angles per pulse (arcsec),
    # velocities per pulse (m/s, an accelerometer's)
    "deg/h": ("rate", 1.0),
    "deg/s": ("rate", 3600.0),
    "rad/s": ("rate", 3600.0 * 180.0 / math.pi),
    "g": ("acceleration", 1.0),
    "m/s^2": ("acceleration", 1.0 / units.G0),
    "arcsec": ("angle", 1.0),
    "deg": ("angle", 3600.0),
    "rad": ("angle", 3600.0 * 180.0 / math.pi),
    "urad": ("angle", 3600.0 * 180.0 / math.pi * 1e-6),
    "m/s": ("velocity", 1.0 / units.G0),
}


def split_scale_unit(unit: str) -> tuple[str, str]:
    """(numerator, denominator) of a scale unit: ``V/(deg/s)``, ``deg/h/mA``, ``arcsec/pulse``, ``mA/g``."""
    u = unit.replace(" ", "").replace("per", "/")
    if "/(" in u and u.endswith(")"):
        num, den = u.split("/(", 1)
        return num, den[:-1]
    for inp in sorted(INPUT_UNITS, key=len, reverse=True):  # longest first: deg/h before deg
        if u.startswith(inp + "/"):
            return inp, u[len(inp) + 1 :]
    if u.count("/") == 1:
        num, den = u.split("/")
        return num, den
    return u, ""


def scale_in_base(scale: tuple[float, str], output_unit: str, kind: str, where: str) -> float:
    """The nominal scale in the record's units: deg/h (gyros) or g (accelerometers) per base unit of the output
    (mA, V, pulse/s; :data:`OUTPUT_UNITS`). A pulse weight (angle or velocity per pulse) gives the rate per pulse/s:
    1 arcsec per pulse at 1 pulse/s is 1 deg/h."""
    value, unit = scale
    quantity, factor, base = OUTPUT_UNITS[output_unit]
    num, den = split_scale_unit(unit)
    want = "acceleration" if kind == ACCEL else "rate"
    if quantity == "pulses":
        want = "velocity" if kind == ACCEL else "angle"
        den = "pulses" if den in ("pulse", "pulses", "count", "counts") else den
    inverse = False
    if num in INPUT_UNITS and den in OUTPUT_UNITS:
        inp, out = num, den
    elif den in INPUT_UNITS and num in OUTPUT_UNITS:
        inp, out, inverse = den, num, True
    else:
        raise _err(
            where,
            f"unit {unit!r} is not a scale of a {kind} with output in {output_unit}: write it as "
            + ("'arcsec/pulse' (a pulse weight)" if quantity == "pulses" else f"'deg/h/{base}' or '{base}/(deg/s)'")
            + f" (inputs: {', '.join(INPUT_UNITS)}; outputs: {', '.join(OUTPUT_UNITS)})",
        )
    iq, ifac = INPUT_UNITS[inp]
    oq, ofac, _ = OUTPUT_UNITS[out]
    if iq != want or oq != quantity:
        raise _err(
            where,
            f"unit {unit!r} relates {iq} to {oq}; a {kind} whose output is in {output_unit} needs {want} per "
            f"{quantity}",
        )
    # value inp per out (or out per inp, inverted): the record's input units (deg/h, g) per base output unit
    return (value if not inverse else 1.0 / value) * ifac / ofac


def somigliana_gravity(latitude_deg: float) -> float:
    """WGS-84 normal gravity at the latitude, height 0, m/s² (Somigliana; NIMA TR8350.2 eq. 4-1)."""
    s2 = math.sin(math.radians(latitude_deg)) ** 2
    return units.WGS84_GAMMA_E * (1.0 + units.WGS84_K * s2) / math.sqrt(1.0 - units.WGS84_E2 * s2)


def to_celsius(x: np.ndarray, unit: str) -> np.ndarray:
    """Temperatures in ``unit`` (C, K, F) as °C."""
    if unit == "K":
        return x - 273.15
    if unit == "F":
        return (x - 32.0) * 5.0 / 9.0
    return x
