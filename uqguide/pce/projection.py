"""Pseudo-spectral projection: PCE coefficients from model runs at quadrature nodes.

Each tensor rule projects axis by axis; a Smolyak grid combines its tensor projections with the
Smolyak coefficients (docs/pce.md#pseudo-spectral-projection).
"""

from __future__ import annotations

import numpy as np

from .basis import index_lookup, univariate
from .germ import Germ
from .quadrature import Grid, union_basis


def project(germ: Germ, grid: Grid, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """PCE coefficients of ``y (N, m)`` (values at ``grid.xi``, ``m`` = time steps x components).

    Returns ``alpha (P, d)`` (union of the tensor terms' bases, zero index first) and
    ``coef (P, m)``.
    """
    y = np.asarray(y, dtype=float)
    alpha = union_basis(grid)
    lookup = index_lookup(alpha)
    coef = np.zeros((alpha.shape[0], y.shape[1]))
    d = germ.dim
    for term in grid.terms:
        block = y[term.rows]  # (n_1, ..., n_d, m)
        for j, rule in enumerate(term.rules):
            phi = univariate(germ.kind(j), rule.nodes, rule.degree)  # (p_j + 1, n_j)
            block = np.moveaxis(np.tensordot(phi * rule.weights, block, axes=(1, j)), 0, j)
        # block[a_1, ..., a_d, :] is the tensor term's coefficient of psi_a.
        degrees = block.shape[:d]
        rows = np.array([lookup[a] for a in np.ndindex(*degrees)], dtype=int)
        np.add.at(coef, rows, term.coef * block.reshape(-1, y.shape[1]))
    return alpha, coef
