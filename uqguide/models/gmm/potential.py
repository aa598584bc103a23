"""Attract/repulse potential of the GMM papers and its derivatives.

``phi(r; r_f) = e^T P e / 2 + q V(r) / 2`` (:class:`AttractRepulsePotential`) with its gradient,
Hessian, ``H_f`` (A19) and ``Gamma(y) = D3 phi[y, y]`` (A23):
docs/papers.md#gmm-potentials-and-controllers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .gauss_sum import GaussSum, float_fields


def matvec(M: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``M x`` for a batch of vectors ``x`` (n, 3) and ``M`` (3, 3) or (n, 3, 3).

    Written as three element-wise products so that every row is computed by the same
    operations whatever the batch size (a BLAS product may pick a different kernel, and so a
    different rounding, for 1 row and for 1000): a batch run then equals its single runs
    bit for bit.
    """
    if M.ndim == 2:
        return x[:, 0:1] * M[:, 0] + x[:, 1:2] * M[:, 1] + x[:, 2:3] * M[:, 2]
    return M[:, :, 0] * x[:, 0:1] + M[:, :, 1] * x[:, 1:2] + M[:, :, 2] * x[:, 2:3]


@dataclass(frozen=True)
class PotentialDerivatives:
    """Derivatives of ``phi`` at a batch of points: gradient ``g`` (n, 3) [m] and Hessian ``H``
    (n, 3, 3) [-] w.r.t. ``r``, ``H_f = d g / d r_f`` (n, 3, 3) [-], ``gamma = D3 phi[y, y]`` (n, 3)
    [1/m (unit of y)^2] when ``y`` was given, and the Gaussian-sum value ``V`` (n,)."""

    g: np.ndarray
    H: np.ndarray
    H_f: np.ndarray
    gamma: np.ndarray | None
    V: np.ndarray


@dataclass(frozen=True)
class AttractRepulsePotential:
    """``phi = 1/2 e^T P e + 1/2 (e^T M e) V(r)`` with symmetric positive definite attraction and
    repulsion gains ``P``, ``M`` (3, 3) [-] and repulsive kernels ``V`` (GMM or APF obstacles)."""

    P: np.ndarray
    M: np.ndarray
    V: GaussSum

    def __post_init__(self) -> None:
        for name, A in zip("PM", float_fields(self, "P", "M")):
            if A.shape != (3, 3) or not np.allclose(A, A.T):
                raise ValueError(f"the gain {name} must be a symmetric 3x3 matrix")

    def phi(self, r: np.ndarray, r_f: np.ndarray) -> np.ndarray:
        """``phi(r; r_f)``, shape (n,), for ``r`` (n, 3) and ``r_f`` (3,) or (n, 3) [m]."""
        r = np.asarray(r, dtype=float)
        e = r - r_f
        Pe = matvec(self.P, e)
        Me = matvec(self.M, e)
        return 0.5 * np.sum(e * Pe, axis=-1) + 0.5 * np.sum(e * Me, axis=-1) * self.V.value(r)

    def derivatives(
        self, r: np.ndarray, r_f: np.ndarray, y: np.ndarray | None = None
    ) -> PotentialDerivatives:
        """Gradient, Hessian, ``d g / d r_f`` and (given a direction ``y`` (n, 3), a velocity for
        ``(dH/dt) y``) ``D3 phi[y, y]`` at ``r`` (n, 3) [m] for the goal ``r_f`` (3,) or (n, 3)."""
        r = np.asarray(r, dtype=float)
        e = r - r_f
        d = self.V.derivatives(r, y)
        Me = matvec(self.M, e)
        q = np.sum(e * Me, axis=-1)
        V = d.value[:, None, None]
        outer_gMe = d.grad[:, :, None] * Me[:, None, :]  # grad V (M e)^T
        g = matvec(self.P, e) + d.value[:, None] * Me + 0.5 * q[:, None] * d.grad
        H = (
            self.P
            + V * self.M
            + np.swapaxes(outer_gMe, 1, 2)
            + outer_gMe
            + 0.5 * q[:, None, None] * d.hess
        )
        H_f = -self.P - V * self.M - outer_gMe
        gamma = None
        if y is not None:
            y = np.asarray(y, dtype=float)
            My = matvec(self.M, y)
            hy = matvec(d.hess, y)
            gamma = (
                2 * np.sum(d.grad * y, axis=-1)[:, None] * My
                + np.sum(y * hy, axis=-1)[:, None] * Me
                + 2 * np.sum(e * My, axis=-1)[:, None] * hy
                + np.sum(y * My, axis=-1)[:, None] * d.grad
                + 0.5 * q[:, None] * d.third
            )
        return PotentialDerivatives(g=g, H=H, H_f=H_f, gamma=gamma, V=d.value)
