"""Signatures of the development of a curve: ``signatures`` (signature, log-signature, rho^n, sigma_*^n,
sigma_L^n, sim^n; iisignature or numpy) and ``tensor`` (the truncated tensor algebra, Lyndon words: the face of
``algebra`` and ``lyndon``)."""
