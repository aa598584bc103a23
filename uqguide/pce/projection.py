"""Pseudo-spectral projection: PCE coefficients from model runs at quadrature nodes.

For one tensor rule with projection degrees ``p_j`` (see :mod:`uqguide.pce.quadrature`), the
coefficient of ``psi_alpha`` (``alpha_j <= p_j``) is the paper's eq (23),

    ``c_alpha = sum_i w_i y(xi_i) psi_alpha(xi_i)``,

computed axis by axis (a tensor contraction with each variable's ``w_j phi_j(x_j)`` matrix, so a
128-node grid costs 7 small matrix products, not a 128 x 128 basis matrix). A Smolyak grid
combines its tensor projections with the Smolyak coefficients (Smolyak pseudo-spectral
projection, Conrad & Marzouk 2013): unlike a single projection with the sparse grid's weights,
it is exact for every polynomial in the union of the tensor bases, with no aliasing from the
sparse grid's negative weights.
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
