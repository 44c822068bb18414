"""Test-plan design: Fisher information of a plan, D/A/E/c/detect criteria, gradient optimisation of positions
and dwells, comparison with the classical plans (:mod:`~gyrojax.planning.optimal`; the flat API's ``gj.design``).
The package is not called ``design`` so that the flat function ``gj.design`` does not shadow it."""
