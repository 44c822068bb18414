"""Instrument kinds (conventions §5): the names a record's ``instrument.kind`` and a model's ``kind`` take.

This module sits at the bottom of the package (it imports nothing), so that reading a record needs no physics:
the effect registry (:mod:`gyrojax.physics.registry`) and the record schema (:mod:`gyrojax.data.schema`) both take
the kinds from here.
"""

SDF = "sdf-gyro"
"""Single-degree-of-freedom gyro (IEEE 517; Hu ch. 2), axes ``ia``, ``oa``, ``sa``."""
TDF = "tdf-gyro"
"""Two-degree-of-freedom (dynamically tuned) gyro (Hu 3-94), axes ``x``, ``y``, ``z``."""
ACCEL = "pendulous-accel"
"""Pendulous accelerometer (Hu 3-38), axes ``ia``, ``pa``, ``oa``."""
FOG = "fog"
"""Fibre-optic gyro (IEEE 952), axes ``ia``, ``oa``, ``sa`` as the SDF gyro."""
RLG = "rlg"
"""Ring-laser gyro (IEEE 647), axes ``ia``, ``oa``, ``sa`` as the SDF gyro."""
INSTRUMENT_KINDS = (SDF, TDF, ACCEL, FOG, RLG)
"""conventions §5 kinds, extended by the optical gyros (IEEE 952/647 form, axes ``ia``, ``oa``, ``sa`` as the SDF)."""
TRIAD_KIND = "imu-triad"
"""Instrument kind of a three-axis IMU record (conventions §5 extension, :mod:`gyrojax.data.triad`)."""
