"""What crosses the boundary: record files (:mod:`~gyrojax.data.records`, CONVENTIONS §5), truth files
(:mod:`~gyrojax.data.truth`, §8), test plans as data and their builders (:mod:`~gyrojax.data.plans`); atomic,
validated file I/O and the result protocol sit below every package, in :mod:`gyrojax.protocol`."""
