"""Sliding-mode proximity controllers of [W]: APF-TSMC, GMM-TSMC (:class:`TSMC`) and GMM-NTSMC
(:class:`NTSMC`), with the reaching law :class:`ReachingLaw`; callables on batches,
``u = ctl.command(r, v, A, B)``. The laws in full: docs/papers.md#gmm-potentials-and-controllers;
the labels: docs/papers.md#the-gmm-papers-ambiguities-as-settled.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .potential import AttractRepulsePotential, matvec


def sig(x: np.ndarray, a: float) -> np.ndarray:
    """Sign-preserving power ``sign(x) |x|^a``, element-wise ([W 13])."""
    return np.sign(x) * np.abs(x) ** a


def positive_diagonal(name: str, value: np.ndarray | float) -> np.ndarray:
    """A diagonal gain as a 3-vector (a scalar is broadcast); ValueError unless all > 0."""
    v = np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy()
    if np.any(v <= 0):
        raise ValueError(f"the gain {name} must be positive definite (all diagonal entries > 0)")
    return v


@dataclass(frozen=True)
class ReachingLaw:
    """``S' = -lambda1 S - lambda2 sig^alpha(S)`` ([W 12]) with diagonal gains ``lambda1`` [1/s],
    ``lambda2`` [unit(S)^(1-alpha)/s] (3-vectors) and ``0 < alpha < 1``."""

    lambda1: np.ndarray
    lambda2: np.ndarray
    alpha: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "lambda1", positive_diagonal("lambda1", self.lambda1))
        object.__setattr__(self, "lambda2", positive_diagonal("lambda2", self.lambda2))
        if not 0 < self.alpha < 1:
            raise ValueError(f"the reaching-law exponent alpha must be in (0, 1), got {self.alpha}")

    def rate(self, S: np.ndarray) -> np.ndarray:
        """``S'`` for ``S`` of shape (n, 3)."""
        return -self.lambda1 * S - self.lambda2 * sig(S, self.alpha)


@dataclass(frozen=True)
class TSMC:
    """Terminal sliding-mode control with a potential-gradient surface (APF-TSMC / GMM-TSMC):
    goal ``r_f`` (3,) [m] at rest, diagonal surface gain ``k_s`` (3,) [1/s]."""

    potential: AttractRepulsePotential
    r_f: np.ndarray
    k_s: np.ndarray
    reaching: ReachingLaw

    def __post_init__(self) -> None:
        object.__setattr__(self, "r_f", np.asarray(self.r_f, dtype=float))
        object.__setattr__(self, "k_s", positive_diagonal("k_s", self.k_s))

    def sliding(self, r: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``S = k_s g + e'`` [m/s], shape (n, 3) ([W 29, 31])."""
        return self.k_s * self.potential.derivatives(r, self.r_f).g + v

    def command(self, r: np.ndarray, v: np.ndarray, A: np.ndarray, B: np.ndarray) -> np.ndarray:
        """Commanded acceleration [m/s^2], shape (n, 3) ([W 30, 32])."""
        d = self.potential.derivatives(r, self.r_f)
        S = self.k_s * d.g + v
        return -self.k_s * matvec(d.H, v) - matvec(A, r) - matvec(B, v) + self.reaching.rate(S)


@dataclass(frozen=True)
class NTSMC:
    """Nonsingular terminal sliding-mode control with the GMM potential ([W 10-16]): goal
    ``r_f`` (3,) [m] at rest, diagonal surface gain ``k_s`` [1/s], linear error gain ``xi0``
    [1/s] (``0 < xi0 < 1``), the gains ``xi1``, ``xi2`` (invertible) of ``sig^tau(e)`` and
    ``sig^{p/q}(e')`` (``tau > 1``; ``p < q`` positive odd integers), and the floor ``eps``
    [m/s] on ``|e'_i|`` in the factor ``|e'|^{1-p/q}`` (0: as published, A17)."""

    potential: AttractRepulsePotential
    r_f: np.ndarray
    k_s: np.ndarray
    reaching: ReachingLaw
    xi0: float
    xi1: np.ndarray
    xi2: np.ndarray
    tau: float
    p: int
    q: int
    eps: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "r_f", np.asarray(self.r_f, dtype=float))
        for name in ("k_s", "xi1", "xi2"):
            object.__setattr__(self, name, positive_diagonal(name, getattr(self, name)))
        odd = self.p % 2 == 1 and self.q % 2 == 1
        if not (self.p > 0 and self.q > 0 and odd and self.p < self.q):
            raise ValueError(
                f"p and q must be positive odd integers with p < q, got {self.p}, {self.q}"
            )
        if not self.tau > 1:
            raise ValueError(f"tau must be greater than 1, got {self.tau}")
        if self.eps < 0:
            raise ValueError(f"the stall floor eps must be >= 0 m/s, got {self.eps}")

    @property
    def rho(self) -> float:
        """``p / q``."""
        return self.p / self.q

    def sliding(self, r: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``S`` of [W 10], shape (n, 3)."""
        e = r - self.r_f
        g = self.potential.derivatives(r, self.r_f).g
        return (self.k_s * g + self.xi0 * e + self.xi1 * sig(e, self.tau)
                + self.xi2 * sig(v, self.rho))

    def command(self, r: np.ndarray, v: np.ndarray, A: np.ndarray, B: np.ndarray) -> np.ndarray:
        """Commanded acceleration [m/s^2], shape (n, 3) ([W 14])."""
        e = r - self.r_f
        d = self.potential.derivatives(r, self.r_f)
        S = (self.k_s * d.g + self.xi0 * e + self.xi1 * sig(e, self.tau)
             + self.xi2 * sig(v, self.rho))
        bracket = (
            -self.k_s * matvec(d.H, v)
            + self.reaching.rate(S)
            - self.xi0 * v
            - self.tau * self.xi1 * np.abs(e) ** (self.tau - 1) * v
        )
        gain = (self.q / self.p) / self.xi2 * np.maximum(np.abs(v), self.eps) ** (1 - self.rho)
        return gain * bracket - matvec(A, r) - matvec(B, v)
