"""Exact third and fourth moments of a sparse PCE by linearising products of its basis
(:func:`central_moments_linearised`); its cost follows the pairs of retained terms
(:func:`product_terms`).

Derivation and cost: docs/methods.md#exact-skewness-and-kurtosis.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .basis import univariate
from .expansion import Expansion
from .quadrature import gauss_rule

#: Product terms (pairs x spread) above which the linearisation is not attempted.
MAX_PRODUCT_TERMS = 20_000_000
_CHUNK_FLOATS = 2**22
_ZERO = 1e-13  # |T| below this is a structural zero (parity), not a coefficient
#: Largest code of one product's digits kept as one integer; past it the partial codes are
#: replaced by their ranks, which keep their order and so the result, bit for bit.
_CODE_LIMIT = 2**62


@lru_cache(maxsize=64)
def triple_products(kind: tuple[str, float, float], p: int) -> np.ndarray:
    """``T[m, n, k] = E[phi_m phi_n phi_k]`` for ``m, n <= p``, ``k <= 2 p``: ``(p+1, p+1, 2p+1)``.

    Structural zeros (outside ``|m - n| <= k <= m + n``, or of odd parity for a symmetric
    measure) are set to exactly 0.
    """
    nodes, weights = gauss_rule(kind, 2 * p + 1)
    phi = univariate(kind, nodes, 2 * p)  # (2p + 1, nodes)
    t = np.einsum("mq,nq,kq,q->mnk", phi[: p + 1], phi[: p + 1], phi, weights)
    m, n, k = np.meshgrid(np.arange(p + 1), np.arange(p + 1), np.arange(2 * p + 1),
                          indexing="ij")
    t[(k < np.abs(m - n)) | (k > m + n) | (np.abs(t) < _ZERO)] = 0.0
    return t


def _supports(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each ``(m, n)``: the count, offset and list of ``k`` with ``T[m, n, k] != 0``."""
    p1 = t.shape[0]
    nz = t.reshape(p1 * p1, -1) != 0.0
    counts = nz.sum(axis=1)
    offsets = np.concatenate([[0], np.cumsum(counts)[:-1]])
    ks = np.nonzero(nz)[1]
    return counts, offsets, ks


def _ranked(code: np.ndarray, own: np.ndarray, own_ok: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The partial codes replaced by their ranks among the distinct ones (order kept, so the
    digits still to come append as before); a term of the surrogate whose partial code is
    absent can never be a product's and is marked so."""
    uniq, rank = np.unique(code, return_inverse=True)
    at = np.minimum(np.searchsorted(uniq, own), uniq.size - 1)
    found = own_ok & (uniq[at] == own)
    return rank.ravel().astype(np.int64), np.where(found, at, 0).astype(np.int64), found


def product_terms(exp: Expansion) -> int:
    """Number of (pair, g) entries the linearisation of ``exp``'s square builds."""
    exp = exp.trimmed()
    alpha = exp.alpha[1:]
    if alpha.shape[0] == 0:
        return 0
    a, b = np.triu_indices(alpha.shape[0])
    total = np.ones(a.size)
    for j in np.flatnonzero(alpha.max(axis=0)):
        p = int(alpha[:, j].max())
        counts, _, _ = _supports(triple_products(exp.germ.kind(int(j)), p))
        total *= counts[alpha[a, j] * (p + 1) + alpha[b, j]]
    return int(total.sum())


def central_moments_linearised(exp: Expansion) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Central moments 2-4 ``(m,)`` of the surrogate, exactly."""
    exp = exp.trimmed()
    alpha = exp.alpha[1:]
    coef = exp.coef[1:]  # (P - 1, m): the centred surrogate's coefficients
    m = exp.n_columns
    if alpha.shape[0] == 0:
        z = np.zeros(m)
        return z, z.copy(), z.copy()
    a, b = np.triu_indices(alpha.shape[0])
    # Expand every pair dimension by dimension: entries (pair, partial g code, value).
    pair = np.arange(a.size)
    code = np.zeros(a.size, dtype=np.int64)
    val = np.where(a == b, 1.0, 2.0)  # the (a, b) and (b, a) products together
    active = np.flatnonzero(alpha.max(axis=0))
    # The surrogate's own terms coded the same way (for E[z^3] = sum s_g c_g).
    own = np.zeros(alpha.shape[0], dtype=np.int64)
    own_ok = np.ones(alpha.shape[0], dtype=bool)
    for j in active:
        p = int(alpha[:, j].max())
        t = triple_products(exp.germ.kind(int(j)), p)
        counts, offsets, ks = _supports(t)
        key = alpha[a[pair], j] * (p + 1) + alpha[b[pair], j]
        rep = counts[key]
        start = np.repeat(offsets[key], rep)
        within = np.arange(rep.sum()) - np.repeat(np.cumsum(rep) - rep, rep)
        k = ks[start + within]
        pair = np.repeat(pair, rep)
        key = np.repeat(key, rep)
        val = np.repeat(val, rep) * t.reshape((p + 1) ** 2, -1)[key, k]
        if (int(code.max(initial=0)) + 1) * (2 * p + 1) > _CODE_LIMIT:
            code, own, own_ok = _ranked(code, own, own_ok)
        code = np.repeat(code, rep) * (2 * p + 1) + k
        own = own * (2 * p + 1) + alpha[:, j]
    codes_sorted, g = np.unique(code, return_inverse=True)
    g = g.ravel()
    n_g = codes_sorted.size
    pos = np.searchsorted(codes_sorted, own)
    present = own_ok & (pos < n_g) & (codes_sorted[np.minimum(pos, n_g - 1)] == own)
    from scipy import sparse  # here: `uqguide validate` starts without it

    lin = sparse.csr_matrix((val, (g, pair)), shape=(n_g, a.size))  # duplicates summed
    mu2, mu3, mu4 = np.zeros(m), np.zeros(m), np.zeros(m)
    step = max(1, _CHUNK_FLOATS // max(a.size, n_g))
    for c0 in range(0, m, step):
        cols = slice(c0, min(m, c0 + step))
        cc = coef[:, cols]
        s = lin @ (cc[a] * cc[b])  # z^2's coefficients, (n_g, chunk)
        mu4[cols] = (s * s).sum(axis=0)
        mu3[cols] = (s[pos[present]] * cc[present]).sum(axis=0)
        mu2[cols] = (cc * cc).sum(axis=0)
    return mu2, mu3, mu4
