"""Sums of Gaussian kernels ``V(r) = sum_j c_j exp(-d_j^T L_j d_j / 2)``, ``d_j = r - mu_j``, and
their derivatives up to third order (:class:`GaussSum`, :class:`GaussSumDerivatives`): GMM
kernels and classical APF obstacles, parameters optionally batched per sample. The formulas, and
why ``exp(-q/2)`` underflowing across thin parts is harmless:
docs/papers.md#gmm-potentials-and-controllers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..kernels import njit


def float_fields(obj: object, *names: str) -> tuple[np.ndarray, ...]:
    """Store the named fields of the frozen dataclass ``obj`` as float arrays; returns them."""
    arrays = tuple(np.asarray(getattr(obj, name), dtype=float) for name in names)
    for name, array in zip(names, arrays):
        object.__setattr__(obj, name, array)
    return arrays


@dataclass(frozen=True)
class GaussSumDerivatives:
    """Value (n,), gradient (n, 3), Hessian (n, 3, 3) of a Gaussian sum at a batch of points,
    and ``third`` = ``D3V[y, y]`` (n, 3) when a direction ``y`` was given."""

    value: np.ndarray
    grad: np.ndarray
    hess: np.ndarray
    third: np.ndarray | None = None


@dataclass(frozen=True)
class GaussSum:
    """``V(r) = sum_j c_j exp(-1/2 (r - mu_j)^T L_j (r - mu_j))``.

    Heights ``c`` (K,) or (n, K) in the unit of ``V``, centres ``mu`` (K, 3) or (n, K, 3) [m],
    symmetric positive definite precisions ``L`` (K, 3, 3) or (n, K, 3, 3) [1/m^2].
    """

    c: np.ndarray
    mu: np.ndarray
    L: np.ndarray

    def __post_init__(self) -> None:
        c, mu, L = float_fields(self, "c", "mu", "L")
        if mu.shape[-1] != 3 or L.shape[-2:] != (3, 3) or c.shape[-1] != mu.shape[-2]:
            raise ValueError(
                f"a Gaussian sum needs c (..., K), mu (..., K, 3), L (..., K, 3, 3); "
                f"got {c.shape}, {mu.shape}, {L.shape}"
            )

    @property
    def n_kernels(self) -> int:
        return int(self.mu.shape[-2])

    @classmethod
    def from_mixture(
        cls,
        weights: np.ndarray,
        means: np.ndarray,
        covariances: np.ndarray,
        norm: str = "2pi",
    ) -> GaussSum:
        """The repulsive kernel set of a Gaussian mixture: weights ``pi_j`` (..., K), means
        (..., K, 3) [m], covariances (..., K, 3, 3) [m^2].

        ``norm="2pi"``: ``c_j = pi_j / (2 pi |Sigma_j|^{1/2})`` as printed in [W 7-9] (the 3-D
        density times ``sqrt(2 pi)``); ``"3d"``: the 3-D normaliser
        ``pi_j / ((2 pi)^{3/2} |Sigma_j|^{1/2})`` of [C 10] (A9).
        """
        covariances = np.asarray(covariances, dtype=float)
        det = np.linalg.det(covariances)
        if np.any(det <= 0):
            raise ValueError("every mixture covariance must be positive definite")
        if norm == "2pi":
            denom = 2 * np.pi * np.sqrt(det)
        elif norm == "3d":
            denom = (2 * np.pi) ** 1.5 * np.sqrt(det)
        else:
            raise ValueError(f"norm must be '2pi' or '3d', got {norm!r}")
        return cls(np.asarray(weights, dtype=float) / denom, means, np.linalg.inv(covariances))

    @classmethod
    def from_apf(
        cls, psi: ArrayLike, centers: ArrayLike, N: ArrayLike, sigma: ArrayLike
    ) -> GaussSum:
        """Obstacles ``psi_i exp(-(r - r_obs,i)^T N_i (r - r_obs,i) / sigma_i)`` of [W 28]: heights
        ``psi`` (m,), centres (m, 3) [m], symmetric positive definite ``N`` (m, 3, 3) [1/m^2], width
        factors ``sigma`` (m,)."""
        N = np.asarray(N, dtype=float)
        sigma = np.asarray(sigma, dtype=float)
        return cls(
            np.asarray(psi, dtype=float),
            np.asarray(centers, dtype=float),
            2.0 * N / sigma[:, None, None],
        )

    def _batched(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Parameters with a leading axis of length 1 (shared) or ``n`` (one set per point)."""
        K = self.n_kernels
        out = []
        cores: tuple[tuple[int, ...], ...] = ((K,), (K, 3), (K, 3, 3))
        for param, core in zip((self.c, self.mu, self.L), cores):
            a: np.ndarray = param.reshape((-1, *core))
            if a.shape[0] not in (1, n):
                raise ValueError(
                    f"Gaussian-sum parameters for {a.shape[0]} samples, points for {n}"
                )
            out.append(np.ascontiguousarray(a))
        return out[0], out[1], out[2]

    def value(self, r: np.ndarray) -> np.ndarray:
        """``V(r)``, shape (n,), for points ``r`` of shape (n, 3) [m]."""
        return self.derivatives(r).value

    def derivatives(self, r: np.ndarray, y: np.ndarray | None = None) -> GaussSumDerivatives:
        """``V``, its gradient, Hessian and (given a direction ``y`` (n, 3)) ``D3V[y, y]`` at
        ``r`` (n, 3) [m]."""
        r = np.ascontiguousarray(r, dtype=float)
        n = r.shape[0]
        c, mu, L = self._batched(n)
        want_third = y is not None
        yy = np.ascontiguousarray(y, dtype=float) if want_third else np.zeros((n, 3))
        value, grad, hess, third = _gauss_sum_kernel(r, yy, c, mu, L, want_third)
        return GaussSumDerivatives(value, grad, hess, third if want_third else None)


@njit(cache=True)
def _gauss_sum_kernel(
    r: np.ndarray, y: np.ndarray, c: np.ndarray, mu: np.ndarray, L: np.ndarray, want_third: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    # One fused loop: the NumPy broadcasting version built (n, K, 3, 3) temporaries and spent
    # most of a batch simulation on them. Checked against finite differences in the tests.
    n = r.shape[0]
    K = mu.shape[1]
    value = np.zeros(n)
    grad = np.zeros((n, 3))
    hess = np.zeros((n, 3, 3))
    third = np.zeros((n, 3))
    d = np.empty(3)
    th = np.empty(3)
    Ly = np.empty(3)
    for i in range(n):
        ic = i if c.shape[0] > 1 else 0
        im = i if mu.shape[0] > 1 else 0
        iL = i if L.shape[0] > 1 else 0
        for k in range(K):
            for a in range(3):
                d[a] = r[i, a] - mu[im, k, a]
            q = 0.0
            for a in range(3):
                th[a] = L[iL, k, a, 0] * d[0] + L[iL, k, a, 1] * d[1] + L[iL, k, a, 2] * d[2]
                q += d[a] * th[a]
            eta = c[ic, k] * np.exp(-0.5 * q)
            if eta == 0.0:
                continue
            value[i] += eta
            for a in range(3):
                grad[i, a] -= eta * th[a]
                for b in range(3):
                    hess[i, a, b] += eta * (th[a] * th[b] - L[iL, k, a, b])
            if want_third:
                yLy = 0.0
                ty = 0.0
                for a in range(3):
                    Ly[a] = (
                        L[iL, k, a, 0] * y[i, 0]
                        + L[iL, k, a, 1] * y[i, 1]
                        + L[iL, k, a, 2] * y[i, 2]
                    )
                    yLy += y[i, a] * Ly[a]
                    ty += th[a] * y[i, a]
                for a in range(3):
                    third[i, a] += eta * ((yLy - ty * ty) * th[a] + 2.0 * ty * Ly[a])
    return value, grad, hess, third
