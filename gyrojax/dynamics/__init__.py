"""Loops in time: exact zero-order-hold discretisation (:mod:`~gyrojax.dynamics.discretize`), the torque-rebalance
and table-servo loops (:mod:`~gyrojax.dynamics.loops`), the TDF capture loops (:mod:`~gyrojax.dynamics.tdfloop`)
and loop-aware identification (:mod:`~gyrojax.dynamics.loopfit`)."""
