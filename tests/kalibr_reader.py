"""A reader of Kalibr's imu.yaml with the key set, types and checks of Kalibr's own (for the tests of
``gyrojax noise --kalibr``)."""

import math

import yaml


def kalibr_imu_parameters(path):
    """What Kalibr's reader takes from an imu.yaml: ethz-asl/kalibr
    ``aslam_offline_calibration/kalibr/python/kalibr_common/ConfigReader.py``, class ``ImuParameters`` (its
    ``getRosTopic``, ``getUpdateRate``, ``getAccelerometerStatistics``, ``getGyroStatistics``; ``IccImu.__init__`` in
    ``kalibr_imu_camera_calibration/IccSensors.py`` calls both statistics for every IMU). The same key set and
    checks, written here from reading it: ``yaml.safe_load`` of the file; a missing key is a RuntimeError naming the
    field (``catch_keyerror``); ``rostopic`` must be a ``str``; ``update_rate`` > 0; each density and random walk
    > 0; the discrete noise is density / √(1/update_rate). Returns (rostopic, update_rate, (accel discrete, walk,
    density), (gyro discrete, walk, density))."""
    data = yaml.safe_load(open(path).read())

    def field(k):
        try:
            return data[k]
        except KeyError:
            raise RuntimeError(f"[ImuConfig Reader]: Field '{k}' missing in file: {path}") from None

    topic = field("rostopic")
    if not isinstance(topic, str):
        raise RuntimeError("[ImuConfig Reader]: rostopic has to be a string")
    rate = field("update_rate")
    if rate <= 0.0:
        raise RuntimeError("[ImuConfig Reader]: invalid update_rate")
    stats = []
    for sensor in ("accelerometer", "gyroscope"):
        nd, rw = field(f"{sensor}_noise_density"), field(f"{sensor}_random_walk")
        if nd <= 0.0 or rw <= 0.0:
            raise RuntimeError(f"[ImuConfig Reader]: invalid {sensor} statistics")
        stats.append((nd / math.sqrt(1.0 / rate), rw, nd))
    return topic, rate, stats[0], stats[1]
