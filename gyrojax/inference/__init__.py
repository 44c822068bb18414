"""From records to coefficients and verdicts: the joint GLS fit with honest standard errors
(:mod:`~gyrojax.inference.identify`, built on :mod:`~gyrojax.inference.campaign`,
:mod:`~gyrojax.inference.identifiability`, :mod:`~gyrojax.inference.solver`, :mod:`~gyrojax.inference.noisefit` and
:mod:`~gyrojax.inference.result`), the triad fit of hand-moved IMUs (:mod:`~gyrojax.inference.triad`), fits of records
too long for memory (:mod:`~gyrojax.inference.bigfit`), and the diagnosis of missing effects
(:mod:`~gyrojax.inference.diagnose`)."""
