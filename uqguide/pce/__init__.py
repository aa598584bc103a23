"""Polynomial-chaos building blocks, above ``models``.

The pieces the PCE methods (:mod:`uqguide.methods.pce_tensor`, ``pce_smolyak``,
``pce_adaptive``) share, one concept per module: ``germ``, ``basis``, ``quadrature``,
``projection``, ``design`` (the expansion's variables, polynomials and designs); ``lars``,
``loo``, ``sparse_regression``, ``series_fit``, ``pca``, ``pca_rank`` (sparse regression by
corrected LOO, series through principal components); ``expansion``, ``surrogate``, ``outputs``;
``moments``, ``linearisation``, ``far_tails``, ``sobol_indices``, ``derived``, ``tails``
(statistics, indices, events); ``validation``, ``validation_design``, ``support``,
``runs_estimate``, ``point_choice`` and ``loo``'s fit-run values (the validated statistics);
``default_plan``. chaospy's ``(d, n)`` arrays appear only inside :mod:`uqguide.pce.quadrature`;
everything else is ``(n, d)``.

How the pieces work: docs/methods.md#inside-the-pce-methods.
"""
