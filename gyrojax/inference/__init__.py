"""From records to coefficients and verdicts. One public fit, :func:`gyrojax.inference.identify.fit`, chooses by
instrument kind: the joint GLS fit of turntable records with honest standard errors
(:mod:`~gyrojax.inference.identify`, built on :mod:`~gyrojax.inference.campaign`,
:mod:`~gyrojax.inference.identifiability`, :mod:`~gyrojax.inference.solver`, :mod:`~gyrojax.inference.noisefit` and
:mod:`~gyrojax.inference.result`) or the triad fit of hand-moved IMUs (:mod:`~gyrojax.inference.triad`,
:mod:`~gyrojax.inference.triad_result`); both results save in the format of :mod:`~gyrojax.inference.formats`.
Beside them: the least-squares core (:mod:`~gyrojax.inference.lstsq`), fits of records too long for memory
(:mod:`~gyrojax.inference.bigfit`), and the diagnosis of missing effects (:mod:`~gyrojax.inference.diagnose`)."""
