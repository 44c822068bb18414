"""What crosses the boundary: record files (:mod:`~gyrojax.data.records`, CONVENTIONS §5), truth files
(:mod:`~gyrojax.data.truth`, §8), test plans as data and their builders (:mod:`~gyrojax.data.plans`), and atomic,
validated file I/O (:mod:`~gyrojax.data.io`)."""
