"""Monte Carlo studies of many simulated gyros: study files, the vmapped pipeline, sharded runs and their results
(:mod:`~gyrojax.montecarlo.study`)."""
