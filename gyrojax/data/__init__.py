"""What crosses the boundary: records (conventions §5) — the :class:`~gyrojax.data.record.Record` type, its time base
(:mod:`~gyrojax.data.timebase`), the schema (:mod:`~gyrojax.data.schema`), the CSV (:mod:`~gyrojax.data.csvfile`),
the file pair (:mod:`~gyrojax.data.records`) and the arrays the model takes (:mod:`~gyrojax.data.arrays`) —; truth
files (:mod:`~gyrojax.data.truth`, §8); test plans as data and their builders (:mod:`~gyrojax.data.plans`) and plan
files (:mod:`~gyrojax.data.planfile`); ``imu-triad`` records and importers (:mod:`~gyrojax.data.importers`, reading
logs with :mod:`~gyrojax.data.logs` and checking accelerometers with :mod:`~gyrojax.data.accelcheck`). Atomic,
validated file I/O and the result protocol sit below every package, in :mod:`gyrojax.protocol`."""
