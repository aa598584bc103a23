"""Sparse regression of a series' principal components on one shared least-angle path.

The candidate sets of :mod:`uqguide.pce.sparse_regression`, but each q-norm's path computed once
for all the components (:class:`uqguide.pce.joint_lars.JointLarsPath`) and each degree's
restriction of it scored once for all of them (:func:`uqguide.pce.joint_loo.score_path`); each
component then takes its own q-norm, degree and terms by the same selection rule
(:func:`fit_joint`). Used for a series' components other than the first where the
column-by-column search is expensive (:mod:`uqguide.pce.series_fit`), never for scalar outputs.

What is gained and given up: docs/methods.md#time-series-in-the-adaptive-pce and
docs/methods.md#sparse-regression-the-candidate-grid-lars-and-leave-one-out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from . import basis
from .germ import Germ
from .joint_lars import JointLarsPath
from .joint_loo import MultiLooPath, score_path
from .lars import LarsBasis, SparseFit
from .sparse_regression import (PATIENCE, Candidates, ColumnsFit, candidate_sets, columns_fit,
                                degree_grid)


@dataclass
class JointFit:
    """A :class:`ColumnsFit` of several columns and each column's leave-one-out residuals.

    Attributes
    ----------
    fit : ColumnsFit
    loo_resid : ndarray, shape (N, r)
        ``y_i - y_hat_(-i)`` of each column's selected expansion (the runs' values minus what
        the expansion fitted without run ``i`` predicts there).
    """

    fit: ColumnsFit
    loo_resid: np.ndarray


def fit_joint(germ: Germ, xi: np.ndarray, y: np.ndarray, *, degree_min: int = 1,
              degree_max: int | None = None, q: float | None = None) -> JointFit:
    """Sparse PCE of every column of ``y (N, r)`` on shared least-angle paths (module
    docstring). Arguments as :func:`uqguide.pce.sparse_regression.fit_columns`; no column may
    be constant (principal-component scores are not)."""
    with threadpool_limits(limits=1, user_api="blas"):  # why: fit_columns
        return _fit_joint(germ, xi, y, degree_min, degree_max, q)


def _search(cs: Candidates, lb: LarsBasis, y: np.ndarray, degree_min: int
            ) -> dict[int, MultiLooPath]:
    """One q-norm's joint path, scored at the degrees of the grid and refined around every
    column's best degree, coarse to fine."""
    n, r = y.shape
    order = JointLarsPath(lb, y).order(min(cs.cols.size - 1, n - 2))
    paths: dict[int, MultiLooPath] = {}

    def score(p: int) -> None:
        if p not in paths and degree_min <= p <= cs.top:
            path = order[cs.norms[order] <= p * (1 + 1e-12)]
            paths[p] = score_path(lb.psi, y, path, PATIENCE)

    for p in degree_grid(degree_min, cs.top):
        score(p)
    # At most five more degrees per level, not every degree between the neighbours (with
    # many components, their best degrees spread over the grid).
    for j in range(r):
        lo, hi = degree_min, cs.top
        while True:
            done = sorted(p for p in paths if lo <= p <= hi)
            i = min(range(len(done)), key=lambda k: paths[done[k]].best_loo[j])
            lo, hi = done[max(i - 1, 0)], done[min(i + 1, len(done) - 1)]
            if hi - lo <= 2 or all(p in paths for p in range(lo + 1, hi)):
                for p in range(lo + 1, hi):
                    score(p)
                break
            for p in degree_grid(lo + 1, hi - 1):
                score(p)
    return paths


def _fit_joint(germ: Germ, xi: np.ndarray, y: np.ndarray, degree_min: int,
               degree_max: int | None, q: float | None) -> JointFit:
    n, r = y.shape
    union, sets = candidate_sets(germ.dim, n, degree_min, degree_max, q)
    psi = basis.evaluate(germ, union, xi)
    # (loo, candidate count, fit in union columns, q, degree) of every scored (q, degree),
    # per column; and the LOO residuals of each.
    scored: list[list[tuple[float, int, SparseFit, float, int]]] = [[] for _ in range(r)]
    resid: list[list[np.ndarray]] = [[] for _ in range(r)]
    for cs in sets:
        lb = LarsBasis(psi[:, cs.cols])
        paths = _search(cs, lb, y, degree_min)
        for p, mp in paths.items():
            count = int(np.count_nonzero(cs.norms <= p * (1 + 1e-12)))
            for j in range(r):
                f = mp.fit(j)
                scored[j].append((f.loo, count, SparseFit(cs.cols[f.terms], f.coef, f.loo,
                                                          f.loo_se), cs.q, p))
                resid[j].append(mp.best_resid[:, j].copy())
    fits, degree, qs, loo = [], np.zeros(r, dtype=int), np.zeros(r), np.zeros(r)
    loo_resid = np.zeros((n, r))
    for j in range(r):
        least = min(s[0] for s in scored[j])
        near = [i for i, s in enumerate(scored[j]) if s[0] <= least * 1.01 or s[0] == least]
        k = min(near, key=lambda i: (scored[j][i][1], scored[j][i][0]))
        _, _, fit, qs[j], degree[j] = scored[j][k]
        fits.append(fit)
        loo[j] = fit.loo
        loo_resid[:, j] = resid[j][k]
    return JointFit(columns_fit(union, fits, degree, qs, loo), loo_resid)
