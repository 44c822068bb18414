"""Test-plan design by Fisher information: the information of a plan (:mod:`~gyrojax.planning.fisher`), the
criteria (:mod:`~gyrojax.planning.criteria`), gradient-optimised static positions and dwells
(:mod:`~gyrojax.planning.optimal`; the flat API's ``gj.design``) and the comparison with the classical plans
(:mod:`~gyrojax.planning.baselines`)."""
