"""The cross term of a regression PCE's index error, measured on runs it did not fit: an
index moves with the surrogate's error ``e`` by ``-2 E[g e] / V`` to first order (``g`` the
index's direction), which the validation runs estimate with a stratified mean's Student
interval (without them :func:`uqguide.pce.sobol_indices.widen_by_truncation` bounds it from the
LOO error). The derivation and the measured coverage: docs/pce.md#the-index-error-identity.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from . import basis
from .expansion import Expansion
from .sobol_indices import ratios, term_sets
from .validation import LEVEL, stratified_se
from .validation_design import ValidationDesign

_CHUNK_FLOATS = 2**22  # runs x columns x index sets held at once (32 MB)


@dataclass
class ValidationRuns:
    """Runs where a surrogate's error is measured: germ points ``xi (n, d)``, model values
    ``y (n, m)`` (the surrogate minus the error there) and their design (weights, strata)."""

    xi: np.ndarray
    y: np.ndarray
    design: ValidationDesign


def cross_term_band(exp: Expansion, runs: ValidationRuns, groups: Sequence[Sequence[int]] = ()
                    ) -> np.ndarray:
    """``(2, m, S)``: the indices corrected by the cross term of the surrogate's error ``e``,
    ``S - 2 E[g e] / V`` with ``g = P f - S (f - mean)`` the index's direction (``P`` the
    projection on its terms), ``E[g e]`` the validation runs' weighted mean with its 95%
    Student interval (:func:`uqguide.pce.validation.stratified_se`). The error's own share is
    left to :func:`truncation_bounds` (docs/pce.md#the-index-error-identity)."""
    from scipy.stats import t as student

    sets = term_sets(exp.alpha, groups)
    n, m, n_sets = runs.xi.shape[0], exp.n_columns, sets.shape[1]
    coef = exp.coef
    des = runs.design
    out = np.full((2, m, n_sets), np.nan)
    step = max(1, _CHUNK_FLOATS // max(1, n * n_sets))
    with threadpool_limits(limits=1, user_api="blas"):
        psi = basis.evaluate(exp.germ, exp.alpha, runs.xi)
        for a in range(0, m, step):
            cols = slice(a, min(m, a + step))
            c = coef[:, cols]
            var = (c[1:] ** 2).sum(axis=0)                           # (mb,)
            point = ratios(c, sets)                                  # (mb, S)
            centred = psi[:, 1:] @ c[1:]                             # (n, mb)
            err = centred + c[0] - runs.y.reshape(n, -1)[:, cols]    # e = surrogate - model
            part = np.stack([psi[:, 1:] @ (c[1:] * sets[1:, k, None])
                             for k in range(n_sets)], axis=-1)       # (n, mb, S)
            infl = ((part - point * centred[..., None]) * err[..., None]).reshape(n, -1)
            se, df = stratified_se(infl, des.weight, des.stratum, des.share, des.pool)
            with np.errstate(invalid="ignore"):
                half = student.ppf((1 + LEVEL) / 2, np.maximum(df, 1.0)) * se
            shape = point.shape
            with np.errstate(invalid="ignore", divide="ignore"):
                centre = point - 2 * (des.weight @ infl).reshape(shape) / var[:, None]
                half = 2 * half.reshape(shape) / var[:, None]
            out[:, cols] = np.stack([centre - half, centre + half])
    return out
