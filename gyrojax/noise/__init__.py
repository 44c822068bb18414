"""Random drift. The one noise description, :class:`~gyrojax.noise.spec.NoiseSpec` (IEEE 952 units, its Allan
variance, mean variance, whitening parameters, truth-file dict and saved form), and the one simulator
(:mod:`~gyrojax.noise.processes`); whitening and the fits' white + Gauss–Markov / AR noise models
(:mod:`~gyrojax.noise.whiten`, on the jitted Kalman filter and REML of :mod:`~gyrojax.noise.reml`); Allan variance and
the IEEE 952 fit on arrays (:mod:`~gyrojax.noise.allan`); Haar wavelet variances (:mod:`~gyrojax.noise.wavelet`);
GMWM / AVLR fits (:mod:`~gyrojax.noise.gmwm`, their latent-process models :mod:`~gyrojax.noise.gmwm_model`) and
what a fitted model tells (:mod:`~gyrojax.noise.readoff`); AR/ARMA analysis of drift series
(:mod:`~gyrojax.noise.randomdrift`)."""
