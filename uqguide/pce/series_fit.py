"""A series output's adaptive PCE (:func:`fit_series`): principal components, their sparse fits
(each its own search up to :data:`HYBRID_WORK`, else a shared path for all but the first
:data:`LEAD`), and the number kept (:func:`uqguide.pce.pca.choose`).

Why the hybrid, with the measurements that set it:
docs/methods.md#time-series-in-the-adaptive-pce.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from . import basis
from .germ import Germ
from .loo import loo_residuals
from .pca import Components, candidates, choose, decompose
from .sparse_regression import ColumnsFit, candidate_sets, fit_columns

log = logging.getLogger(__name__)

#: One component's search work (multiply-adds) up to which every component is searched column
#: by column (the 500-run oscillator's is 4e8).
HYBRID_WORK = 2e8
#: Components searched column by column above :data:`HYBRID_WORK`, the largest first (each
#: costs about what the joint path for all the others does).
LEAD = 1
#: Work (multiply-adds) above which even the leading components take the joint path: about a
#: CPU-minute of least-angle steps.
COLUMNWISE_WORK = 1e11


@dataclass
class SeriesFit:
    """The kept components and their expansions (``r`` columns); ``rule``: how the count was
    chosen, ``"moments"``, ``"n_components"`` or ``"variance_fraction"``."""

    components: Components
    fit: ColumnsFit
    rule: str


def _keep(fit: ColumnsFit, r: int) -> ColumnsFit:
    """The first ``r`` columns of a joint fit, on the terms they use."""
    core = fit.core[:, :r]
    used = np.flatnonzero(np.any(core != 0.0, axis=1))
    used = np.union1d([0], used)
    return ColumnsFit(fit.alpha[used], core[used], fit.degree[:r], fit.q[:r], fit.loo[:r],
                      fit.n_terms[:r], fit.n_candidates)


def _columnwise_work(d: int, n: int, r: int, degree_min: int, degree_max: int | None,
                     q: float | None) -> float:
    _, sets = candidate_sets(d, n, degree_min, degree_max, q)
    return float(sum(r * n * cs.cols.size * min(n, cs.cols.size) for cs in sets))


def _loo_residuals(germ: Germ, xi: np.ndarray, y: np.ndarray, fit: ColumnsFit) -> np.ndarray:
    """Leave-one-out residuals ``(N, r)`` of each column's OLS fit on its own terms."""
    return loo_residuals(basis.evaluate(germ, fit.alpha, xi), fit.core, y)


def _merge(a: ColumnsFit, b: ColumnsFit) -> ColumnsFit:
    """The columns of ``a`` then those of ``b``, on the union of their terms (graded, constant
    first)."""
    alpha = basis.graded(np.unique(np.vstack([a.alpha, b.alpha]), axis=0))
    lookup = basis.index_lookup(alpha)
    core = np.zeros((alpha.shape[0], a.core.shape[1] + b.core.shape[1]))
    for fit, lo in ((a, 0), (b, a.core.shape[1])):
        rows = [lookup[tuple(int(v) for v in row)] for row in fit.alpha]
        core[rows, lo:lo + fit.core.shape[1]] = fit.core
    return ColumnsFit(alpha, core, np.concatenate([a.degree, b.degree]),
                      np.concatenate([a.q, b.q]), np.concatenate([a.loo, b.loo]),
                      np.concatenate([a.n_terms, b.n_terms]),
                      max(a.n_candidates, b.n_candidates))


def _fit_components(germ: Germ, xi: np.ndarray, scores: np.ndarray,
                    degree_min: int, degree_max: int | None, q: float | None,
                    loo: bool) -> tuple[ColumnsFit, np.ndarray | None]:
    """Expansions of the components' ``scores (N, r)`` (column by column where cheap, else the
    hybrid or the joint path), and their leave-one-out residuals if ``loo``."""
    n, r = scores.shape
    one = _columnwise_work(germ.dim, n, 1, degree_min, degree_max, q)
    if one <= HYBRID_WORK:
        fit = fit_columns(germ, xi, scores, degree_min=degree_min, degree_max=degree_max,
                          q=q)
        return fit, (_loo_residuals(germ, xi, scores, fit) if loo else None)
    lead = min(LEAD, r) if LEAD * one <= COLUMNWISE_WORK else 0
    parts, resid = [], []
    if lead:
        fit = fit_columns(germ, xi, scores[:, :lead], degree_min=degree_min,
                          degree_max=degree_max, q=q)
        parts.append(fit)
        if loo:
            resid.append(_loo_residuals(germ, xi, scores[:, :lead], fit))
    if lead < r:
        joint = fit_columns(germ, xi, scores[:, lead:], degree_min=degree_min,
                            degree_max=degree_max, q=q, joint=True)
        parts.append(joint)
        if loo and joint.loo_resid is not None:
            resid.append(joint.loo_resid)
    fit = parts[0] if len(parts) == 1 else _merge(*parts)
    log.debug("series: %d leading component(s) searched column by column, %d on the joint "
              "path", lead, r - lead)
    return fit, (np.hstack(resid) if loo else None)


def fit_series(germ: Germ, xi: np.ndarray, y: np.ndarray, *, degree_min: int = 1,
               degree_max: int | None = None, q: float | None = None,
               variance_fraction: float | None = None, n_components: int | None = None
               ) -> SeriesFit:
    """Principal components of ``y (N, m)`` and their sparse PCEs.

    Other arguments as :func:`uqguide.pce.sparse_regression.fit_columns`; keep the fewest
    components holding ``variance_fraction`` of the scaled variance, or ``n_components``.
    """
    # One BLAS thread for the whole fit, the SVD included (docs/pce.md#one-blas-thread).
    with threadpool_limits(limits=1, user_api="blas"):
        dec = decompose(y)
        if n_components is not None:
            r, rule = min(n_components, dec.size), "n_components"
        elif variance_fraction is not None:
            r, rule = dec.count_for_fraction(variance_fraction), "variance_fraction"
        else:
            r, rule = candidates(dec, y.shape[0]), "moments"
        comps = dec.components(r)
        if r == 0:
            empty = ColumnsFit(np.zeros((1, germ.dim), dtype=int), np.zeros((1, 0)),
                               np.zeros(0, dtype=int), np.zeros(0), np.zeros(0),
                               np.zeros(0, dtype=int))
            return SeriesFit(comps, empty, rule)
        fit, loo_resid = _fit_components(germ, xi, comps.scores, degree_min, degree_max, q,
                                         loo=rule == "moments")
        if loo_resid is None:
            return SeriesFit(comps, fit, rule)
        kept = choose(dec, y, loo_resid)
        log.debug("series: %d of %d candidate components kept by the moments' rule", kept, r)
        return SeriesFit(dec.components(kept), _keep(fit, kept), rule)
