"""ROS 1 (``.bag``) and ROS 2 (a folder with ``metadata.yaml``, sqlite3 or mcap) bags of ``sensor_msgs/Imu``
messages, read by the ``rosbags`` library (pure Python; the optional extra ``gyrojax[bags]``), into an
``imu-triad`` record by :func:`gyrojax.data.importers.triad_from_arrays` (a rest log, or a calibration session).

The message fixes the units (sensor_msgs/Imu: ``angular_velocity`` in rad/s, ``linear_acceleration`` in m/s²,
REP 103), so no unit flag applies. The clock is each message's ``header.stamp`` (the sensor's time); when the
stamps do not increase (all zero, or a driver that does not stamp), the bag's receive time instead, and said.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gyrojax.errors import RecordError

IMU_TYPES = ("sensor_msgs/msg/Imu", "sensor_msgs/Imu")


def read_imu_bag(path, topic: str | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """(times s, accelerometer (n, 3) m/s², gyro (n, 3) rad/s, what was read) of the ``sensor_msgs/Imu`` topic
    ``topic`` of a ROS 1 or ROS 2 bag (the only such topic when None). :class:`RecordError` naming the bag and the
    topics it has otherwise."""
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise RecordError(f"{path}: reading ROS bags needs the rosbags library: pip install 'gyrojax[bags]'") from None
    p = Path(path)
    try:
        reader = AnyReader([p], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as e:  # rosbags raises its own types for a file that is no bag
        raise RecordError(f"{p}: not a readable ROS 1 or ROS 2 bag ({type(e).__name__}: {str(e)[:120]})") from None
    try:
        imu = sorted({c.topic for c in reader.connections if c.msgtype in IMU_TYPES})
        if not imu:
            have = sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections})
            raise RecordError(f"{p}: no sensor_msgs/Imu topic; the bag has {have}")
        if topic is None and len(imu) > 1:
            raise RecordError(f"{p}: {len(imu)} sensor_msgs/Imu topics {imu}: choose one with --topic")
        topic = topic or imu[0]
        if topic not in imu:
            raise RecordError(f"{p}: --topic {topic!r} is no sensor_msgs/Imu topic of the bag; it has {imu}")
        conns = [c for c in reader.connections if c.topic == topic]
        stamp, recv, acc, gyr = [], [], [], []
        try:
            for conn, t_ns, raw in reader.messages(connections=conns):
                msg = reader.deserialize(raw, conn.msgtype)
                h = msg.header.stamp
                stamp.append(int(getattr(h, "sec", 0)) * 1_000_000_000 + int(getattr(h, "nanosec", 0)))
                recv.append(t_ns)
                a, w = msg.linear_acceleration, msg.angular_velocity
                acc.append((a.x, a.y, a.z))
                gyr.append((w.x, w.y, w.z))
        except Exception as e:  # a damaged bag: rosbags' own error types, struct or decompression errors
            why = f"{type(e).__name__}: {str(e)[:100]}"
            raise RecordError(f"{p}: topic {topic!r}, message {len(stamp) + 1} cannot be read ({why})") from None
    finally:
        reader.close()
    if len(stamp) < 2:
        raise RecordError(f"{p}: topic {topic!r} holds {len(stamp)} message(s); a log needs at least 2")
    stamp, recv = np.asarray(stamp, np.int64), np.asarray(recv, np.int64)
    if np.all(np.diff(stamp) > 0):
        t, source = (stamp - stamp[0]) * 1e-9, f"the header stamps of topic {topic!r}"
    elif np.all(np.diff(recv) > 0):
        t, source = (recv - recv[0]) * 1e-9, f"the bag's receive times of topic {topic!r} (its header stamps repeat)"
    else:
        i = int(np.flatnonzero(np.diff(stamp) <= 0)[0])
        raise RecordError(
            f"{p}: topic {topic!r}, message {i + 2}: neither its header stamp nor its receive time increases"
        )
    info = {"topic": topic, "messages": len(t), "time_source": source, "imu_topics": imu}
    return t, np.asarray(acc, float), np.asarray(gyr, float), info


def import_bag(path, topic: str | None = None, **kw):
    """A ROS bag's ``sensor_msgs/Imu`` topic as an ``imu-triad`` record (module doc); other keyword arguments as
    :func:`gyrojax.data.importers.triad_from_arrays` (the units are the message's)."""
    from gyrojax.data.importers import triad_from_arrays
    from gyrojax.data.logs import file_stem, jitter_note, log_clock

    where = str(path)
    t, acc, gyr, info = read_imu_bag(path, topic)
    t, clock = log_clock(len(t), where, times=t, time_source=info["time_source"])
    notes = [f"ROS bag: {info['messages']} sensor_msgs/Imu messages of topic {info['topic']!r} (rad/s, m/s²)"]
    note = jitter_note(t, info["time_source"])
    if note:
        notes.append(note)
    kw["name"] = kw.get("name") or file_stem(path) or Path(path).name
    return triad_from_arrays(
        t, acc, gyr, gyro_unit="rad/s", acc_unit="m/s^2", source=where, notes=notes, clock=clock, **kw
    )
