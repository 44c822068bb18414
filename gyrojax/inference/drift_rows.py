"""A drift term's shape in a record's measurement rows (the regressors of :mod:`gyrojax.inference.adequacy`).

On a rebalance record a drift term is its own regressor. On a servo record the measurement is the table rate that
nulls the pickoff (Hu 3-59), so a drift δ shows as the change it makes to that rate, −δ/(∂ω_ind/∂θ̇_s), averaged over
each sample interval; the inputs are those at the table rate the fitted model predicts, never the recorded rate, whose
noise is the measurement's.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model, indicated_output, instrument_inputs, servo_rate, setup_values, true_angles


def servo_state(data, result):
    """Servo record: the inputs at the model's predicted table rate, and the gain of each sample's drift on the
    measured rate (deg/h of measured rate per deg/h of drift).

    In servo mode the table rate is the measurement, so inputs built from the recorded rate (ω_I, the table rate)
    share its noise and are not exogenous. The table rate that nulls the pickoff under the fitted model
    (:func:`gyrojax.physics.model.servo_rate`, Hu 3-59) is. A drift δ added to the indicated output moves that rate
    by −δ / (∂ω_ind/∂θ̇_s): the shape a drift term leaves in the measurement, sign and all (a south mounting, IA
    against the servo axis, turns the other way for the same drift).
    """
    model = result.model if result is not None else Model((), data.kind)
    theta = jnp.asarray(result.theta if result is not None else np.zeros(0), dtype=jnp.float64)
    setup = setup_values(model, theta)
    r, angles = servo_rate(model, theta, data, setup)
    _, rates = true_angles(data, setup)
    s = data.servo_axis

    def ind(rr):
        x = instrument_inputs(data, setup, angles, rates.at[:, s].set(rr))
        return indicated_output(model, theta, x, data.kind)

    _, d_ind = jax.jvp(ind, (r,), (jnp.ones_like(r),))  # deg/h of indicated output per rad/s of table rate
    gain = -1.0 / (np.asarray(d_ind) * units.DEG_PER_H)
    x = instrument_inputs(data, setup, angles, rates.at[:, s].set(r))
    table_rates = np.asarray(rates).copy()
    table_rates[:, s] = np.asarray(r)
    return {k: np.asarray(v) for k, v in x.items()}, gain, np.rad2deg(table_rates) * 3600.0


def rows_of(data, ok, gain=None):
    """Per-sample values -> the measurement rows of a record kept by ``ok``: servo, the interval mean (trapezoid, as
    the model integrates the balance equation) of the value times the drift's ``gain`` (deg/h of measured rate per
    deg/h of drift, :func:`servo_state`); TDF, the two channels stacked; rebalance, the samples. The rows keep the
    values' own unit."""

    def rows(a):
        a = np.asarray(a, dtype=float)
        if data.mode == "servo":
            a = a * (gain if a.ndim == 1 else gain[:, None])
            return (0.5 * (a[1:] + a[:-1]))[ok]
        if data.kind == fx.TDF:
            return np.concatenate([a, a])[ok]
        return a[ok]

    return rows
