"""A record as arrays: :func:`record_data` turns a :class:`~gyrojax.data.record.Record` (file units) into the
:class:`~gyrojax.physics.model.RecordData` that the measurement model takes (SI inside, the measurement vector of
conventions §4: the indicated output in rebalance mode, the servo-axis rate per interval in servo mode).
"""

from __future__ import annotations

import jax
import numpy as np

from gyrojax import units
from gyrojax.data.record import Record
from gyrojax.kinds import TDF
from gyrojax.physics.model import RecordData


def on_device(x) -> jax.Array:
    """``x`` as a float64 device array, by ``jax.device_put``: ``jnp.asarray`` of a numpy array compiles a staging
    function for every new shape, eight of them for each record of a shape not seen before."""
    return jax.device_put(np.asarray(x, dtype=np.float64))


def record_data(record: Record) -> RecordData:
    """Arrays of a record, converted to SI, with its measurement vector (module doc)."""
    angles = np.deg2rad(record.angles_deg)
    rates = np.deg2rad(record.rates_dps)
    t = np.asarray(record.time_s, dtype=float)
    temp = record.temperature_C
    temp = np.full(record.n, 20.0) if temp is None else np.asarray(temp, dtype=float)
    dt = np.diff(t)
    if record.mode == "servo":
        s = record.servo_axis_index
        seg = record.segment_id
        same = np.diff(seg) == 0
        y = np.where(same, np.diff(angles[:, s]) / np.where(dt > 0, dt, 1.0), 0.0) / units.DEG_PER_H
        weight = same.astype(float)
        command = record.indicated
    else:
        ind = record.indicated
        y = ind.T.reshape(-1) if record.kind == TDF else ind
        weight = np.ones_like(y)
        command = np.zeros(record.n)
    return RecordData(
        axes=on_device(record.axes_enu),
        triad=on_device(record.triad),
        latitude=on_device(np.deg2rad(record.latitude_deg)),
        gravity=on_device(record.gravity_mps2),
        time_s=on_device(t),
        angles=on_device(angles),
        rates=on_device(rates),
        temperature=on_device(temp),
        y=on_device(y),
        weight=on_device(weight),
        command=on_device(command),
        dt=on_device(dt),
        kind=record.kind,
        mode=record.mode,
        servo_axis=record.servo_axis_index,
        encoder_axis=record.encoder_axis_index,
        rates_derived=bool(record.rates_derived),
    )
