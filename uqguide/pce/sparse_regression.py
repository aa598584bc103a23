"""Degree-adaptive sparse regression of output columns (adaptive PCE, spec 4.4).

For each output column (a scalar component or a principal-component score) and each degree
``p = degree_min .. degree_max``: the candidate basis is the hyperbolic set ``||alpha||_q <= p``,
hybrid LARS (:mod:`uqguide.pce.lars`) picks its best sparse subset by corrected leave-one-out
error, and the degree of least error is kept. Raising the degree stops once the target error is
met or the error has risen at two degrees in a row (Blatman & Sudret 2011, section 5.2).

The candidate sets are nested in the degree, so the basis is evaluated once at ``degree_max``
and each degree's candidates are a column subset.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from . import basis
from .germ import Germ
from .lars import SparseFit, hybrid_lars
from .pca import constant_columns

log = logging.getLogger(__name__)

#: Largest candidate basis evaluated (terms); higher degrees are skipped with a log message.
MAX_CANDIDATES = 20_000


@dataclass
class ColumnsFit:
    """Sparse expansions of several columns on one shared multi-index set.

    Attributes
    ----------
    alpha : ndarray of int, shape (P, d)
        Union of the columns' retained terms, constant first.
    core : ndarray, shape (P, r)
        Coefficients per column (zero where a column does not use a term).
    degree : ndarray of int, shape (r,)
        Selected truncation degree per column.
    loo : ndarray, shape (r,)
        Corrected leave-one-out error per column (relative to its variance; 0 for a constant).
    n_terms : ndarray of int, shape (r,)
        Retained terms per column (constant included).
    """

    alpha: np.ndarray
    core: np.ndarray
    degree: np.ndarray
    loo: np.ndarray
    n_terms: np.ndarray


def q_norms(alpha: np.ndarray, q: float) -> np.ndarray:
    """``||alpha||_q`` of each multi-index ``(P,)``."""
    return (alpha.astype(float) ** q).sum(axis=1) ** (1.0 / q)


def fit_columns(germ: Germ, xi: np.ndarray, y: np.ndarray, *, degree_min: int, degree_max: int,
                q: float, target_loo: float) -> ColumnsFit:
    """Adaptive sparse PCE of every column of ``y``.

    Parameters
    ----------
    germ : Germ
    xi : ndarray, shape (N, d)
        Design points (germ coordinates).
    y : ndarray, shape (N, r)
        Output columns at the design points.
    degree_min, degree_max : int
        Range of truncation degrees tried.
    q : float
        q-norm of the hyperbolic truncation.
    target_loo : float
        Corrected LOO error at which raising the degree stops.
    """
    d = germ.dim
    cand = basis.hyperbolic_indices(d, degree_max, q)
    norms = q_norms(cand, q)
    top = degree_max
    while cand.shape[0] > MAX_CANDIDATES and top > degree_min:
        top -= 1
        cand = cand[norms <= top * (1 + 1e-12)]
        norms = norms[norms <= top * (1 + 1e-12)]
    if top < degree_max:
        log.warning("adaptive PCE: candidate basis capped at degree %d (%d terms) of the "
                    "requested %d", top, cand.shape[0], degree_max)
    psi = basis.evaluate(germ, cand, xi)
    r = y.shape[1]
    fits, degree, loo = [], np.zeros(r, dtype=int), np.zeros(r)
    constant = constant_columns(y)
    for c in range(r):
        if constant[c]:
            # All runs agree: the constant, exactly (no variance to regress on).
            fits.append(SparseFit(np.zeros(1, dtype=int), y[:1, c].copy(), 0.0))
            continue
        best, best_p, history = None, degree_min, []
        for p in range(degree_min, top + 1):
            cols = np.flatnonzero(norms <= p * (1 + 1e-12))
            fit = hybrid_lars(psi[:, cols], y[:, c])
            fit.terms = cols[fit.terms]
            history.append(fit.loo)
            if best is None or fit.loo < best.loo:
                best, best_p = fit, p
            if fit.loo <= target_loo:
                break
            if len(history) >= 3 and history[-1] > history[-2] > history[-3]:
                break
        fits.append(best)
        degree[c], loo[c] = best_p, best.loo
    used = np.unique(np.concatenate([[0]] + [f.terms for f in fits]))
    pos = {t: i for i, t in enumerate(used)}
    core = np.zeros((used.size, r))
    for c, f in enumerate(fits):
        core[[pos[t] for t in f.terms], c] = f.coef
    n_terms = np.array([f.terms.size for f in fits], dtype=int)
    return ColumnsFit(cand[used], core, degree, loo, n_terms)
