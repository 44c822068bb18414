"""Records from a plan and a truth: quasi-static balance equation or through the instrument's loop, with random
drift (:mod:`~gyrojax.simulation.simulator`; the flat API's ``gj.simulate``)."""
