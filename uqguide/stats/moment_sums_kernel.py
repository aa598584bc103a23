"""Compiled central sums of a chunk of samples (the hot part of :meth:`.stats.MomentSums.of`).

Two passes over the data instead of NumPy's temporary per power. Each column's sum is
accumulated in sample order, the order of NumPy's ``sum(axis=0)`` on a C-ordered array, so both
forms agree up to the rounding of the powers (the tests compare them). ``numba.njit`` directly,
not :func:`uqguide.models.kernels.njit`: statistics sit below the models in the import layers
(``cache=True`` is safe read-only: numba then caches in a user-wide folder).
"""

from __future__ import annotations

import numpy as np

from numba import njit


@njit(cache=True, error_model="numpy")
def column_sums(y: np.ndarray, high: bool) -> tuple[np.ndarray, np.ndarray]:
    """Mean ``(c,)`` and central sums ``(3, c)`` of orders 2-4 of the columns of C-ordered
    ``y (n, c)``, ``n >= 1``; with ``high`` ``(15, c)``, orders 5-16 too (what the tail-aware
    intervals read)."""
    n, c = y.shape
    acc = np.zeros(c)
    for i in range(n):
        for j in range(c):
            acc[j] += y[i, j]
    mean = acc / n
    rows = 15 if high else 3
    s = np.zeros((rows, c))
    s2, s3, s4 = s[0], s[1], s[2]
    for i in range(n):
        for j in range(c):
            d = y[i, j] - mean[j]
            d2 = d * d
            s2[j] += d2
            s3[j] += d2 * d
            p = d2 * d2
            s4[j] += p
            for r in range(3, rows):
                p = p * d
                s[r, j] += p
    return mean, s


@njit(cache=True, error_model="numpy")
def comoment_sums(y: np.ndarray, mean: np.ndarray) -> np.ndarray:
    """Comoment sums ``sum_i (y_i - mean)(y_i - mean)^T`` ``(P, k, k)`` of every group of ``k``
    components of C-ordered ``y (n, P, k)``, ``mean (P, k)``."""
    n, P, k = y.shape
    cm = np.zeros((P, k, k))
    for i in range(n):
        for q in range(P):
            for a in range(k):
                da = y[i, q, a] - mean[q, a]
                for b in range(k):
                    cm[q, a, b] += da * (y[i, q, b] - mean[q, b])
    return cm
