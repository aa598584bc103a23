"""Polynomial-chaos building blocks, above ``models``.

The pieces the PCE methods share (uq-methods.md sections 4.2-4.5).

One concept per module, as a pipeline of small functions::

    germ        independent standardised variables and their maps to the physical inputs
    basis       multi-index sets (total degree, hyperbolic, tensor); orthonormal polynomials
    quadrature  1-D rules, tensor grids, Smolyak combinations
    projection  pseudo-spectral (tensor / Smolyak) projection -> coefficients
    design      deterministic unit-cube designs (Sobol', LHS) for regression
    lars        hybrid LARS with corrected leave-one-out error
    sparse_regression  degree-adaptive sparse fits of many output columns
    pca         principal components of time-series outputs
    expansion   a fitted expansion of one output
    moments     mean / covariance / skewness / kurtosis / Sobol' indices from an expansion
    sobol_indices  first, total and group indices at every step, with 95% intervals
    derived     outputs computed from other outputs' surrogates (miss distances)
    outputs     model outputs -> columns, expansions -> an Estimate's statistics

The methods themselves are :mod:`uqguide.methods.pce_tensor`, :mod:`uqguide.methods.pce_smolyak`
and :mod:`uqguide.methods.pce_adaptive`. chaospy's ``(d, n)`` arrays appear only inside
:mod:`uqguide.pce.quadrature`; everything else is ``(n, d)``.
"""
