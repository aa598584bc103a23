"""Least-angle regression's order of entry of the candidates (LARS), for ``y`` of shape (N, q).

:class:`LarsPath` advances the "lar" path of ``y (N,)`` or the multiresponse path (MRSR) of
``y (N, q)`` on demand; :class:`LarsBasis` lays a candidate basis out once for several paths.

The steps and why they are cheap:
docs/methods.md#sparse-regression-the-candidate-grid-lars-and-leave-one-out; why no rescaling
and the refreshed correlations: docs/pce.md#lars-on-the-columns-as-they-are.
"""

from __future__ import annotations

import numpy as np

_DEGENERATE = 1e-10  # relative norm below which a new column adds nothing to the span
_REFRESH = 8  # LARS steps between exact recomputations of the correlations


class LarsBasis:
    """A candidate basis ``psi (N, P)`` prepared for :class:`LarsPath`, shared by the paths of
    several output columns (a series' principal components): the transposed basis (contiguous,
    one pass over memory per product) and the columns' squared norms."""

    def __init__(self, psi: np.ndarray) -> None:
        self.n = int(psi.shape[0])
        self.psi_t = np.ascontiguousarray(psi.T)
        self.norms2 = np.einsum("ij,ij->i", self.psi_t, self.psi_t)

    @property
    def psi(self) -> np.ndarray:
        """The basis ``(N, P)`` (a transposed view)."""
        return self.psi_t.T


class LarsPath:
    """Least-angle regression's order of entry of the columns of ``psi (N, P)`` (or a
    :class:`LarsBasis`) for ``y (N,)`` (the "lar" step) or ``y (N, q)`` (the multiresponse step,
    even for ``q = 1``); asking for more steps continues the path. A column (nearly) in the span
    of the active ones is skipped.
    """

    def __init__(self, psi: np.ndarray | LarsBasis, y: np.ndarray) -> None:
        lb = psi if isinstance(psi, LarsBasis) else LarsBasis(psi)
        n, p = lb.n, lb.psi_t.shape[0]
        self.basis = lb
        self.joint = y.ndim == 2
        self.y = np.asarray(y, dtype=float) if self.joint else y
        self.cap = int(min(n - 1, p))
        size = max(self.cap, 1)
        self.excluded = lb.norms2 <= (_DEGENERATE**2) * n
        self.q = np.empty((size, n))  # the active columns, orthonormalised
        self.active: list[int] = []
        # Kept up to date step by step: rebuilt from the list each step, they cost a third of it.
        self._act = np.zeros(size, dtype=np.intp)
        self._free = ~self.excluded
        self.corr = lb.psi_t @ self.y  # psi^T (y - y_hat): (P,), or (P, q)
        self.corr[self.excluded] = 0.0
        if self.joint:
            r = self.y.shape[1]
            self.qty = np.empty((size, r))  # Q^T Y
            self.b = np.zeros((size, r))  # Y_hat = Q^T b
            self.corr_ols = self.corr.copy()  # psi^T (Y - Y_bar), Y_bar the active set's fit
            self.next = int(np.argmax(np.einsum("ij,ij->i", self.corr, self.corr)))
        else:
            self.z = np.zeros(size)  # R^-T s
            self.qz = np.zeros(n)  # Q z = A G^-1 s
            self.fitted = np.zeros(n)
            self.next = int(np.argmax(np.abs(self.corr)))
        self.done = self.cap < 2

    def order(self, max_steps: int) -> np.ndarray:
        """The first ``max_steps`` candidates (constant excluded) in order of entry."""
        with np.errstate(divide="ignore", invalid="ignore"):  # the step sizes' 0 / 0
            while not self.done and len(self.active) < min(max_steps + 1, self.cap):
                self._step()
        order = np.array(self.active, dtype=int)
        return order[order != 0][:max_steps]

    def _refresh(self, k: int) -> None:
        """Correlations with the residual, recomputed (the updates drift by round-off)."""
        if self.joint:
            q = self.q[:k]
            self.corr = self.basis.psi_t @ (self.y - q.T @ self.b[:k])
            self.corr_ols = self.basis.psi_t @ (self.y - q.T @ self.qty[:k])
        else:
            self.corr = self.basis.psi_t @ (self.y - self.fitted)

    def _step(self) -> None:
        """Take the next candidate in (or skip it) and move the fit to the following one."""
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
        self._free[j] = False
        if d2 <= _DEGENERATE * lb.norms2[j]:
            self.excluded[j] = True  # in the span of the active columns: adds nothing
        else:
            d = np.sqrt(d2)
            self.q[k] = v / d
            if self.joint:
                self.qty[k] = self.q[k] @ self.y
                self.b[k] = 0.0
                # The least-squares residual loses its part along the new column.
                self.corr_ols -= np.outer(lb.psi_t @ self.q[k], self.qty[k])
            else:
                s_new = 1.0 if self.corr[j] >= 0.0 else -1.0
                self.z[k] = (s_new - row @ self.z[:k]) / d
                self.qz += (self.z[k] / d) * v
            self.active.append(j)
            self._act[k] = j
            k += 1
            if k >= self.cap:
                self.done = True
                return
            if self.joint and k % _REFRESH == 0:
                self._refresh(k)
        # The "lar" path also recomputes after a skipped candidate; the multiresponse path
        # does not. Either is as accurate; aligning them would move one kind of fit's bits.
        if not self.joint and k % _REFRESH == 0:
            self._refresh(k)
        idx = np.flatnonzero(self._free)
        (self._joint_move if self.joint else self._lar_move)(k, idx)

    def _lar_move(self, k: int, idx: np.ndarray) -> None:
        """Along the equiangular direction until a free candidate's correlation ties."""
        c_max = np.abs(self.corr[self._act[:k]]).max()
        zz = self.z[:k] @ self.z[:k]  # s^T G^-1 s
        if not idx.size or c_max <= 0.0 or zz <= 0.0:
            self.done = True
            return
        scale = 1.0 / np.sqrt(zz)
        u = self.qz * scale  # the equiangular direction (unit norm)
        a = self.basis.psi_t @ u
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

    def _joint_move(self, k: int, idx: np.ndarray) -> None:
        """Toward the active set's least-squares fit until a free candidate's row ties."""
        act = self.corr[self._act[:k]]
        c2 = np.einsum("ij,ij->i", act, act).max()
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
    """Per row, the root ``g`` in (0, 1] of ``||u - g a||^2 = (1 - g)^2 c2`` (inf if none),
    from the numerically stable pair ``q / aa``, ``cc / q``."""
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
