"""Least-angle regression's order of entry of the candidates (LARS), for one output or several.

:class:`LarsPath` is the "lar" path of one output column (Efron et al. 2004); :class:`JointLarsPath`
the multiresponse path (MRSR, Similä & Tikka 2007) shared by several columns, a candidate's
correlation measured by the norm of its row of the correlation matrix. Both use the columns as
given (no rescaling) and recompute the correlations every :data:`_REFRESH` steps so they do not
drift. :class:`LarsBasis` lays the candidate basis out once for the paths of several columns.

The steps, why they are cheap and why no rescaling:
docs/methods.md#sparse-regression-the-candidate-grid-lars-and-leave-one-out.
"""

from __future__ import annotations

import numpy as np

_DEGENERATE = 1e-10  # relative norm below which a new column adds nothing to the span
_REFRESH = 8  # LARS steps between exact recomputations of the correlations


class LarsBasis:
    """A candidate basis prepared for :class:`LarsPath`, shared by the paths of several output
    columns (the principal components of a series): the transposed basis (contiguous, one pass
    over memory per product with every candidate) and the columns' squared norms.

    Parameters
    ----------
    psi : ndarray, shape (N, P)
        Candidate basis at the design points.
    """

    def __init__(self, psi: np.ndarray) -> None:
        self.n = int(psi.shape[0])
        self.psi_t = np.ascontiguousarray(psi.T)
        self.norms2 = np.einsum("ij,ij->i", self.psi_t, self.psi_t)

    @property
    def psi(self) -> np.ndarray:
        """The basis ``(N, P)`` (a transposed view)."""
        return self.psi_t.T


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

    A step costs one product with the ``(N, P)`` basis and two with the active columns,
    kept orthonormalised (``Q``, by Gram-Schmidt, repeated when a column is nearly in the
    span: "twice is enough"). The equiangular direction is ``u = A G^-1 s / sqrt(s^T G^-1 s)``
    (``A`` the active columns, ``G = A^T A``, ``s`` the signs of their correlations, which do
    not change on a LAR path); with ``A = Q R``, ``A G^-1 s = Q z``, ``z = R^-T s``, and ``z``
    grows by one entry per step, ``z_new = (s_new - r . z) / d`` (``r = Q^T a_new``, ``d`` the
    new column's distance to the span), so ``Q z`` is updated in ``O(N)``. A column (nearly)
    in the span of the active ones is skipped. The path keeps its state, so asking for more
    steps continues it rather than starting again.

    Parameters
    ----------
    psi : ndarray, shape (N, P), or LarsBasis
        Candidate basis at the design points.
    y : ndarray, shape (N,)
        Output at the design points.
    """

    def __init__(self, psi: np.ndarray | LarsBasis, y: np.ndarray) -> None:
        lb = psi if isinstance(psi, LarsBasis) else LarsBasis(psi)
        n, p = lb.n, lb.psi_t.shape[0]
        self.basis = lb
        self.y = y
        self.cap = int(min(n - 1, p))
        size = max(self.cap, 1)
        self.excluded = lb.norms2 <= (_DEGENERATE**2) * n
        self.q = np.empty((size, n))  # the active columns, orthonormalised
        self.z = np.zeros(size)  # R^-T s
        self.qz = np.zeros(n)  # Q z = A G^-1 s
        self.active: list[int] = []
        # The active set as an index array and the free candidates as a mask, kept up to date
        # step by step: rebuilt from the list each step, they cost a third of a step.
        self._act = np.zeros(size, dtype=np.intp)
        self._free = ~self.excluded
        self.fitted = np.zeros(n)
        self.corr = lb.psi_t @ y
        self.corr[self.excluded] = 0.0
        self.next = int(np.argmax(np.abs(self.corr)))
        self.done = self.cap < 2

    def order(self, max_steps: int) -> np.ndarray:
        """The first ``max_steps`` candidates (constant excluded) in order of entry."""
        with np.errstate(divide="ignore", invalid="ignore"):  # the step sizes' 0 / 0
            while not self.done and len(self.active) < min(max_steps + 1, self.cap):
                self._step()
        order = np.array(self.active, dtype=int)
        return order[order != 0][:max_steps]

    def _refresh(self) -> None:
        """Correlations with the residual, recomputed (the updates drift by round-off)."""
        self.corr = self.basis.psi_t @ (self.y - self.fitted)

    def _step(self) -> None:
        lb, j, k = self.basis, self.next, len(self.active)
        q = self.q[:k]
        col = lb.psi_t[j]
        row = q @ col
        v = col - row @ q
        d2 = v @ v
        if d2 < 0.25 * lb.norms2[j]:  # cancellation: orthogonalise once more
            extra = q @ v
            v -= extra @ q
            row += extra
            d2 = v @ v
        free = self._free
        free[j] = False
        if d2 <= _DEGENERATE * lb.norms2[j]:
            self.excluded[j] = True  # in the span of the active columns: adds nothing
        else:
            d = np.sqrt(d2)
            s_new = 1.0 if self.corr[j] >= 0.0 else -1.0
            z_new = (s_new - row @ self.z[:k]) / d
            self.q[k] = v / d
            self.z[k] = z_new
            self.qz += (z_new / d) * v
            self.active.append(j)
            self._act[k] = j
            k += 1
            if k >= self.cap:
                self.done = True
                return
        if k % _REFRESH == 0:
            self._refresh()
        c_max = np.abs(self.corr[self._act[:k]]).max()
        zz = self.z[:k] @ self.z[:k]  # s^T G^-1 s
        idx = np.flatnonzero(free)
        if not idx.size or c_max <= 0.0 or zz <= 0.0:
            self.done = True
            return
        scale = 1.0 / np.sqrt(zz)
        u = self.qz * scale  # the equiangular direction (unit norm)
        a = lb.psi_t @ u
        cf, af = self.corr[idx], a[idx]
        # 0 / 0 gives nan, ignored as the steps at or below the floor are (errstate: order).
        g1 = (c_max - cf) / (scale - af)
        g2 = (c_max + cf) / (scale + af)
        floor = 1e-15 * c_max
        g1[~(g1 > floor)] = np.inf
        g2[~(g2 > floor)] = np.inf
        gam = np.minimum(g1, g2, out=g1)
        i = int(np.argmin(gam))
        if not np.isfinite(gam[i]):
            self.done = True
            return
        self.fitted += gam[i] * u
        self.corr -= gam[i] * a
        self.next = int(idx[i])


def lars_order(psi: np.ndarray, y: np.ndarray, max_steps: int) -> np.ndarray:
    """Candidate columns (excluding the constant column 0) in LARS order of entry
    (:class:`LarsPath`)."""
    return LarsPath(psi, y).order(max_steps)


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
