"""Corrected leave-one-out errors of least-squares fits: along a path, and at the fit runs.

:class:`LooPath` scores the nested sets of a growing path for ``y (N,)`` or ``y (N, q)``;
:func:`score_path` feeds it until the error can only rise. :func:`loo_values` and
:func:`loo_residuals` are a fitted expansion's leave-one-out values and residuals at its own
runs; :class:`FitRuns` and :class:`FitFloor` carry them to the validation.

The error formula: docs/methods.md#sparse-regression-the-candidate-grid-lars-and-leave-one-out.
"""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from . import basis
from .expansion import Expansion
from .lars import _DEGENERATE, LarsPath


@dataclass
class SparseFit:
    """The selected sparse expansion of one output column.

    ``terms (P,)``: candidate columns kept (0, the constant, first); ``coef (P,)``: their OLS
    coefficients; ``loo``: corrected leave-one-out error relative to the output's variance;
    ``loo_se``: its standard error (0 where unknown).
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


class LooPath:
    """Corrected LOO errors of the nested sets of a growing path (column 0, the constant,
    first) of columns of ``psi (N, P)``, for ``y (N,)`` or ``y (N, q)`` (none constant).

    The QR is extended block by block (docs/pce.md#the-leave-one-out-path), so a longer path
    costs only its new part; a column (nearly) in the span is dropped.
    """

    def __init__(self, psi: np.ndarray, y: np.ndarray) -> None:
        n = y.shape[0]
        self.psi, self.y, self.n = psi, y, n
        self.joint = y.ndim == 2
        r = y.shape[1] if self.joint else 1
        self.var: np.ndarray | float = (y.var(axis=0, ddof=1) if self.joint
                                        else float(y.var(ddof=1)) if n > 1 else 0.0)
        self.fed = 0  # entries of the path consumed (kept or dropped)
        self.cols = np.zeros(0, dtype=int)  # kept columns
        self.loo = np.zeros((0, r) if self.joint else 0)  # score of each nested set
        self.se = np.zeros_like(self.loo)  # its standard error (0 for several columns)
        self._q = np.zeros((n, 0))
        self._r = np.zeros((0, 0))
        self._rinv = np.zeros((0, 0))
        self._qty = np.zeros_like(self.loo)
        self._resid = y.astype(float).copy()
        self._hat = np.zeros(n)
        self._frob = 0.0
        self._undefined = False
        #: Per column of ``y (N, q)``: least error so far, its set size (0: none finite yet)
        #: and its leave-one-out residuals.
        self.best_loo = np.full(r, np.inf)
        self.best_size = np.zeros(r, dtype=int)
        self.best_resid = np.zeros((n, r))

    def feed(self, path: np.ndarray) -> None:
        """Score ``path``'s entries past those already fed (``path`` extends the earlier one)."""
        new = np.asarray(path[self.fed:], dtype=int)
        self.fed = max(self.fed, len(path))
        if new.size:
            self._extend(new)

    def _extend(self, new: np.ndarray) -> None:
        q, n, m = self._q, self.n, self.cols.size
        block = orthogonal_block(self.psi, q, new)
        if block is None:
            return
        new, qb, rb, c = block
        k = new.size
        qty = qb.T @ self._resid  # = Qb^T y: Qb is orthogonal to the kept columns
        hat = self._hat[:, None] + np.cumsum(qb * qb, axis=1)
        r, rinv, frob = grown_factor(self._r, self._rinv, self._frob, c, rb)
        p = m + 1 + np.arange(k)
        leverage = (hat >= 1.0 - 1e-10).any(axis=0) | (p >= n)
        score = self._score_columns if self.joint else self._score_column
        loo, se = score(qb, qty, hat, p, frob, leverage)
        self._q = np.hstack([q, qb])
        self._r, self._rinv = r, rinv
        self._qty = np.concatenate([self._qty, qty])
        self._hat = hat[:, -1].copy()
        self._frob = float(frob[-1])
        self.cols = np.concatenate([self.cols, new])
        self.loo = np.concatenate([self.loo, loo])
        self.se = np.concatenate([self.se, se])

    # Two scorings: with one column they agree to round-off only, and merging them would move
    # the last bits of one kind of fit.

    def _score_column(self, qb: np.ndarray, qty: np.ndarray, hat: np.ndarray, p: np.ndarray,
                      frob: np.ndarray, leverage: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The errors of one output's nested sets, and their standard errors; a set after one
        whose error is undefined (a leverage of 1, or not finite) is undefined too."""
        n = self.n
        resid = _residuals(self._resid, qb, qty)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            e2 = (resid / (1.0 - hat)) ** 2
            factor = n / (n - p) * (1.0 + frob) / self.var
            loo = np.mean(e2, axis=0) * factor
            se = np.std(e2, axis=0) / np.sqrt(n) * factor
        undefined = np.maximum.accumulate(leverage | ~np.isfinite(loo) | self._undefined)
        loo[undefined] = np.inf
        self._resid = resid[:, -1].copy()
        self._undefined = bool(undefined[-1])
        return loo, se

    def _score_columns(self, qb: np.ndarray, qty: np.ndarray, hat: np.ndarray, p: np.ndarray,
                       frob: np.ndarray, leverage: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The errors ``(k, q)`` of several outputs' nested sets (a set after one of leverage 1
        is undefined too), each column's best set so far and its leave-one-out residuals."""
        n, m, var = self.n, self.cols.size, np.asarray(self.var)
        undefined = np.maximum.accumulate(leverage | self._undefined)
        loo = np.empty((qty.shape[0], qty.shape[1]))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            lev = 1.0 / (1.0 - hat)
            base = n / (n - p) * (1.0 + frob) / n
            for j in range(qty.shape[1]):
                resid = _residuals(self._resid[:, j], qb, qty[:, j])
                e = resid * lev
                loo[:, j] = np.einsum("ik,ik->k", e, e) * (base / var[j])
                loo[undefined | ~np.isfinite(loo[:, j]), j] = np.inf
                i = int(np.argmin(loo[:, j]))
                if loo[i, j] < self.best_loo[j]:
                    self.best_loo[j], self.best_size[j] = loo[i, j], m + 1 + i
                    self.best_resid[:, j] = e[:, i]
                self._resid[:, j] = resid[:, -1]
        self._undefined = bool(undefined[-1])
        return loo, np.zeros_like(loo)

    def best_sizes(self) -> np.ndarray:
        """Each column's best nested set's size so far (one output: its first least error's,
        1 when none is finite; several: 0 for a column with no finite error yet)."""
        return self.best_size if self.joint else np.array([int(np.argmin(self.loo)) + 1])

    def fit(self, k: int | None = None, column: int = 0) -> SparseFit:
        """Column ``column``'s OLS fit on the first ``k`` kept columns (default: its best
        nested set), with its score; the constant, exactly, for an output without variance."""
        from scipy.linalg import solve_triangular

        if self.joint:
            k = int(self.best_size[column]) if k is None else k
            qty, loo, se = self._qty[:k, column], self.loo[:, column], self.se[:, column]
        else:
            if self.var <= 0.0:  # no variance to regress on
                return SparseFit(np.zeros(1, dtype=int), np.array([self.y.mean()]), 0.0)
            k = int(self.best_sizes()[0]) if k is None else k
            qty, loo, se = self._qty[:k], self.loo, self.se
        coef = solve_triangular(self._r[:k, :k], qty, lower=False, check_finite=False)
        score = float(loo[k - 1]) if k and np.isfinite(loo[k - 1]) else float(np.inf)
        return SparseFit(self.cols[:k].copy(), coef, score,
                         float(se[k - 1]) if np.isfinite(score) else 0.0)


def _residuals(resid: np.ndarray, qb: np.ndarray, qty: np.ndarray) -> np.ndarray:
    """OLS residuals ``(N, k)`` of the nested sets a block adds: the kept set's ``resid`` less
    its part along each new orthonormal column."""
    return resid[:, None] - np.cumsum(qb * qty, axis=1)


def score_path(psi: np.ndarray, y: np.ndarray, order: np.ndarray | LarsPath,
               patience: int | None = None, hint: int = 0,
               state: LooPath | None = None) -> LooPath:
    """Score the nested sets ``{0} + order[:k]`` of ``y (N,)`` or ``(N, q)`` by corrected LOO
    (:meth:`LooPath.fit` then gives each column's best); ``psi (N, P_cand)``, column 0 constant.

    A :class:`LarsPath` ``order`` is advanced only as far as the scoring reads it. ``patience``:
    stop past ``2 P_best + patience`` terms (``P_best`` the largest best set size;
    docs/pce.md#the-leave-one-out-path); None scores the whole path. ``hint``: a guess of the
    best size for the first block. ``state``: the scores of a shorter path ``order`` extends
    (same ``psi``, ``y``), advanced in place.
    """
    path = LooPath(psi, y) if state is None else state
    if not path.joint and path.var <= 0.0:
        return path  # a constant: nothing to score
    limit = max(0, path.n - 2)

    def head(k: int) -> np.ndarray:
        """``[0] + order[:limit]`` up to its first ``k`` entries (fewer where it ends)."""
        k = min(k - 1, limit)
        part = order.order(k) if isinstance(order, LarsPath) else order[:k]
        return np.concatenate([[0], part[:k]]).astype(int)

    full = head(limit + 1 if patience is None
                else max(4 * patience, 2 * hint + patience, path.fed) + 1)
    while True:
        path.feed(full)
        if patience is None:
            return path
        want = 2 * int(path.best_sizes().max()) + patience
        if want < path.cols.size:
            return path
        longer = head(max(2 * full.size, want + 1))
        if longer.size == full.size:  # the whole order is scored
            return path
        full = longer


def loo_values(expansion: Expansion, xi: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Leave-one-out surrogate values ``(N, m)`` at the fit runs ``xi (N, d)``.

    ``targets (N, r')``: what the core's columns were fitted to by OLS on their own non-zero
    terms (a core column beyond them, a series' mean row, has no residual); a run of leverage 1
    keeps its fitted value.
    """
    psi = basis.evaluate(expansion.germ, expansion.alpha, xi)
    fitted = psi @ expansion.core
    shift = np.zeros_like(fitted)
    for j, qm in _own_terms(psi, expansion.core, min(targets.shape[1], expansion.core.shape[1])):
        resid = targets[:, j] - fitted[:, j]
        hat = np.einsum("ij,ij->i", qm, qm)
        with np.errstate(divide="ignore", invalid="ignore"):
            # fitted - loo prediction = r h / (1 - h)
            move = resid * hat / (1.0 - hat)
        shift[:, j] = np.where(np.isfinite(move) & (hat < 1.0 - 1e-10), move, 0.0)
    return expansion.mixed(fitted - shift)


def loo_residuals(psi: np.ndarray, core: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Leave-one-out residuals ``(N, r)`` of each column of ``y`` refitted by OLS on the terms
    its column of ``core (P, r)`` uses (``psi (N, P)``: the core's terms at the runs); 0 where
    undefined."""
    out = np.zeros_like(y)
    for j, qm in _own_terms(psi, core, y.shape[1]):
        resid = y[:, j] - qm @ (qm.T @ y[:, j])
        with np.errstate(divide="ignore", invalid="ignore"):
            out[:, j] = resid / (1.0 - np.einsum("ij,ij->i", qm, qm))
    return np.where(np.isfinite(out), out, 0.0)


def _own_terms(psi: np.ndarray, core: np.ndarray, columns: int
               ) -> Iterator[tuple[int, np.ndarray]]:
    """Each of the first ``columns`` columns of ``core`` and an orthonormal basis ``(N, P_j)``
    of the columns of ``psi`` it uses (the constant included); none for a column with as many
    terms as runs (each run its own term: no leave-one-out prediction)."""
    from scipy.linalg import qr  # here: as orthogonal_block's

    for j in range(columns):
        terms = np.union1d([0], np.flatnonzero(core[:, j]))
        if terms.size < psi.shape[0]:
            yield j, qr(psi[:, terms], mode="economic", check_finite=False)[0]


@dataclass(frozen=True)
class FitRuns:
    """The fit runs as a second sample of the model-minus-surrogate differences
    (docs/pce.md#the-fit-runs-floor).

    ``y (N, ...)``: the model at the successful fit runs; ``s_loo``: the surrogate's LOO values
    there; ``stratum``, ``ratio``, ``input_share``: as :class:`FitFloor`'s.
    """

    y: np.ndarray
    s_loo: np.ndarray
    stratum: np.ndarray
    ratio: np.ndarray
    input_share: np.ndarray


@dataclass(frozen=True)
class FitFloor:
    """A statistic's per-run values at the fit runs (:func:`stratified_se`'s floor).

    ``influence (N, m)``: from the surrogate's LOO predictions; ``stratum (N,)``; ``ratio (N,)``:
    importance ratio ``1 / q(u)`` to the validation pool's density; ``input_share (K,)``: each
    stratum's probability under the input distribution.
    """

    influence: np.ndarray
    stratum: np.ndarray
    ratio: np.ndarray
    input_share: np.ndarray

    def variance(self, k: int, share: float) -> np.ndarray:
        """``Var_q(r f | k)`` from the fit runs in stratum ``k`` (``share``: its pool
        probability ``Q_k``); 0 with fewer than two of them (docs/pce.md#the-fit-runs-floor)."""
        rows = self.stratum == k
        nk = int(rows.sum())
        if nk < 2 or share <= 0:
            return np.zeros(self.influence.shape[1])
        f, r = self.influence[rows], self.ratio[rows]
        c = self.input_share[k] / share
        v = c * np.mean(r[:, None] * f * f, axis=0) - (c * f.mean(axis=0)) ** 2
        return np.maximum(v, 0.0) * nk / (nk - 1)
