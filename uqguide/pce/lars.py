"""Least-angle regression with corrected leave-one-out selection (hybrid LARS, spec 4.4).

Blatman & Sudret (2011, J. Comput. Phys. 230(6)): least-angle regression over a candidate basis
gives a nested sequence of active sets (one more polynomial per step); each set is refitted by
ordinary least squares and scored by its corrected leave-one-out error

    ``eps_LOO = mean((r_i / (1 - h_i))^2) / var(y) * T(P, N)``,
    ``T(P, N) = N / (N - P) * (1 + trace((A^T A / N)^-1) / N)``

(``r_i`` the OLS residuals, ``h_i`` the diagonal of the hat matrix, ``A (N, P)`` the active
basis at the N design points). The set of least error is kept.

The path's OLS refits share one incremental QR factorisation (Gram-Schmidt with
re-orthogonalisation, one column per step): residuals, hat diagonal and ``trace((A^T A)^-1) =
||R^-1||_F^2`` all update in ``O(N P)`` per step, so scoring the whole path costs about one QR
of the largest set.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_DEGENERATE = 1e-10  # relative norm below which a new column adds nothing to the span
_REFRESH = 8  # LARS steps between exact recomputations of the correlations


@dataclass
class SparseFit:
    """The selected sparse expansion of one output column.

    Attributes
    ----------
    terms : ndarray of int, shape (P,)
        Columns of the candidate basis kept (0, the constant, first).
    coef : ndarray, shape (P,)
        Their OLS coefficients.
    loo : float
        Corrected leave-one-out error (relative to the output's variance).
    """

    terms: np.ndarray
    coef: np.ndarray
    loo: float


class LarsPath:
    """Least-angle regression's order of entry, advanced on demand.

    Least-angle regression (Efron et al. 2004, the "lar" variant) on the basis columns as they
    are, the constant among them and none rescaled, as OpenTURNS' LARS does: the columns of an
    orthonormal basis have about the same norm on a design, so the order of entry follows the
    size of the PCE coefficients. Two choices matter for accuracy:

    - no rescaling of the columns to unit norm on the design (as for raw regressors), which
      promotes high-degree polynomials that happen to be small at the design points;
    - the correlations are recomputed from the residual every few steps, not only updated
      (scikit-learn's ``lars_path`` only updates them, and its path drifts once the residual
      is 1e-5 of the output: on Ishigami with 200 runs it stalled at a LOO error of 2e-7 where
      this path reaches OpenTURNS' 1e-12, with the same terms).

    A step costs about one product with the ``(N, P)`` basis and a few with the inverse
    Cholesky factor of the active columns' Gram matrix, grown by one row per step. A column
    (nearly) in the span of the active ones is skipped. The path keeps its state, so asking
    for more steps continues it rather than starting again.
    """

    def __init__(self, psi: np.ndarray, y: np.ndarray) -> None:
        n, p = psi.shape
        self.y = y
        self.cap = int(min(n - 1, p))
        self.psi_t = np.ascontiguousarray(psi.T)  # one pass over memory per product
        self.norms2 = np.einsum("ij,ij->j", psi, psi)
        self.excluded = self.norms2 <= (_DEGENERATE**2) * n
        self.linv = np.zeros((max(self.cap, 1), max(self.cap, 1)))  # inverse Cholesky factor
        self.act = np.empty((max(self.cap, 1), n))  # the active columns, contiguous
        self.active: list[int] = []
        self.fitted = np.zeros(n)
        self.corr = self.psi_t @ y
        self.corr[self.excluded] = 0.0
        self.next = int(np.argmax(np.abs(self.corr)))
        self.done = self.cap < 2

    def order(self, max_steps: int) -> np.ndarray:
        """The first ``max_steps`` candidates (constant excluded) in order of entry."""
        while not self.done and len(self.active) < min(max_steps + 1, self.cap):
            self._step()
        order = np.array(self.active, dtype=int)
        return order[order != 0][:max_steps]

    def _step(self) -> None:
        psi_t, j, k = self.psi_t, self.next, len(self.active)
        b = self.act[:k] @ psi_t[j]
        row = self.linv[:k, :k] @ b
        d2 = self.norms2[j] - row @ row
        if d2 <= _DEGENERATE * self.norms2[j]:
            self.excluded[j] = True  # in the span of the active columns: adds nothing
        else:
            d = np.sqrt(d2)
            self.linv[k, :k] = -(row @ self.linv[:k, :k]) / d
            self.linv[k, k] = 1.0 / d
            self.act[k] = psi_t[j]
            self.active.append(j)
            k += 1
            if k >= self.cap:
                self.done = True
                return
        if k % _REFRESH == 0:
            # Exact again: the updates below drift by round-off.
            self.corr = psi_t @ (self.y - self.fitted)
        active = self.active
        sign = np.sign(self.corr[active])
        c_max = np.abs(self.corr[active]).max()
        lk = self.linv[:k, :k]
        w = (lk @ sign) @ lk
        scale = 1.0 / np.sqrt(sign @ w)
        u = (w * scale) @ self.act[:k]  # the equiangular direction
        a = psi_t @ u
        free = ~self.excluded
        free[active] = False
        if not free.any() or c_max <= 0.0:
            self.done = True
            return
        cf, af = self.corr[free], a[free]
        with np.errstate(divide="ignore", invalid="ignore"):
            g1 = (c_max - cf) / (scale - af)
            g2 = (c_max + cf) / (scale + af)
        floor = 1e-15 * c_max
        gam = np.minimum(np.where(g1 > floor, g1, np.inf), np.where(g2 > floor, g2, np.inf))
        i = int(np.argmin(gam))
        if not np.isfinite(gam[i]):
            self.done = True
            return
        self.fitted += gam[i] * u
        self.corr -= gam[i] * a
        self.next = int(np.flatnonzero(free)[i])


def lars_order(psi: np.ndarray, y: np.ndarray, max_steps: int) -> np.ndarray:
    """Candidate columns (excluding the constant column 0) in LARS order of entry
    (:class:`LarsPath`)."""
    return LarsPath(psi, y).order(max_steps)


def _path_scores(psi: np.ndarray, y: np.ndarray, cols: np.ndarray, var: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Corrected LOO errors of the nested sets ``cols[:1], cols[:2], ...`` (column 0 first).

    One Householder QR of the path's columns gives every nested set's OLS residuals (cumulative
    sums of ``Q`` columns times ``Q^T y``), hat diagonals (cumulative sums of ``Q^2``) and
    ``trace((A^T A)^-1) = ||R^-1||_F^2`` (cumulative column norms of ``R^-1``), in BLAS-3 work.
    Columns (nearly) in the span of the earlier ones are dropped and the QR redone.

    Returns the kept columns, their scores (``inf`` where undefined), ``R`` and ``Q^T y``.
    """
    from scipy.linalg import qr, solve_triangular  # here: `uqguide validate` starts without it

    n = y.size
    while True:
        a = psi[:, cols]
        r = qr(a, mode="r", check_finite=False)[0][: cols.size]
        diag = np.abs(np.diag(r))
        bad = diag <= _DEGENERATE * np.linalg.norm(a, axis=0)
        if not bad.any():
            break
        cols = cols[~bad]
    # Q = A R^-1 (Householder R is backward stable: Q is orthonormal to ~eps cond(A)).
    q = solve_triangular(r, a.T, trans="T", lower=False, check_finite=False).T
    qty = q.T @ y
    resid = y[:, None] - np.cumsum(q * qty, axis=1)
    hat = np.cumsum(q * q, axis=1)
    rinv = solve_triangular(r, np.eye(r.shape[0]), lower=False, check_finite=False)
    frob = np.cumsum((rinv * rinv).sum(axis=0))
    p = np.arange(1, cols.size + 1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        loo = np.mean((resid / (1.0 - hat)) ** 2, axis=0) / var * n / (n - p) * (1.0 + frob)
    undefined = (hat >= 1.0 - 1e-10).any(axis=0) | (p >= n) | ~np.isfinite(loo)
    loo[np.maximum.accumulate(undefined)] = np.inf  # a leverage of 1 stays 1 as terms join
    return cols, loo, r, qty


def corrected_loo_path(psi: np.ndarray, y: np.ndarray, order: np.ndarray,
                       patience: int | None = None, hint: int = 0) -> SparseFit:
    """Score the nested sets ``{0} + order[:k]`` by corrected LOO; the best one refitted.

    Parameters
    ----------
    psi : ndarray, shape (N, P_cand)
        Candidate basis at the design points; column 0 is the constant.
    y : ndarray, shape (N,)
    order : ndarray of int
        Candidate columns in order of entry.
    patience : int, optional
        Score the path in growing blocks, and stop once it has been scored past
        ``2 P_best + patience`` terms (``P_best`` the best set's size): the error's factor
        ``N / (N - P)`` only grows from there, and scoring the long tail of a path costs
        ``O(N P^2)``. None scores the whole path.
    hint : int
        A guess of the best set's size (a neighbouring degree's), so that the first block
        is long enough and the QR is rarely redone.
    """
    n = y.size
    var = y.var(ddof=1) if n > 1 else 0.0
    if var <= 0.0:
        return SparseFit(np.zeros(1, dtype=int), np.array([y.mean()]), 0.0)
    full = np.concatenate([[0], order[: max(0, n - 2)]]).astype(int)
    length = full.size if patience is None else min(
        full.size, max(4 * patience, 2 * hint + patience) + 1)
    while True:
        cols, loo, r, qty = _path_scores(psi, y, full[:length], var)
        best = int(np.argmin(loo))
        if length >= full.size or patience is None:
            break
        want = 2 * (best + 1) + patience
        if want < cols.size:
            break
        length = min(full.size, max(2 * length, want + 1))
    k = best + 1
    from scipy.linalg import solve_triangular

    coef = solve_triangular(r[:k, :k], qty[:k], lower=False, check_finite=False)
    score = float(loo[best]) if np.isfinite(loo[best]) else float(np.inf)
    return SparseFit(cols[:k].copy(), coef, score)


def hybrid_lars(psi: np.ndarray, y: np.ndarray) -> SparseFit:
    """LARS order of the candidates, then the corrected-LOO-best nested set (module docstring)."""
    n, p_cand = psi.shape
    order = lars_order(psi, y, max_steps=min(p_cand - 1, n - 2))
    return corrected_loo_path(psi, y, order)
