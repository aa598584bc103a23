"""Polynomial-chaos building blocks, above ``models``, shared by the PCE methods
(:mod:`uqguide.methods.pce_tensor`, ``pce_smolyak``, ``pce_adaptive``), one concept per module:
the expansion's variables, polynomials and designs; sparse regression by corrected LOO and series
through principal components; statistics, indices and events; the validated statistics
(``credibility`` and the rules it runs). Arrays are ``(n, d)`` (chaospy's ``(d, n)`` only inside
:mod:`uqguide.pce.quadrature`).

How the pieces work: docs/methods.md#inside-the-pce-methods and docs/pce.md.
"""
