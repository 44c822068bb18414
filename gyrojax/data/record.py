"""The :class:`Record` type: one test run as metadata and columns (conventions §5), with its derived views.

Reading and writing the files is :mod:`gyrojax.data.records`; the checks are :mod:`gyrojax.data.schema`.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from gyrojax.data.timebase import continuous_segments, derive_rate
from gyrojax.kinds import ACCEL, FOG, RLG, SDF, TDF

FORMAT = "gyrojax-record-1"
"""The ``format`` of a record's JSON (conventions §5)."""

TRIAD_KEYS = {
    SDF: ("ia", "oa", "sa"),
    TDF: ("x", "y", "z"),
    ACCEL: ("ia", "pa", "oa"),
    FOG: ("ia", "oa", "sa"),
    RLG: ("ia", "oa", "sa"),
}
"""The metadata keys of the instrument axes of each kind (the rows of :attr:`Record.triad`)."""


@dataclass
class Record:
    """One test run: metadata (the JSON, unknown keys kept) and columns (numpy arrays, every CSV column kept).

    Units are those of the files: s, deg, deg/s, mA, °C. Use the properties for the derived views.
    """

    meta: dict
    columns: dict[str, np.ndarray]
    path: str | None = None
    _rates_derived: bool | None = field(default=None, repr=False)

    # ---- metadata views ------------------------------------------------------------------------------------
    @property
    def name(self) -> str:
        """The record's name (the file stem)."""
        return self.meta["name"]

    @property
    def kind(self) -> str:
        """Instrument kind (conventions §5): ``sdf-gyro``, ``tdf-gyro``, ``pendulous-accel``, ``fog`` or ``rlg``."""
        return self.meta["instrument"]["kind"]

    @property
    def mode(self) -> str:
        """``rebalance`` or ``servo`` (conventions §4)."""
        return self.meta["mode"]

    @property
    def axis_names(self) -> list[str]:
        """Table axis names, outermost first."""
        return [a["name"] for a in self.meta["table"]["axes"]]

    @property
    def axes_enu(self) -> np.ndarray:
        """Table axis unit vectors in L at zero angles, outermost first, shape (k, 3)."""
        return np.array([a["axis_enu"] for a in self.meta["table"]["axes"]], dtype=float)

    @property
    def triad(self) -> np.ndarray:
        """Instrument axes in platform coordinates, rows (IA, OA, SA) / (X, Y, Z) / (IA, PA, OA)."""
        keys = TRIAD_KEYS[self.kind]
        return np.array([self.meta["instrument"][k] for k in keys], dtype=float)

    @property
    def latitude_deg(self) -> float:
        """Geodetic latitude of the site, deg."""
        return float(self.meta["site"]["latitude_deg"])

    @property
    def gravity_mps2(self) -> float:
        """Local gravity magnitude at the site, m/s²."""
        return float(self.meta["site"]["gravity_mps2"])

    @property
    def scale_factor(self) -> float:
        """Nominal scale factor: deg/h/mA for gyros, g/mA for accelerometers."""
        key = "scale_factor_g_per_mA" if self.kind == ACCEL else "scale_factor_deg_per_h_per_mA"
        return float(self.meta[key])

    @property
    def servo_axis_index(self) -> int | None:
        """Index of the servo axis among the table axes (servo records), else None."""
        s = self.meta.get("servo_axis")
        return None if s is None else self.axis_names.index(s)

    @property
    def encoder_axis_index(self) -> int:
        """Axis whose angle readout carries ``encoder_harmonic``: the servo axis, or else the last axis."""
        s = self.servo_axis_index
        return len(self.axis_names) - 1 if s is None else s

    # ---- column views --------------------------------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of samples."""
        return len(self.columns["time_s"])

    @property
    def time_s(self) -> np.ndarray:
        """Sample times, s, shape (n,)."""
        return self.columns["time_s"]

    @property
    def angles_deg(self) -> np.ndarray:
        """Table angles, shape (n, k), deg."""
        return np.stack([self.columns[f"angle_{a}_deg"] for a in self.axis_names], axis=1)

    @property
    def segment_id(self) -> np.ndarray:
        """Integer id of the continuous segment of each sample (conventions §5)."""
        return continuous_segments(self.time_s, self.columns.get("segment"))

    @property
    def rates_derived(self) -> bool:
        """True when at least one table rate is derived from the angles (no ``rate_<axis>_dps`` column)."""
        return any(f"rate_{a}_dps" not in self.columns for a in self.axis_names)

    @property
    def rates_dps(self) -> np.ndarray:
        """Table rates, shape (n, k), deg/s: the rate columns where given, else derived inside segments."""
        seg = None  # the segment ids only when a rate has to be derived
        out = []
        for a in self.axis_names:
            col = self.columns.get(f"rate_{a}_dps")
            if col is None:
                seg = self.segment_id if seg is None else seg
                col = derive_rate(self.time_s, self.columns[f"angle_{a}_deg"], seg)
            out.append(col)
        return np.stack(out, axis=1)

    @property
    def current_mA(self) -> np.ndarray:
        """Torquer current; servo records without the column have 0 (commanded current)."""
        if self.kind == TDF:
            return np.stack([self.columns["current_x_mA"], self.columns["current_y_mA"]], axis=1)
        col = self.columns.get("current_mA")
        return np.zeros(self.n) if col is None else col

    @property
    def indicated(self) -> np.ndarray:
        """Indicated output S_nom·i: deg/h for gyros (TDF: shape (n, 2)), g for accelerometers."""
        return self.scale_factor * self.current_mA

    @property
    def temperature_C(self) -> np.ndarray | None:
        """Instrument temperature, °C, shape (n,); None when the record has no such column."""
        return self.columns.get("temperature_C")

    def to_pandas(self):
        """The CSV columns as a ``pandas.DataFrame`` (with ``segment_id`` added); metadata in ``.attrs``."""
        import pandas as pd

        df = pd.DataFrame(self.columns)
        df["segment_id"] = self.segment_id
        df.attrs.update(copy.deepcopy(self.meta))
        return df

    def with_columns(self, **cols) -> "Record":
        """A copy with some columns replaced or added."""
        new = dict(self.columns)
        new.update({k: np.asarray(v, dtype=float) for k, v in cols.items()})
        return Record(copy.deepcopy(self.meta), new, self.path)
