"""Corrected leave-one-out errors of one growing path for several output columns at once.

:class:`uqguide.pce.lars.LooPath` for ``y (N, r)``: the QR factorisation of the path's columns,
the hat diagonal and the factor ``T(P, N)`` depend only on the columns, so they are computed once
and shared; only the residuals (one cumulative sum per column) are per column. Scoring a path for
the ``r`` principal components of a series then costs one QR and ``r`` cheap residual updates,
not ``r`` QRs. Each column also keeps the leave-one-out residuals of its best nested set, from
which the surrogate's own error of the series' moments is estimated
(:mod:`uqguide.pce.pca_rank`).
"""

from __future__ import annotations

import numpy as np

from .lars import GrowingPath, SparseFit, grown_factor, orthogonal_block



class MultiLooPath(GrowingPath):
    """Corrected LOO errors ``(K, r)`` of the nested sets of one path (constant first).

    Parameters
    ----------
    psi : ndarray, shape (N, P)
        Candidate basis at the design points.
    y : ndarray, shape (N, r)
        Output columns at the design points (none constant).
    """

    def __init__(self, psi: np.ndarray, y: np.ndarray) -> None:
        n, r = y.shape
        self.psi, self.y, self.n, self.r = psi, y, n, r
        self.var = y.var(axis=0, ddof=1)
        self.fed = 0
        self.cols = np.zeros(0, dtype=int)
        self.loo = np.zeros((0, r))
        self._q = np.zeros((n, 0))
        self._r = np.zeros((0, 0))
        self._rinv = np.zeros((0, 0))
        self._qty = np.zeros((0, r))
        self._resid = y.astype(float).copy()
        self._hat = np.zeros(n)
        self._frob = 0.0
        self._undefined = False
        #: Per column: least error so far, its set size, its leave-one-out residuals (N,).
        self.best_loo = np.full(r, np.inf)
        self.best_size = np.zeros(r, dtype=int)
        self.best_resid = np.zeros((n, r))

    def _extend(self, new: np.ndarray) -> None:
        q, n, m = self._q, self.n, self.cols.size
        block = orthogonal_block(self.psi, q, new)
        if block is None:
            return
        new, qb, rb, c = block
        k = new.size
        hat = self._hat[:, None] + np.cumsum(qb * qb, axis=1)
        r, rinv, frob = grown_factor(self._r, self._rinv, self._frob, c, rb)
        p = m + 1 + np.arange(k)
        undefined = (hat >= 1.0 - 1e-10).any(axis=0) | (p >= n)
        undefined = np.maximum.accumulate(undefined | self._undefined)
        qty = qb.T @ self._resid  # (k, r)
        loo = np.empty((k, self.r))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            lev = 1.0 / (1.0 - hat)
            base = n / (n - p) * (1.0 + frob) / n
            for j in range(self.r):
                resid = np.cumsum(qb * -qty[:, j], axis=1)
                resid += self._resid[:, j, None]
                e = resid * lev
                loo[:, j] = np.einsum("ik,ik->k", e, e) * (base / self.var[j])
                bad = undefined | ~np.isfinite(loo[:, j])
                loo[bad, j] = np.inf
                i = int(np.argmin(loo[:, j]))
                if loo[i, j] < self.best_loo[j]:
                    self.best_loo[j], self.best_size[j] = loo[i, j], m + 1 + i
                    self.best_resid[:, j] = e[:, i]
                self._resid[:, j] = resid[:, -1]
        self._q = np.hstack([q, qb])
        self._r, self._rinv = r, rinv
        self._qty = np.vstack([self._qty, qty])
        self._hat = hat[:, -1].copy()
        self._frob, self._undefined = float(frob[-1]), bool(undefined[-1])
        self.cols = np.concatenate([self.cols, new])
        self.loo = np.vstack([self.loo, loo])

    def fit(self, j: int) -> SparseFit:
        """Column ``j``'s best nested set: its OLS fit and score."""
        from scipy.linalg import solve_triangular

        k = int(self.best_size[j])
        coef = solve_triangular(self._r[:k, :k], self._qty[:k, j], lower=False,
                                check_finite=False)
        return SparseFit(self.cols[:k].copy(), coef, float(self.best_loo[j]))


def score_path(psi: np.ndarray, y: np.ndarray, order: np.ndarray, patience: int
               ) -> MultiLooPath:
    """Score the nested sets ``{0} + order[:k]`` for every column of ``y``, in growing blocks,
    until the path has been scored ``patience`` terms past twice every column's best set (the
    factor ``N / (N - P)`` only grows from there), or to its end."""
    n = y.shape[0]
    full = np.concatenate([[0], order[: max(0, n - 2)]]).astype(int)
    path = MultiLooPath(psi, y)
    length = min(full.size, 4 * patience + 1)
    while True:
        path.feed(full[:length])
        want = 2 * int(path.best_size.max()) + patience
        if length >= full.size or want < path.cols.size:
            return path
        length = min(full.size, max(2 * length, want + 1))
