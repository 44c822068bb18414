"""The candidates of the triad diagnosis (:mod:`gyrojax.inference.triad_diagnose`): regressors R(ω, a, t, T) added
to one channel's indicated rate (deg/h per coefficient unit) — the named effects of the registry through the
channel's SDF inputs (Hu 2-45; conventions §6), the MEMS candidates of conventions §9.3 and the model-free shapes."""

from __future__ import annotations

from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.errors import ModelError
from gyrojax.physics import effects as fx
from gyrojax.physics import triad as tp

MEMS_CANDIDATES = ("bias_turn_on", "time_offset")
"""Triad candidates beyond the registry (conventions §9): a bias step at each turn-on (one level per record after
the first, per channel, deg/h) and a time offset between the gyro and accelerometer streams (one for the triad, s)."""

SHAPES = ("rate_cross", "rate_magnitude", "motion_bias", "time_quadratic")
"""Model-free residual shapes per channel: ω_I ω_O, ω_I ω_S, ω_O ω_S ((deg/s)²); |ω| (deg/s); a bias present only
while the body moves (the residual against a move's duration); t² (h²)."""
SHAPE_LINES = {
    "rate_cross": "products of body rates about two axes (ω_I ω_O, ω_I ω_S, ω_O ω_S), deg/h per (deg/s)²",
    "rate_magnitude": "the body rate's magnitude |ω| (peak rate of a move), deg/h per deg/s",
    "motion_bias": "a bias present only while the body moves (∝ a move's duration), deg/h",
    "time_quadratic": "a quadratic drift in time, deg/h/h²",
}


@dataclass
class Regressor:
    """One candidate or shape on one channel (``channel`` None: on all three at once, as ``time_offset``)."""

    name: str
    effect: str
    channel: int | None
    coefficients: tuple
    units: tuple
    func: object  # (inputs dict of one channel or of the triad) -> (n, k) deg/h per coefficient unit


def _named(name: str, c: int) -> Regressor:
    eff = fx.get(name)

    def func(x, eff=eff):
        k = len(eff.coefficients)
        return np.column_stack(
            [np.asarray(eff.contribution(x, jnp.eye(k)[i])) * np.ones(len(x["t_h"])) for i in range(k)]
        )

    return Regressor(f"{name}[{tp.CHANNELS[c]}]", name, c, eff.coefficients, eff.units, func)


def _shape(name: str, c: int) -> Regressor:
    def func(x, name=name):
        dps = 1.0 / units.SECONDS_PER_HOUR
        wi, wo, ws = (np.asarray(x[k]) * dps for k in ("w_I", "w_O", "w_S"))
        if name == "rate_cross":
            return np.column_stack([wi * wo, wi * ws, wo * ws])
        if name == "rate_magnitude":
            return np.sqrt(wi**2 + wo**2 + ws**2)[:, None]
        if name == "motion_bias":
            return np.asarray(x["moving"], dtype=float)[:, None]
        return ((np.asarray(x["t_h"]) - x["t_mid"]) ** 2 * np.ones(len(wi)))[:, None]

    n_coef = 3 if name == "rate_cross" else 1
    unit = {"rate_cross": "deg/h/(deg/s)^2", "rate_magnitude": "deg/h/(deg/s)", "motion_bias": "deg/h"}
    return Regressor(
        f"{name}[{tp.CHANNELS[c]}]", name, c, (name,) * n_coef, (unit.get(name, "deg/h/h^2"),) * n_coef, func
    )


def candidate_regressors(model, data, candidates=None) -> list:
    """The named and MEMS candidates of every channel absent from ``model`` that the session can carry."""
    names = candidates
    if names is None:
        temp = np.concatenate([x["temperature_C"] for x in data["inputs"]])
        names = [
            n
            for n in fx.names(fx.SDF)
            if n not in model.terms and n not in tp.TURNTABLE_ONLY and (n != "bias_temperature" or np.ptp(temp) > 1e-6)
        ]
        names += [n for n in MEMS_CANDIDATES if n != "bias_turn_on" or data["n_records"] > 1]
    out = []
    for n in names:
        if n == "bias_turn_on":
            k = data["n_records"] - 1
            if k < 1:
                raise ModelError("bias_turn_on needs records of two or more turn-ons")
            for c in range(3):
                out.append(
                    Regressor(
                        f"bias_turn_on[{tp.CHANNELS[c]}]",
                        n,
                        c,
                        tuple(f"D_F_step_{i + 1}" for i in range(k)),
                        ("deg/h",) * k,
                        lambda x, k=k: np.eye(k + 1)[np.asarray(x["record"], dtype=int)][:, 1:],
                    )
                )
        elif n == "time_offset":
            out.append(Regressor("time_offset", n, None, ("dt_acc",), ("s",), lambda x: x["g_dot"][..., None]))
        elif n in fx.names(fx.SDF) and n not in tp.TURNTABLE_ONLY:
            out.extend(_named(n, c) for c in range(3))
        else:
            raise ModelError(f"unknown triad candidate {n!r} (registry effects, {', '.join(MEMS_CANDIDATES)})")
    return out


def shape_regressors() -> list:
    """The model-free shapes of every channel (:data:`SHAPES`)."""
    return [_shape(s, c) for s in SHAPES for c in range(3)]
