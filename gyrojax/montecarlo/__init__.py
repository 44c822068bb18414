"""Monte Carlo studies of many simulated gyros: the study file (:mod:`~gyrojax.montecarlo.study`), the per-draw
pipeline (:mod:`~gyrojax.montecarlo.pipeline`), sharded and distributed runs (:mod:`~gyrojax.montecarlo.runner`,
:mod:`~gyrojax.montecarlo.hosts`) and their results (:mod:`~gyrojax.montecarlo.results`)."""
