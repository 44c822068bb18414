"""The source books' closed forms and systems, used as independent checks and as tools of their own: Hu's
classical solutions (:mod:`~gyrojax.seeds.classical`), drift processing (Hu ch. 4/6), FOG temperature models
(seed 001, :mod:`~gyrojax.seeds.thermal`), marine INS calibration (seed 003, :mod:`~gyrojax.seeds.marine`), system
navigation error (:mod:`~gyrojax.seeds.system`), optical gyros (:mod:`~gyrojax.seeds.optical`) and the physical
drift model (:mod:`~gyrojax.seeds.physical`)."""
