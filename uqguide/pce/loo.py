"""Corrected leave-one-out errors of least-squares fits: of nested sets along a path, at the runs.

:class:`LooPath` scores the nested sets of a growing path (column 0, the constant, first) for one
output column, its QR extended block by block, so scoring a whole path costs about one QR of its
largest set; :class:`MultiLooPath` does so for several columns at once (the QR, hat diagonal and
factor shared). :func:`corrected_loo_path` and :func:`score_path` feed a path in growing blocks
until the error can only rise. :func:`loo_values` gives a fitted expansion's leave-one-out values
at its own fit runs, which floor the validation runs' variance (:class:`FitRuns`,
:class:`FitFloor`).

The error formula and its correction factor:
docs/methods.md#sparse-regression-the-candidate-grid-lars-and-leave-one-out; the fit runs'
values: docs/methods.md#validation-corrected-moments-no-usable-surrogate-the-kept-surrogate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import basis
from .expansion import Expansion
from .lars import _DEGENERATE, LarsPath


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
    loo_se : float
        Its standard error: that of the mean of the squared leave-one-out residuals, times the
        same factors (0 where unknown).
    """

    terms: np.ndarray
    coef: np.ndarray
    loo: float
    loo_se: float = 0.0


def orthogonal_block(psi: np.ndarray, q: np.ndarray, new: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """Columns ``new`` of ``psi`` orthogonalised against ``q``'s orthonormal columns (classical
    Gram-Schmidt, twice) and factorised by Householder QR, dropping those (nearly) in the span
    of the kept ones: ``(new, Qb, Rb, C)`` with ``psi[:, new] = q C + Qb Rb``; None when none
    adds anything."""
    from scipy.linalg import qr  # here: `uqguide validate` starts without it

    while True:
        b = psi[:, new]
        norms = np.linalg.norm(b, axis=0)
        c = q.T @ b
        b = b - q @ c
        c2 = q.T @ b
        b -= q @ c2
        c += c2
        qb, rb = qr(b, mode="economic", check_finite=False)
        bad = np.abs(np.diag(rb)) <= _DEGENERATE * norms
        if not bad.any():
            return new, qb, rb, c
        new = new[~bad]
        if new.size == 0:
            return None


def grown_factor(r: np.ndarray, rinv: np.ndarray, frob: float, c: np.ndarray, rb: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``R`` and ``R^-1`` grown by a block (:func:`orthogonal_block`'s ``C``, ``Rb``), and
    ``trace((A^T A)^-1) = ||R^-1||_F^2`` of each nested set the block adds (``(k,)``, from
    ``frob``, the kept set's): the new columns of ``R^-1`` are ``[-R^-1 C Rb^-1; Rb^-1]``."""
    from scipy.linalg import solve_triangular

    m, k = r.shape[0], rb.shape[0]
    rbinv = solve_triangular(rb, np.eye(k), lower=False, check_finite=False)
    top = -rinv @ (c @ rbinv)
    frobs = frob + np.cumsum((top * top).sum(axis=0) + (rbinv * rbinv).sum(axis=0))
    r_new = np.zeros((m + k, m + k))
    r_new[:m, :m], r_new[:m, m:], r_new[m:, m:] = r, c, rb
    rinv_new = np.zeros((m + k, m + k))
    rinv_new[:m, :m], rinv_new[:m, m:], rinv_new[m:, m:] = rinv, top, rbinv
    return r_new, rinv_new, frobs


class GrowingPath:
    """A path scored as it grows: :meth:`feed` hands the entries not yet seen to ``_extend``
    (:class:`LooPath`, :class:`MultiLooPath`)."""

    fed: int

    def feed(self, path: np.ndarray) -> None:
        """Score ``path``'s entries past those already fed (``path`` extends the earlier one)."""
        new = np.asarray(path[self.fed:], dtype=int)
        self.fed = max(self.fed, len(path))
        if new.size:
            self._extend(new)

    def _extend(self, new: np.ndarray) -> None:
        raise NotImplementedError


class LooPath(GrowingPath):
    """Corrected LOO errors of the nested sets of a growing path (column 0, the constant,
    first), its QR extended block by block as the path grows.

    A block of new columns is orthogonalised against the kept ones (classical Gram-Schmidt,
    twice) and factorised by Householder QR; the nested sets' OLS residuals (cumulative sums of
    ``Q`` columns times ``Q^T y``), hat diagonals (cumulative sums of ``Q^2``) and
    ``trace((A^T A)^-1) = ||R^-1||_F^2`` (cumulative column norms of ``R^-1``, whose new
    columns are ``[-R^-1 C Rb^-1; Rb^-1]``) follow in BLAS-3 work on the block only, so a path
    scored again after LARS has gone on costs only its new part. A column (nearly) in the span
    of the earlier ones is dropped.

    Parameters
    ----------
    psi : ndarray, shape (N, P)
        Candidate basis at the design points.
    y : ndarray, shape (N,)
        Output at the design points (non-constant).
    """

    def __init__(self, psi: np.ndarray, y: np.ndarray) -> None:
        n = y.size
        self.psi, self.y, self.n = psi, y, n
        self.var = float(y.var(ddof=1))
        self.fed = 0  # entries of the path consumed (kept or dropped)
        self.cols = np.zeros(0, dtype=int)  # kept columns
        self.loo = np.zeros(0)  # score of each nested set of the kept columns
        self.se = np.zeros(0)  # its standard error
        self._q = np.zeros((n, 0))
        self._r = np.zeros((0, 0))
        self._rinv = np.zeros((0, 0))
        self._qty = np.zeros(0)
        self._resid = y.astype(float).copy()
        self._hat = np.zeros(n)
        self._frob = 0.0
        self._undefined = False

    def _extend(self, new: np.ndarray) -> None:
        q, n, m = self._q, self.n, self.cols.size
        block = orthogonal_block(self.psi, q, new)
        if block is None:
            return
        new, qb, rb, c = block
        k = new.size
        qty = qb.T @ self._resid  # = Qb^T y: Qb is orthogonal to the kept columns
        resid = self._resid[:, None] - np.cumsum(qb * qty, axis=1)
        hat = self._hat[:, None] + np.cumsum(qb * qb, axis=1)
        r, rinv, frob = grown_factor(self._r, self._rinv, self._frob, c, rb)
        p = m + 1 + np.arange(k)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            e2 = (resid / (1.0 - hat)) ** 2
            factor = n / (n - p) * (1.0 + frob) / self.var
            loo = np.mean(e2, axis=0) * factor
            se = np.std(e2, axis=0) / np.sqrt(n) * factor
        undefined = (hat >= 1.0 - 1e-10).any(axis=0) | (p >= n) | ~np.isfinite(loo)
        undefined = np.maximum.accumulate(undefined | self._undefined)  # a leverage of 1 stays
        loo[undefined] = np.inf
        self._q = np.hstack([q, qb])
        self._r, self._rinv = r, rinv
        self._qty = np.concatenate([self._qty, qty])
        self._resid, self._hat = resid[:, -1].copy(), hat[:, -1].copy()
        self._frob, self._undefined = float(frob[-1]), bool(undefined[-1])
        self.cols = np.concatenate([self.cols, new])
        self.loo = np.concatenate([self.loo, loo])
        self.se = np.concatenate([self.se, se])

    def fit(self, k: int) -> SparseFit:
        """The OLS fit of the first ``k`` kept columns, with its score."""
        from scipy.linalg import solve_triangular

        coef = solve_triangular(self._r[:k, :k], self._qty[:k], lower=False,
                                check_finite=False)
        score = float(self.loo[k - 1]) if np.isfinite(self.loo[k - 1]) else float(np.inf)
        se = float(self.se[k - 1]) if np.isfinite(score) else 0.0
        return SparseFit(self.cols[:k].copy(), coef, score, se)


def corrected_loo_path(psi: np.ndarray, y: np.ndarray, order: np.ndarray | LarsPath,
                       patience: int | None = None, hint: int = 0,
                       state: LooPath | None = None) -> SparseFit:
    """Score the nested sets ``{0} + order[:k]`` by corrected LOO; the best one refitted.

    Parameters
    ----------
    psi : ndarray, shape (N, P_cand)
        Candidate basis at the design points; column 0 is the constant.
    y : ndarray, shape (N,)
    order : ndarray of int, or LarsPath
        Candidate columns in order of entry; a :class:`LarsPath` is advanced only as far as
        the scoring reads it (with ``patience``, the steps past ``2 P_best + patience`` are
        never taken: on a kinked series' components, 150 runs, they were half of all LARS
        steps). The result is the same as for the path's whole order.
    patience : int, optional
        Score the path in growing blocks, and stop once it has been scored past
        ``2 P_best + patience`` terms (``P_best`` the best set's size): the error's factor
        ``N / (N - P)`` only grows from there, and scoring the long tail of a path costs
        ``O(N P^2)``. None scores the whole path.
    hint : int
        A guess of the best set's size (a neighbouring degree's), so that the first block
        is long enough.
    state : LooPath, optional
        The scores of a shorter path that ``order`` extends (same ``psi`` and ``y``): only
        the new part is scored. It is advanced in place.

    Returns
    -------
    SparseFit
        The nested set of least corrected LOO error, its OLS coefficients and its error.
    """
    n = y.size
    # The state has the same variance already (the same formula on the same y).
    var = state.var if state is not None else (y.var(ddof=1) if n > 1 else 0.0)
    if var <= 0.0:
        return SparseFit(np.zeros(1, dtype=int), np.array([y.mean()]), 0.0)
    limit = max(0, n - 2)

    def head(k: int) -> np.ndarray:
        """``[0] + order[:limit]`` up to its first ``k`` entries (fewer where it ends)."""
        k = min(k - 1, limit)
        part = order.order(k) if isinstance(order, LarsPath) else order[:k]
        return np.concatenate([[0], part[:k]]).astype(int)

    path = LooPath(psi, y) if state is None else state
    full = head(limit + 1 if patience is None
                else max(4 * patience, 2 * hint + patience, path.fed) + 1)
    while True:
        path.feed(full)
        best = int(np.argmin(path.loo))
        if patience is None:
            break
        want = 2 * (best + 1) + patience
        if want < path.cols.size:
            break
        longer = head(max(2 * full.size, want + 1))
        if longer.size == full.size:  # the whole order is scored
            break
        full = longer
    return path.fit(best + 1)


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


def loo_values(expansion: Expansion, xi: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Leave-one-out surrogate values ``(N, m)`` at the fit runs.

    Parameters
    ----------
    expansion : Expansion
        The fitted expansion; each column of its core is an OLS fit on its own non-zero terms.
    xi : ndarray, shape (N, d)
        The fit runs' germ points.
    targets : ndarray, shape (N, r')
        What the core's columns were fitted to (a scalar's components, a series' scores); a
        core column beyond them (a series' mean row) is not fitted and has no residual.

    Returns
    -------
    ndarray, shape (N, m)
        ``expansion.evaluate(xi)`` with every fitted column's value replaced by its
        leave-one-out prediction. A run of leverage 1 (its own term) keeps its fitted value.
    """
    from scipy.linalg import qr  # here: as orthogonal_block's

    psi = basis.evaluate(expansion.germ, expansion.alpha, xi)
    fitted = psi @ expansion.core
    shift = np.zeros_like(fitted)
    for j in range(min(targets.shape[1], expansion.core.shape[1])):
        terms = np.union1d([0], np.flatnonzero(expansion.core[:, j]))
        if terms.size >= xi.shape[0]:
            continue
        qm, _ = qr(psi[:, terms], mode="economic", check_finite=False)
        resid = targets[:, j] - fitted[:, j]
        hat = np.einsum("ij,ij->i", qm, qm)
        with np.errstate(divide="ignore", invalid="ignore"):
            # fitted - loo prediction = r h / (1 - h)
            move = resid * hat / (1.0 - hat)
        shift[:, j] = np.where(np.isfinite(move) & (hat < 1.0 - 1e-10), move, 0.0)
    return expansion.mixed(fitted - shift)


@dataclass(frozen=True)
class FitRuns:
    """The fit runs as a second sample of the model-minus-surrogate differences.

    Attributes
    ----------
    y : ndarray, shape (N, ...)
        The model's values at the successful fit runs.
    s_loo : ndarray, shape (N, ...)
        The surrogate's leave-one-out values there (:func:`loo_values`).
    stratum : ndarray of int, shape (N,)
        Each run's stratum of the validation design.
    ratio : ndarray, shape (N,)
        Each run's importance ratio to the validation pool's density.
    input_share : ndarray, shape (K,)
        Each stratum's probability under the input distribution.
    """

    y: np.ndarray
    s_loo: np.ndarray
    stratum: np.ndarray
    ratio: np.ndarray
    input_share: np.ndarray


@dataclass(frozen=True)
class FitFloor:
    """A statistic's per-run values at the fit runs (:func:`stratified_se`'s floor).

    Attributes
    ----------
    influence : ndarray, shape (N, m)
        The values, from the surrogate's leave-one-out predictions at the fit runs.
    stratum : ndarray of int, shape (N,)
        Each fit run's stratum of the validation design.
    ratio : ndarray, shape (N,)
        Each fit run's importance ratio ``1 / q(u)`` to the validation pool's density.
    input_share : ndarray, shape (K,)
        Each stratum's probability under the input distribution (the fit runs' own).
    """

    influence: np.ndarray
    stratum: np.ndarray
    ratio: np.ndarray
    input_share: np.ndarray

    def variance(self, k: int, share: float) -> np.ndarray:
        """``Var_q(r f | k)`` from the fit runs in stratum ``k`` (``share``: its pool
        probability ``Q_k``); 0 with fewer than two of them.

        The fit runs are draws of the input distribution ``p``: with ``c = P_k / Q_k``,
        ``E_q[r^2 f^2 | k] = c E_p[r f^2 | k]`` and ``E_q[r f | k] = c E_p[f | k]``.
        """
        rows = self.stratum == k
        nk = int(rows.sum())
        if nk < 2 or share <= 0:
            return np.zeros(self.influence.shape[1])
        f, r = self.influence[rows], self.ratio[rows]
        c = self.input_share[k] / share
        v = c * np.mean(r[:, None] * f * f, axis=0) - (c * f.mean(axis=0)) ** 2
        return np.maximum(v, 0.0) * nk / (nk - 1)
