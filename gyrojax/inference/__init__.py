"""From records to coefficients and verdicts: the joint GLS fit with honest standard errors
(:mod:`~gyrojax.inference.identify`), fits of records too long for memory (:mod:`~gyrojax.inference.bigfit`), and
the diagnosis of missing effects (:mod:`~gyrojax.inference.diagnose`)."""
