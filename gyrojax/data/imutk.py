"""imu_tk's files (Tedaldi, Pretto & Menegatti, ICRA 2014; bitbucket alberto_pretto/imu_tk): an accelerometer
file and a gyroscope file of ``time x y z`` samples — its ASCII text, or the MATLAB matrices of the authors' MATLAB
code (``IMU0x2Dalpha.mat``, ``IMU0x2Domega.mat``) — into an ``imu-triad`` record by
:func:`gyrojax.data.importers.triad_from_arrays` (a multi-position session, or a rest log)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gyrojax.data.importers import triad_from_arrays
from gyrojax.data.logs import jitter_note, log_clock
from gyrojax.data.record import Record
from gyrojax.errors import RecordError


def read_imutk_ascii(path) -> np.ndarray:
    """imu_tk's files: its ASCII format, one sample per line, ``time x y z`` (time in s, values in raw units)
    separated by blanks (its ``.mat`` text files; gzip-compressed files are read too), or a MATLAB file holding one
    such n × 4 matrix (the ``IMU0x2Dalpha.mat``/``IMU0x2Domega.mat`` of Tedaldi et al.'s MATLAB code). Returns
    (n, 4) floats; :class:`RecordError` naming the line (or the variables) otherwise."""
    from gyrojax.data.logs import is_mat_file, read_mat

    p = Path(path)
    if is_mat_file(p):
        found = {k: v for k, v in read_mat(p).items() if 4 in v.shape and max(v.shape) > 1}
        if len(found) != 1:
            raise RecordError(f"{p}: an imu_tk MATLAB file holds one n × 4 matrix (time x y z); found {sorted(found)}")
        ((_, data),) = found.items()
        data = data.T if data.shape[0] == 4 and data.shape[1] != 4 else data
    else:
        try:
            data = np.loadtxt(p, ndmin=2)
        except (OSError, ValueError, UnicodeDecodeError) as e:
            raise RecordError(f"{p}: not an imu_tk ASCII file (time x y z per line): {str(e)[:160]}") from None
    if data.shape[1] != 4 or len(data) < 2:
        raise RecordError(f"{p}: expected 4 columns (time x y z) and at least 2 lines, got shape {data.shape}")
    bad = np.flatnonzero(np.diff(data[:, 0]) <= 0)
    if bad.size:
        raise RecordError(f"{p}: line {bad[0] + 2}: time does not increase ({data[bad[0] + 1, 0]!r})")
    return data


def import_imutk(
    acc_path, gyro_path, *, acc_unit: str = "counts", gyro_unit: str = "counts", name=None, **kw
) -> Record:
    """An imu_tk multi-position recording (or a rest log in its format) (accelerometer and gyroscope files) as one
    ``imu-triad`` record by :func:`gyrojax.data.importers.triad_from_arrays` (other keyword arguments go there).

    Static poses come from :func:`gyrojax.data.segments.detect_rests`; each pair of consecutive poses gets a
    ``move`` segment (a gravity-to-gravity move, its rotation known through the accelerometer directions before and
    after). The accelerometer is in imu_tk's raw counts by default, the gyro too (``gyro_counts_per_dps`` per deg/s).
    """
    acc = read_imutk_ascii(acc_path)
    gyr = read_imutk_ascii(gyro_path)
    if len(acc) != len(gyr) or not np.allclose(acc[:, 0], gyr[:, 0], atol=1e-6):
        raise RecordError(f"{gyro_path}: its timestamps differ from {acc_path}'s; resample one onto the other first")
    notes = []
    note = jitter_note(acc[:, 0], f"{acc_path}: time")
    if note:
        notes.append(note)
    t, clock = log_clock(len(acc), str(acc_path), times=acc[:, 0], time_source=f"the time column of {acc_path} (s)")
    return triad_from_arrays(
        t,
        acc[:, 1:],
        gyr[:, 1:],
        acc_unit=acc_unit,
        gyro_unit=gyro_unit,
        name=name or Path(acc_path).name.split(".")[0],
        source=f"imu_tk files {acc_path}, {gyro_path}",
        notes=notes,
        clock=clock,
        **kw,
    )
