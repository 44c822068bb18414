"""Random drift: the noise description and its processes (:mod:`~gyrojax.noise.processes`), whitening and REML
noise models for the fits (:mod:`~gyrojax.noise.whiten`; the jitted white + Gauss–Markov REML with exact
derivatives in :mod:`~gyrojax.noise.reml`), Allan variance and the IEEE 952 fit (:mod:`~gyrojax.noise.allan`),
Haar wavelet variance of latent processes (:mod:`~gyrojax.noise.wavelet`), GMWM / AVLR noise models with their
uncertainty and adequacy (:mod:`~gyrojax.noise.gmwm`), AR/ARMA analysis of drift series
(:mod:`~gyrojax.noise.randomdrift`)."""
