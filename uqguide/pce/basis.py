"""Orthonormal polynomial bases on the germ: multi-index sets and their evaluation.

A basis is a set of multi-indices ``alpha (P, d)`` (row 0 the constant) and the polynomials
``psi_alpha(xi) = prod_j phi_j,alpha_j(xi_j)``, each ``phi_j,n`` evaluated by its three-term
recurrence (:func:`recurrence`, :func:`univariate`).

Why orthonormal and why recurrences: docs/methods.md#bases-and-quadrature.
"""

from __future__ import annotations

import itertools
from functools import lru_cache

import numpy as np

from .germ import Germ, kind_distribution


def hyperbolic_indices(d: int, degree: int, q: float = 1.0) -> np.ndarray:
    """Multi-indices with ``||alpha||_q = (sum alpha_j^q)^(1/q) <= degree`` (Blatman & Sudret 2011).

    ``q = 1`` is the total-degree set (paper eq 19); ``q < 1`` drops high-order interactions.
    Returns ``(P, d)`` ints in :func:`graded` order; row 0 is the zero index.
    """
    if not 0.0 < q <= 1.0:
        raise ValueError(f"q must be in (0, 1], got {q}")
    budget = float(degree) ** q * (1 + 1e-12)  # equality kept: (1, 1) is in the q=0.5, p=4 set
    rows: list[tuple[int, ...]] = []

    def extend(prefix: tuple[int, ...], used: float) -> None:
        if len(prefix) == d:
            rows.append(prefix)
            return
        for a in range(degree + 1):
            cost = used + (a**q if a else 0.0)
            if cost > budget:
                break
            extend(prefix + (a,), cost)

    extend((), 0.0)
    return graded(np.array(rows, dtype=int).reshape(-1, d))


def tensor_indices(degrees: tuple[int, ...] | list[int]) -> np.ndarray:
    """All multi-indices with ``alpha_j <= degrees[j]``, graded: ``(prod(degrees + 1), d)``."""
    grid = itertools.product(*[range(p + 1) for p in degrees])
    return graded(np.array(list(grid), dtype=int).reshape(-1, len(degrees)))


def graded(alpha: np.ndarray) -> np.ndarray:
    """Multi-indices sorted by total degree, then by the last variables' degrees (zero first)."""
    if alpha.size == 0:
        return alpha
    keys = [alpha[:, j] for j in range(alpha.shape[1])] + [alpha.sum(axis=1)]
    return alpha[np.lexsort(keys)]


@lru_cache(maxsize=64)
def recurrence(kind: tuple[str, float, float], degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Monic recurrence coefficients ``(alpha (degree+1,), beta (degree+1,))`` of a germ variable
    of the given :meth:`Germ.kind`: ``pi_{k+1} = (x - alpha_k) pi_k - beta_k pi_{k-1}``,
    ``beta[0] = 1``."""
    fam, a, b = kind
    if fam == "normal":
        return np.zeros(degree + 1), np.concatenate([[1.0], np.arange(1.0, degree + 1)])
    if fam == "uniform":
        k = np.arange(1.0, degree + 1)
        return np.zeros(degree + 1), np.concatenate([[1.0], k**2 / (4 * k**2 - 1)])
    import chaospy

    coeffs, _, _ = chaospy.stieltjes(degree, kind_distribution(kind))
    return np.asarray(coeffs[0, 0], float), np.asarray(coeffs[1, 0], float)


def univariate(kind: tuple[str, float, float], xi: np.ndarray, degree: int) -> np.ndarray:
    """Orthonormal polynomials ``phi_0..phi_degree`` of a germ variable at ``xi (n,)``:
    ``(degree + 1, n)``."""
    alpha, beta = recurrence(kind, degree)
    xi = np.asarray(xi, dtype=float)
    out = np.empty((degree + 1,) + xi.shape)
    out[0] = 1.0
    if degree >= 1:
        out[1] = (xi - alpha[0]) / np.sqrt(beta[1])
    for k in range(1, degree):
        out[k + 1] = ((xi - alpha[k]) * out[k] - np.sqrt(beta[k]) * out[k - 1]) / np.sqrt(
            beta[k + 1])
    return out


def evaluate(germ: Germ, alpha: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """The basis at germ points ``xi (n, d)``: ``Psi[i, a] = psi_alpha_a(xi_i)``, ``(n, P)``."""
    xi = np.atleast_2d(np.asarray(xi, dtype=float))
    n, P = xi.shape[0], alpha.shape[0]
    # Built term by term (rows) and transposed at the end: each variable multiplies only the
    # terms that involve it (a sparse basis has few per variable), on contiguous rows.
    psi_t = np.ones((P, n))
    for j in range(alpha.shape[1]):
        rows = np.flatnonzero(alpha[:, j])
        if rows.size == 0:
            continue
        phi = univariate(germ.kind(j), xi[:, j], int(alpha[rows, j].max()))  # (p_j + 1, n)
        psi_t[rows] *= phi[alpha[rows, j]]
    return psi_t.T


def index_lookup(alpha: np.ndarray) -> dict[tuple[int, ...], int]:
    """Row number of each multi-index."""
    return {tuple(int(v) for v in row): i for i, row in enumerate(alpha)}
