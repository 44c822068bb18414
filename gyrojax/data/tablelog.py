"""A turntable data system's log as a conventions record (§5): its columns and units mapped by a set-up
(:mod:`gyrojax.data.tablesetup`), its segments detected from the table channel (:mod:`gyrojax.data.tablesegments`),
and — when the instrument has a data system of its own — its two logs joined by time.

* **Clocks.** Each log's time column in s, ms, µs, ns, or ISO 8601 date-times (then seconds since midnight of the
  first stamp's day, so that logs of one day share a clock). The instrument's log is put on the table's clock by
  ``clock_offset_s`` (its time + offset = the table's); the table's angles (unwrapped) and rates are interpolated
  linearly onto the instrument's times, never the other way (the output is the measurement: interpolating it would
  filter its noise). Instrument samples outside the table log, or inside a gap of it (a step above 1.5 × its median,
  conventions §5), are left out and counted. The overlap is said; logs that barely overlap are refused.
* **Angles.** Encoder counts (``counts_per_rev``), deg, rad or arcsec, unwrapped into a continuous angle: with a
  table-rate column each step is the multiple of 360° nearest the rate's; without one, steps are taken below 180°
  (and a table turning more than 90° between samples is refused: its direction cannot be told).
* **Output.** Torquer current (mA, A, µA), volts (V, mV), pulse counts per interval (the mean pulse rate over the
  interval, stamped at its middle), a rate (deg/h, deg/s, rad/s) or an acceleration (g, m/s²). Conventions §5 names
  one output column, ``current_mA`` (``current_x_mA``, ``current_y_mA`` for a TDF gyro), and its nominal scale
  ``scale_factor_deg_per_h_per_mA`` (``scale_factor_g_per_mA``): the record keeps the output in its base unit (mA,
  V, pulse/s, deg/h or g) in that column and the nominal scale per that unit (1 for a rate or an acceleration), and
  says so under ``output`` in its JSON. The indicated rate S_nom · output is then exactly the data system's.
* **Segments.** Positions, rate steps and revolutions detected from the table channel (or a data system's own step
  column), labelled in ``segment``; the transitions between holds are left out unless ``keep_transitions`` (a
  table accelerating is no part of a rate test). What was found and left out is reported under ``import``.
"""

from __future__ import annotations

import numpy as np

from gyrojax.data.logs import file_stem, numeric_columns, read_table
from gyrojax.data.record import FORMAT, Record
from gyrojax.data.schema import validate_columns, validate_meta
from gyrojax.data.tablesegments import describe, detect_table_segments
from gyrojax.data.tablesetup import TableSetup, check_setup
from gyrojax.data.tableunits import (
    ANGLE_UNITS,
    OUTPUT_UNITS,
    RATE_UNITS,
    TIME_UNITS,
    scale_in_base,
    somigliana_gravity,
    to_celsius,
)
from gyrojax.errors import RecordError
from gyrojax.kinds import ACCEL, TDF

MIN_OVERLAP = 0.5
"""Smallest share of the instrument's log that the table's log must cover (after the clock offset)."""
TABLE_KEYS = ("time", "segment")


def clock_seconds(df, col: str, unit: str, where: str) -> np.ndarray:
    """A log's time column in s: numbers in ``unit`` (:data:`~gyrojax.data.tablesetup.TIME_UNITS`), or ISO 8601
    date-times (``unit`` ``iso``) as seconds since midnight of the first stamp's day; strictly increasing, or an
    error naming the row and the column."""
    import pandas as pd

    if unit == "iso":
        raw = df[col].astype(str)
        stamps = pd.to_datetime(raw, format="ISO8601", errors="coerce", utc=True)
        bad = np.flatnonzero(stamps.isna().to_numpy())
        if bad.size:
            i = int(bad[0])
            raise RecordError(
                f"{where}: row {i + df.attrs.get('first_line', 2)}, column {col!r} holds {raw.iloc[i]!r}, not an ISO "
                "8601 date-time (2026-03-01T09:30:00.125)"
            )
        ns = stamps.to_numpy(dtype="datetime64[ns]").astype(np.int64)
        day = ns[0] - ns[0] % (86400 * 10**9)
        t = (ns - day) * 1e-9
    else:
        t = numeric_columns(df, [col], where)[:, 0] * TIME_UNITS[unit]
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0])
        raise RecordError(
            f"{where}: row {i + 1 + df.attrs.get('first_line', 2)}, column {col!r}: time does not increase "
            f"({t[i + 1]:.9g} s after {t[i]:.9g} s); a log's clock must increase from row to row"
        )
    return t


def unwrap_angle(theta: np.ndarray, t: np.ndarray, rate: np.ndarray | None, where: str) -> np.ndarray:
    """A continuous angle (deg) from readings that may wrap at one revolution (module doc)."""
    d = np.diff(theta)
    if rate is not None:
        expected = 0.5 * (rate[1:] + rate[:-1]) * np.diff(t)
        d = d + 360.0 * np.round((expected - d) / 360.0)
    else:
        d = (d + 180.0) % 360.0 - 180.0
        dt = np.diff(t)
        cont = dt <= 1.5 * np.median(dt) if len(dt) else dt > 0
        big = np.flatnonzero(cont & (np.abs(d) > 90.0))
        if big.size:
            i = int(big[0])
            raise RecordError(
                f"{where}: the table turns {abs(d[i]):.4g} deg between two samples ({t[i]:.6g}–{t[i + 1]:.6g} s): "
                "too far to tell its direction; map the table rate (rate_<axis>) or log faster"
            )
    return np.concatenate([[theta[0]], theta[0] + np.cumsum(d)])


def _join_mask(t_tab: np.ndarray, t_g: np.ndarray) -> tuple[np.ndarray, int, int]:
    """Which instrument times can be interpolated in the table's log: inside it and not inside one of its gaps;
    (mask, samples outside, samples in gaps)."""
    inside = (t_g >= t_tab[0]) & (t_g <= t_tab[-1])
    dt = np.diff(t_tab)
    gap = dt > 1.5 * np.median(dt)
    j = np.clip(np.searchsorted(t_tab, t_g, side="right") - 1, 0, len(dt) - 1)
    in_gap = inside & gap[j] & (t_g > t_tab[j]) & (t_g < t_tab[np.minimum(j + 1, len(t_tab) - 1)])
    return inside & ~in_gap, int((~inside).sum()), int(in_gap.sum())


def _mapped(df, where: str, setup: TableSetup, key: str) -> str:
    col = setup.columns[key].column
    if col not in df.columns:
        raise RecordError(
            f"{where}: column {col!r} ({setup.where.get(f'columns.{key}', key)}) is not in the log; it has "
            f"{list(df.columns)}"
        )
    return col


def import_table(table_log, gyro_log=None, setup: TableSetup | None = None, *, delimiter=None) -> Record:
    """A turntable data system's log (and the instrument's own, on a second clock) as one conventions record.

    Args:
      table_log: the table data system's delimited log (time, angles or rates; and the instrument's columns when
        there is one log).
      gyro_log: the instrument's log on a clock of its own (``columns.gyro_time``), or None.
      setup: the :class:`~gyrojax.data.tablesetup.TableSetup` (columns, units, site, axes, mounting, kind, mode,
        scale); checked here (:func:`~gyrojax.data.tablesetup.check_setup`).
      delimiter: the logs' delimiter (None: detected, and said).

    Returns: the record (not yet saved), ``meta["import"]`` the report (clocks, join, segments, ranges, notes).
    Raises: :class:`~gyrojax.errors.RecordError` naming the file, row, column or key.
    """
    s = check_setup(setup or TableSetup())
    notes: list[str] = []
    two = gyro_log is not None
    if two and "gyro_time" not in s.columns:
        raise RecordError(f"{gyro_log}: a second log needs its own clock: columns.gyro_time (--map gyro_time=COL)")
    if not two and "gyro_time" in s.columns:
        raise RecordError("columns.gyro_time maps the clock of a second log, but one log was given")
    wt = str(table_log)
    tab = read_table(table_log, delimiter, notes)
    gdf, wg = (read_table(gyro_log, delimiter, notes), str(gyro_log)) if two else (tab, wt)
    names = [a for a, _ in s.axes]

    def side(key):  # which log holds the key's column
        if not two or key.startswith(("angle_", "rate_")) or key in TABLE_KEYS:
            return tab, wt
        if key == "temperature" and s.columns[key].column not in gdf.columns:
            return tab, wt
        return gdf, wg

    cols = {k: _mapped(*side(k), s, k) for k in s.columns}
    c_time = s.columns["time"]
    t_tab = clock_seconds(tab, cols["time"], c_time.unit, wt)
    if len(t_tab) < 2:
        raise RecordError(f"{wt}: needs at least two samples")
    # the table's channels, on its clock
    rates = {}
    for a in names:
        if f"rate_{a}" in s.columns:
            c = s.columns[f"rate_{a}"]
            rates[a] = numeric_columns(tab, [cols[f"rate_{a}"]], wt)[:, 0] * RATE_UNITS[c.unit]
    angles, resolution = {}, []
    for a in names:
        key = f"angle_{a}"
        if key in s.columns:
            c = s.columns[key]
            raw = numeric_columns(tab, [cols[key]], wt)[:, 0]
            f = 360.0 / c.counts_per_rev if c.unit == "counts" else ANGLE_UNITS[c.unit]
            resolution.append(f if c.unit == "counts" else None)
            angles[a] = unwrap_angle(raw * f, t_tab, rates.get(a), f"{wt}, column {cols[key]!r}")
        else:  # a rate column alone: the angle integrated from the first sample (trapezoids), starting at 0
            r = rates[a]
            angles[a] = np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * np.diff(t_tab))])
            resolution.append(None)
            notes.append(f"table axis {a!r}: no angle column; its angle is the rate integrated from 0 deg at the start")
    seg_col = None
    if "segment" in s.columns:
        seg_col = numeric_columns(tab, [cols["segment"]], wt)[:, 0]
        frac = np.flatnonzero(seg_col != np.round(seg_col))
        if frac.size:
            i = int(frac[0])
            raise RecordError(
                f"{wt}: row {i + tab.attrs.get('first_line', 2)}, column {cols['segment'][0]!r} holds "
                f"{seg_col[i]!r}; step numbers are integers"
            )
    # the instrument's channels, on its clock
    if two:
        t_g = clock_seconds(gdf, cols["gyro_time"], s.columns["gyro_time"].unit, wg) + s.clock_offset_s
    else:
        t_g = t_tab.copy()
    out_keys = [k for k in (("output_x", "output_y") if s.kind == TDF else ("output",)) if k in s.columns]
    outputs, out_unit = {}, None
    for k in out_keys:
        c = s.columns[k]
        df, where = side(k)
        outputs[k] = numeric_columns(df, [cols[k]], where)[:, 0] * OUTPUT_UNITS[c.unit][1]
        out_unit = c.unit
    temp = None
    if "temperature" in s.columns:
        df, where = side("temperature")
        temp = to_celsius(numeric_columns(df, [cols["temperature"]], where)[:, 0], s.columns["temperature"].unit)
        if two and df is tab:  # the table's thermometer, onto the instrument's times
            temp = np.interp(t_g, t_tab, temp)
    pulses = out_unit is not None and OUTPUT_UNITS[out_unit][0] == "pulses"
    keep = np.ones(len(t_g), dtype=bool)
    if pulses:  # counts per interval: the mean pulse rate over the interval, stamped at its middle
        dtg = np.diff(t_g)
        for k in out_keys:
            outputs[k] = np.concatenate([[np.nan], outputs[k][1:] / dtg])
        t_g = np.concatenate([[t_g[0]], 0.5 * (t_g[1:] + t_g[:-1])])
        keep[0] = False
        notes.append(
            "pulse counts per interval read as the mean pulse rate over the interval, stamped at its middle "
            "(the first sample, whose interval is not logged, is left out)"
        )
    join = {"method": "one clock", "overlap_s": [float(t_tab[0]), float(t_tab[-1])]}
    if two or pulses:
        ok, outside, in_gaps = _join_mask(t_tab, t_g)
        keep &= ok
        if two:
            used = float(keep.sum()) / len(keep)
            span_g = (float(t_g[0]), float(t_g[-1]))
            if used < MIN_OVERLAP:
                raise RecordError(
                    f"{wg}: on the table's clock (offset {s.clock_offset_s:g} s) the instrument's log covers "
                    f"{span_g[0]:.6g}–{span_g[1]:.6g} s and the table's {t_tab[0]:.6g}–{t_tab[-1]:.6g} s: only "
                    f"{100 * used:.3g} % of its samples fall inside the table's log; give the clocks' offset "
                    "(clock_offset_s, --clock-offset: the instrument's time + offset = the table's)"
                )
            join = {
                "method": "the table's angles (unwrapped) and rates interpolated linearly onto the instrument's times",
                "offset_s": s.clock_offset_s,
                "overlap_s": [max(span_g[0], float(t_tab[0])), min(span_g[1], float(t_tab[-1]))],
                "instrument_samples_used": int(keep.sum()),
                "outside_the_table_log": outside,
                "in_gaps_of_the_table_log": in_gaps,
            }
    tq = t_g[keep]
    ang = np.stack([np.interp(tq, t_tab, angles[a]) for a in names], axis=1)
    rts = np.stack([np.interp(tq, t_tab, rates[a]) for a in names], axis=1) if len(rates) == len(names) else None
    seg_q = None
    if seg_col is not None:
        j = np.clip(np.searchsorted(t_tab, tq, side="right") - 1, 0, len(t_tab) - 1)
        seg_q = seg_col[j]  # a step number holds until the next
    # segments: the data system's steps, or detected from the table channel
    servo = s.mode == "servo"
    res = resolution if all(r is not None for r in resolution) else None  # encoders: 360° / counts per rev
    segs = detect_table_segments(tq, ang, rts, servo=servo, resolution=res)
    labels = np.full(len(tq), -1)
    for i, sg in enumerate(segs):
        labels[sg.start : sg.end] = i
    held = np.array([sg.kind != "transition" for sg in segs])
    if seg_q is not None:
        labels = seg_q.astype(np.int64)
        use = np.ones(len(tq), dtype=bool)
        notes.append(f"segments from the log's step column {cols['segment'][0]!r}; every sample kept")
    elif s.keep_transitions or servo:
        use = np.ones(len(tq), dtype=bool)
    else:
        use = held[labels]
    dropped_t = int((~use).sum())
    # the record
    record_cols = {"time_s": tq[use]}
    for j, a in enumerate(names):
        record_cols[f"angle_{a}_deg"] = ang[use, j]
        if rts is not None:
            record_cols[f"rate_{a}_dps"] = rts[use, j]
    record_cols["segment"] = labels[use].astype(float)
    out_cols = {"output": "current_mA", "output_x": "current_x_mA", "output_y": "current_y_mA"}
    for k in out_keys:
        record_cols[out_cols[k]] = outputs[k][keep][use]
    if temp is not None:
        record_cols["temperature_C"] = temp[keep][use]
    if len(record_cols["time_s"]) < 2:
        raise RecordError(f"{wt}: no sample left to write (every sample was a transition or outside the overlap)")
    name = s.name or file_stem(table_log)
    meta = _meta(s, name, out_keys, out_unit, notes)
    seg_json = [sg.to_json(i, names) for i, sg in enumerate(segs)] if seg_q is None else []
    meta["import"] = {
        "source": {"table": wt, **({"instrument": wg} if two else {})},
        "clock": {
            "table": _clock_report(cols["time"], c_time.unit, t_tab),
            **({"instrument": _clock_report(cols["gyro_time"], s.columns["gyro_time"].unit, t_g)} if two else {}),
        },
        "join": join,
        "segments": seg_json,
        "summary": describe(segs, names) if seg_q is None else f"{len(np.unique(labels))} steps from the log",
        "transitions_left_out": {"samples": dropped_t, "seconds": float(dropped_t * np.median(np.diff(tq)))},
        "ranges": {k: [float(np.min(v)), float(np.max(v))] for k, v in record_cols.items() if k != "segment"},
        "notes": notes,
    }
    validate_meta(meta, f"{name}.json")
    validate_columns(meta, record_cols, f"{name}.csv")
    meta["import"]["notes"] = list(dict.fromkeys(notes))
    return Record(meta, {k: np.asarray(v, dtype=float) for k, v in record_cols.items()})


def _clock_report(col: str, unit: str, t: np.ndarray) -> dict:
    dt = np.diff(t)
    return {
        "column": col,
        "unit": unit,
        "start_s": float(t[0]),
        "end_s": float(t[-1]),
        "rate_hz": float(1.0 / np.median(dt)) if dt.size else None,
    }


def _meta(s: TableSetup, name: str, out_keys: list, out_unit: str | None, notes: list) -> dict:
    """The record's JSON (conventions §5) and its ``output`` description."""
    sf_key = "scale_factor_g_per_mA" if s.kind == ACCEL else "scale_factor_deg_per_h_per_mA"
    g = s.gravity_mps2
    if g is None:
        g = somigliana_gravity(s.latitude_deg)
        notes.append(f"site gravity not given: WGS-84 normal gravity at {s.latitude_deg:g} deg, {g:.6f} m/s²")
    inst = {"kind": s.kind, **s.mounting}
    if s.instrument_id is not None:
        inst["id"] = s.instrument_id
    meta = {
        "format": FORMAT,
        "name": name,
        "site": {"latitude_deg": s.latitude_deg, "gravity_mps2": g},
        "table": {"axes": [{"name": a, "axis_enu": [float(x) for x in u]} for a, u in s.axes]},
        "instrument": inst,
        "mode": s.mode,
        "servo_axis": s.servo_axis,
        "notes": s.notes or "imported from a turntable data system's log (gyrojax import table)",
    }
    record_col = {"output": "current_mA", "output_x": "current_x_mA", "output_y": "current_y_mA"}
    if out_unit is None:  # servo mode without a commanded current
        meta[sf_key] = 1.0 if s.scale is None else scale_in_base(s.scale, "mA", s.kind, s.where.get("scale", "scale"))
        meta["output"] = {"note": "no output column: servo mode with no commanded current (0 mA)"}
        return meta
    quantity, _, base = OUTPUT_UNITS[out_unit]
    if quantity in ("rate", "acceleration"):
        meta[sf_key] = 1.0
        scale_text = f"none: the output is already {'a rate' if quantity == 'rate' else 'an acceleration'}"
    else:
        meta[sf_key] = scale_in_base(s.scale, out_unit, s.kind, s.where.get("scale", "scale"))
        scale_text = f"{s.scale[0]:g} {s.scale[1]}"
    per = "g" if s.kind == ACCEL else "deg/h"
    meta["output"] = {
        "columns": {record_col[k]: s.columns[k].column for k in out_keys},
        "quantity": quantity,
        "unit": base,
        "given_unit": out_unit,
        "nominal_scale": scale_text,
        "note": f"{', '.join(record_col[k] for k in out_keys)} holds the output in {base}; {sf_key} is {per} per "
        f"{base}",
    }
    return meta


def import_summary(report: dict) -> list[str]:
    """The lines ``gyrojax import table`` prints from a record's import report."""
    lines = [f"segments: {report['summary']}"]
    tl = report["transitions_left_out"]
    if tl["samples"]:
        lines.append(f"  {tl['samples']} samples ({tl['seconds']:.4g} s) of table transitions left out")
    for k, c in report["clock"].items():
        lines.append(
            f"clock ({k}): column {c['column']!r} in {c['unit']}, {c['start_s']:.6g}–{c['end_s']:.6g} s, "
            f"{c['rate_hz']:.6g} Hz"
        )
    j = report["join"]
    if j["method"] != "one clock":
        lines.append(
            f"join: {j['method']}; offset {j['offset_s']:g} s; overlap {j['overlap_s'][0]:.6g}–{j['overlap_s'][1]:.6g} "
            f"s; {j['instrument_samples_used']} instrument samples used, {j['outside_the_table_log']} outside the "
            f"table's log, {j['in_gaps_of_the_table_log']} in its gaps"
        )
    lines.append(
        "ranges: " + ", ".join(f"{k} {v[0]:.6g}…{v[1]:.6g}" for k, v in report["ranges"].items() if k != "time_s")
    )
    lines.extend(f"note: {n}" for n in report["notes"])
    return lines
