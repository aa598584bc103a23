"""One least-angle path shared by several output columns (multiresponse LARS).

Similä & Tikka's multiresponse sparse regression (MRSR, 2007): the least-angle regression of
:class:`uqguide.pce.lars.LarsPath` with a candidate's correlation with the residual columns
measured by the norm of its row of the correlation matrix; with one column it is the "lar" path
step for step. :class:`JointLarsPath` updates the correlations by rank-one terms, so a step costs
about what one column's does, and recomputes them every :data:`_REFRESH` steps so they do not
drift. The columns are used as given (no rescaling).

The step, why it is cheap and why no rescaling:
docs/methods.md#sparse-regression-the-candidate-grid-lars-and-leave-one-out.
"""

from __future__ import annotations

import numpy as np

from .lars import LarsBasis

_DEGENERATE = 1e-10  # relative norm below which a new column adds nothing to the span
_REFRESH = 8  # steps between exact recomputations of the correlation matrices


class JointLarsPath:
    """Order of entry of the candidates on the multiresponse LARS path of ``y (N, r)``.

    Parameters
    ----------
    psi : LarsBasis
        Candidate basis at the design points (column 0 the constant).
    y : ndarray, shape (N, r)
        Output columns at the design points.
    """

    def __init__(self, psi: LarsBasis, y: np.ndarray) -> None:
        lb = psi
        n, p = lb.n, lb.psi_t.shape[0]
        self.basis = lb
        self.y = np.asarray(y, dtype=float).reshape(n, -1)
        self.cap = int(min(n - 1, p))
        size = max(self.cap, 1)
        self.excluded = lb.norms2 <= (_DEGENERATE**2) * n
        self.q = np.empty((size, n))  # the active columns, orthonormalised
        self.qty = np.empty((size, self.y.shape[1]))  # Q^T Y
        self.b = np.zeros((size, self.y.shape[1]))  # Y_hat = Q^T b
        self.active: list[int] = []
        # As in LarsPath: the active set as an index array, the free candidates as a mask.
        self._act = np.zeros(size, dtype=np.intp)
        self._free = ~self.excluded
        self.corr = lb.psi_t @ self.y  # C = psi^T (Y - Y_hat)
        self.corr_ols = self.corr.copy()  # psi^T (Y - Y_bar)
        self.corr[self.excluded] = 0.0
        self.corr_ols[self.excluded] = 0.0
        self.next = int(np.argmax(np.einsum("ij,ij->i", self.corr, self.corr)))
        self.done = self.cap < 2

    def order(self, max_steps: int) -> np.ndarray:
        """The first ``max_steps`` candidates (constant excluded) in order of entry."""
        while not self.done and len(self.active) < min(max_steps + 1, self.cap):
            self._step()
        order = np.array(self.active, dtype=int)
        return order[order != 0][:max_steps]

    def _refresh(self, k: int) -> None:
        """Both correlation matrices from the residuals (the updates drift by round-off)."""
        q = self.q[:k]
        self.corr = self.basis.psi_t @ (self.y - q.T @ self.b[:k])
        self.corr_ols = self.basis.psi_t @ (self.y - q.T @ self.qty[:k])

    def _step(self) -> None:
        lb, j, k = self.basis, self.next, len(self.active)
        q = self.q[:k]
        col = lb.psi_t[j]
        row = q @ col
        v = col - row @ q
        d2 = v @ v
        if d2 < 0.25 * lb.norms2[j]:  # cancellation: orthogonalise once more
            v -= (q @ v) @ q
            d2 = v @ v
        free = self._free
        free[j] = False
        if d2 <= _DEGENERATE * lb.norms2[j]:
            self.excluded[j] = True  # in the span of the active columns: adds nothing
        else:
            qn = v / np.sqrt(d2)
            self.q[k] = qn
            self.qty[k] = qn @ self.y
            self.b[k] = 0.0
            # The least-squares residual loses its part along the new column.
            self.corr_ols -= np.outer(lb.psi_t @ qn, self.qty[k])
            self.active.append(j)
            self._act[k] = j
            k += 1
            if k >= self.cap:
                self.done = True
                return
            if k % _REFRESH == 0:
                self._refresh(k)
        act = self.corr[self._act[:k]]
        c2 = np.einsum("ij,ij->i", act, act).max()
        idx = np.flatnonzero(free)
        if not idx.size or c2 <= 0.0:
            self.done = True
            return
        u = self.corr[idx]
        a = u - self.corr_ols[idx]
        g = _catch_up(u, a, c2)
        i = int(np.argmin(g))
        if not np.isfinite(g[i]):
            self.done = True  # no candidate catches up: the residual is (numerically) zero
            return
        gam = min(float(g[i]), 1.0)
        self.b[:k] += gam * (self.qty[:k] - self.b[:k])
        self.corr = (1.0 - gam) * self.corr + gam * self.corr_ols
        self.next = int(idx[i])


def _catch_up(u: np.ndarray, a: np.ndarray, c2: float) -> np.ndarray:
    """Per row, the root ``g`` in (0, 1] of ``||u - g a||^2 = (1 - g)^2 c2`` (inf if none).

    ``f(g) = (a.a - c2) g^2 - 2 (u.a - c2) g + (u.u - c2)`` is negative at 0 (an inactive row
    is below the active norm) and not negative at 1 (``u - a`` is the least-squares
    correlation), so exactly one root lies in (0, 1]; it is taken from the numerically stable
    pair ``q / aa``, ``cc / q``.
    """
    aa = np.einsum("ij,ij->i", a, a) - c2
    bb = np.einsum("ij,ij->i", u, a) - c2
    cc = np.einsum("ij,ij->i", u, u) - c2
    disc = np.maximum(bb * bb - aa * cc, 0.0)
    qq = bb + np.copysign(np.sqrt(disc), bb)
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = np.where(aa != 0.0, qq / aa, np.inf)
        r2 = np.where(qq != 0.0, cc / qq, np.inf)
    floor = 1e-15
    r1 = np.where((r1 > floor) & (r1 <= 1.0 + 1e-12), r1, np.inf)
    r2 = np.where((r2 > floor) & (r2 <= 1.0 + 1e-12), r2, np.inf)
    return np.minimum(r1, r2)
