"""The records of one fit as arrays: the campaign, its measurement labels and times, the instrument and input checks,
and the linearisation of the measurement model about θ (``jax.jacfwd``)."""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from gyrojax.data.arrays import record_data
from gyrojax.data.record import Record
from gyrojax.data.triad import TRIAD_KIND
from gyrojax.errors import ModelError, RecordError
from gyrojax.physics import effects as fx
from gyrojax.physics.kept_model import kept_predict, kept_predict_and_jacobian
from gyrojax.physics.model import Model, RecordData, check_servo


def measurement_labels(record: Record, data: RecordData) -> np.ndarray:
    """Continuous-segment label of every measurement (−1: not a measurement, e.g. a servo interval across a gap)."""
    seg = record.segment_id
    if data.mode == "servo":
        lab = seg[:-1].copy()
        lab[np.asarray(data.weight) == 0] = -1
        return lab
    if data.kind == fx.TDF:
        return np.concatenate([seg, seg + seg.max() + 1])
    return seg.copy()


def measurement_times(record: Record, data: RecordData) -> np.ndarray:
    """Time (s) of every measurement: the sample time; a servo interval's midpoint; TDF channels one after the other."""
    t = np.asarray(record.time_s, dtype=float)
    if data.mode == "servo":
        return 0.5 * (t[1:] + t[:-1])
    if data.kind == fx.TDF:
        return np.concatenate([t, t])
    return t


def _check_finite(record: Record) -> None:
    """Records built in memory bypass the loader's checks: every value must still be finite."""
    for k, v in record.columns.items():
        bad = ~np.isfinite(np.asarray(v, dtype=float))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise RecordError(
                f"{record.path or record.name}: row {i + 2}, column {k!r} holds {float(v[i])}; values must be finite"
            )


def instrument_id(record: Record) -> str:
    """Which instrument (and channel) a record measured: its JSON keys ``instrument.id`` and
    ``instrument.channel`` joined as ``id[channel]`` (either may be absent; ``""`` when both are)."""
    inst = record.meta.get("instrument", {})
    ident = inst.get("id")
    chan = inst.get("channel")
    out = "" if ident is None else str(ident)
    return out + (f"[{chan}]" if chan is not None else "")


def check_one_instrument(records) -> None:
    """Refuse records of different instruments or channels in one fit: one coefficient set for several gyros
    would be a blend of theirs. Records without ``instrument.id``/``channel`` are taken as one instrument."""
    ids: dict[str, list[str]] = {}
    for r in records:
        ids.setdefault(instrument_id(r), []).append(r.name)
    if len(ids) > 1:
        listing = "; ".join(f"{k or '(no id)'}: {', '.join(v[:3])}{' …' if len(v) > 3 else ''}" for k, v in ids.items())
        raise ModelError(
            f"records of {len(ids)} different instruments/channels cannot share one coefficient set ({listing}); "
            "fit each instrument on its own (fit_per_instrument, or `gyrojax fit --per-instrument`)"
        )


def split_by_instrument(records) -> dict[str, list]:
    """Records grouped by :func:`instrument_id`, in order of first appearance."""
    out: dict[str, list] = {}
    for r in records:
        out.setdefault(instrument_id(r), []).append(r)
    return out


@dataclass
class Campaign:
    """Records of one fit as arrays: ``data[i]`` (:class:`gyrojax.physics.model.RecordData`), ``labels[i]``
    (segment of each
    measurement, −1 for none) and ``times[i]`` (time of each measurement, s) per record."""

    records: list
    data: list
    labels: list
    kind: str
    times: list = field(default_factory=list)

    @classmethod
    def of(cls, records) -> "Campaign":
        """A campaign from one :class:`Record` or a list of records of one instrument kind; checks that every value
        is finite and that servo records can null the pickoff (Hu 3-59)."""
        if isinstance(records, Record):
            records = [records]
        records = list(records)
        if not records:
            raise ModelError("no records to fit")
        kinds = {r.kind for r in records}
        if TRIAD_KIND in kinds:
            raise ModelError(
                "imu-triad records have no turntable campaign: gyrojax.fit, gyrojax.diagnose and "
                "gyrojax.add_and_refit take them as they are; the turntable tools (design, separate) do not"
            )
        if len(kinds) > 1:
            raise ModelError(f"records of different instrument kinds cannot be fitted together: {sorted(kinds)}")
        check_one_instrument(records)
        for r in records:
            _check_finite(r)
        data = [record_data(r) for r in records]
        for r, d in zip(records, data):
            check_servo(d, r.path or r.name)
        labels = [measurement_labels(r, d) for r, d in zip(records, data)]
        times = [measurement_times(r, d) for r, d in zip(records, data)]
        return cls(records, data, labels, records[0].kind, times)

    @property
    def n_measurements(self) -> int:
        """Number of measurements in all records (rows with a label ≥ 0)."""
        return int(sum((lab >= 0).sum() for lab in self.labels))


def check_terms(model: Model, campaign: Campaign) -> None:
    """Refuse a model whose inputs the records lack: ``bias_temperature`` and ``temperature_hinge``
    (:data:`gyrojax.physics.effects.TEMPERATURE_EFFECTS`) need a ``temperature_C`` column (°C) that varies, or they
    alias D_F. Raises :class:`ModelError`."""
    for name in (t for t in model.terms if t in fx.TEMPERATURE_EFFECTS):
        temps = []
        for r in campaign.records:
            if r.temperature_C is None:
                raise ModelError(f"{r.path or r.name}: effect {name!r} needs column 'temperature_C', which is absent")
            temps.append(r.temperature_C)
        t = np.concatenate(temps)
        if np.ptp(t) < 1e-6:
            raise ModelError(
                f"effect {name!r} cannot be fitted: column 'temperature_C' is constant "
                f"({t[0]} °C) in every record, so it aliases D_F"
            )


class Linearized(NamedTuple):
    """One record's measurement rows at θ: the ``residual`` r = y − predict (output units: deg/h for gyros, g for
    accelerometers), the ``jacobian`` J = ∂predict/∂θ (output units per report unit), the continuous-segment
    ``labels`` and the measurement ``times`` (s)."""

    residual: np.ndarray
    jacobian: np.ndarray
    labels: np.ndarray
    times: np.ndarray


def linearize(model: Model, theta, campaign: Campaign) -> list[Linearized]:
    """The :class:`Linearized` rows of every record at ``theta`` (report units); measurement rows only."""
    out = []
    th = np.asarray(theta, dtype=np.float64)  # numpy: a jnp array of a new shape compiles a staging function
    for d, lab, t in zip(campaign.data, campaign.labels, campaign.times):
        ok = lab >= 0
        # executables kept across processes (built-in models: gyrojax.physics.kept_model)
        if model.size:
            y, jac = kept_predict_and_jacobian(model, th, d)
            jac = np.asarray(jac)[ok]
        else:
            y, jac = kept_predict(model, th, d), np.zeros((int(ok.sum()), 0))
        r = (np.asarray(d.y) - np.asarray(y))[ok]
        out.append(Linearized(r, jac, lab[ok], t[ok]))
    return out


def input_hashes(records) -> list:
    """Name, path and SHA-256 of the columns and JSON of every record: which inputs a result came from."""
    out = []
    for r in records:
        h = hashlib.sha256()
        for k in sorted(r.columns):
            h.update(k.encode())
            h.update(np.ascontiguousarray(r.columns[k]).tobytes())
        h.update(json.dumps(r.meta, sort_keys=True).encode())
        out.append({"name": r.name, "path": r.path, "sha256": h.hexdigest()})
    return out
