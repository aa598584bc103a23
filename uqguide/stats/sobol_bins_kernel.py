"""Compiled bin sums of the given-data first-order indices (the hot loop of
:mod:`uqguide.stats.sobol_given_data`).

One pass over a column's runs accumulates, for every input at once, the bin sums of ``z, z^2,
z^3, z^4`` (``z`` the standardised value), instead of NumPy's ten passes per column and input
(8 ms each at ``n = 1e5``); the index and its influence function's variance follow from those
sums in closed form (docs/error-budget.md#the-given-data-estimator-in-detail).
"""

from __future__ import annotations

import numpy as np

from numba import njit


@njit(cache=True, error_model="numpy")
def binned_indices(lanes: np.ndarray, bins: np.ndarray, sizes: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """First-order indices ``V_i / D`` ``(C, d)`` (NaN without variance) and the sample variance
    of their influence function ``psi`` over the runs ``(C, d)``.

    ``lanes (C, n)``: output columns, runs along each row; ``bins (n, d)``: every run's bin
    ``0 .. M - 1`` per input; ``sizes (M,)``: runs per bin (equal counts), each at least 2.
    """
    c_all, n = lanes.shape
    d = bins.shape[1]
    m = sizes.shape[0]
    first = np.full((c_all, d), np.nan)
    var_psi = np.full((c_all, d), np.nan)
    z = np.empty(n)
    acc = np.zeros((d, m, 4))
    for c in range(c_all):
        row = lanes[c]
        mu = 0.0
        for j in range(n):
            mu += row[j]
        mu /= n
        ss = 0.0
        for j in range(n):
            e = row[j] - mu
            ss += e * e
        var = ss / (n - 1)
        floor = 1e-12 * max(abs(mu), 1e-300)
        if not var > floor * floor:  # (also NaN) a column equal in every run
            continue
        inv = 1.0 / np.sqrt(var)
        for j in range(n):
            z[j] = (row[j] - mu) * inv
        acc[:] = 0.0
        for j in range(n):
            v = z[j]
            v2 = v * v
            v3 = v2 * v
            v4 = v2 * v2
            for i in range(d):
                k = bins[j, i]
                acc[i, k, 0] += v
                acc[i, k, 1] += v2
                acc[i, k, 2] += v3
                acc[i, k, 3] += v4
        for i in range(d):
            t = 0.0
            for k in range(m):
                a = acc[i, k, 0]
                t += (a * a - acc[i, k, 1]) / (sizes[k] - 1.0)
            s = t / n + 1.0 / n
            # psi = 2 z g - g^2 - s z^2 with g = (a - z) / mm, the run's leave-one-out bin
            # mean: c0 + c1 z + c2 z^2 within a bin
            sp = 0.0
            sp2 = 0.0
            for k in range(m):
                mm = sizes[k] - 1.0
                a = acc[i, k, 0]
                p1, p2, p3, p4 = acc[i, k, 0], acc[i, k, 1], acc[i, k, 2], acc[i, k, 3]
                c0 = -a * a / (mm * mm)
                c1 = 2.0 * a * (mm + 1.0) / (mm * mm)
                c2 = -(2.0 * mm + 1.0) / (mm * mm) - s
                sp += sizes[k] * c0 + c1 * p1 + c2 * p2
                sp2 += (sizes[k] * c0 * c0 + 2.0 * c0 * c1 * p1 + (c1 * c1 + 2.0 * c0 * c2) * p2
                        + 2.0 * c1 * c2 * p3 + c2 * c2 * p4)
            mean_psi = sp / n
            first[c, i] = s
            var_psi[c, i] = max(sp2 / n - mean_psi * mean_psi, 0.0)
    return first, var_psi
