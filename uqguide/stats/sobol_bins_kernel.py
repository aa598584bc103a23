"""Compiled bin sums of the given-data first-order indices (the hot loop of
:mod:`uqguide.stats.sobol_given_data`).

Per output column two passes over its runs, every input at once: the first sums each bin's
``z``, ``z dx`` and ``z^2`` (``z`` the standardised value, ``dx`` the input's offset from its
bin's mean), which fix the bin's least-squares line and the coarse bins' (pairs of bins)
residual sums; the second sums the squared residuals from the bins' lines and the powers of
``z`` and of the leave-one-out residual that give the influence function's variance in closed
form (docs/error-budget.md#the-given-data-estimator-in-detail).
"""

from __future__ import annotations

import numpy as np

from numba import njit


@njit(cache=True, error_model="numpy")
def bin_lines(x: np.ndarray, bins: np.ndarray, sizes: np.ndarray, coarse: np.ndarray,
              n_coarse: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                      np.ndarray, np.ndarray]:
    """Every input's bin means ``(d, M)`` of ``x (n, d)``, the inverse of the bins' centred sums
    of squares ``(d, M)`` (0 where the bin's values are all equal: its line is flat), and the
    weight of a squared residual ``(d, M)``: runs over residual degrees of freedom, ``n_b /
    (n_b - 2)`` (``n_b / (n_b - 1)`` for a flat line); then the same three for the coarse bins
    ``(d, n_coarse)``, bin ``k`` in coarse bin ``coarse[k]``."""
    n, d = x.shape
    m = sizes.shape[0]
    out = []
    for level in range(2):
        mb = m if level == 0 else n_coarse
        cnt = np.zeros(mb)
        for k in range(m):
            cnt[k if level == 0 else coarse[k]] += sizes[k]
        mean = np.zeros((d, mb))
        lo = np.full((d, mb), np.inf)
        hi = np.full((d, mb), -np.inf)
        for j in range(n):
            for i in range(d):
                k = bins[j, i] if level == 0 else coarse[bins[j, i]]
                v = x[j, i]
                mean[i, k] += v
                lo[i, k] = min(lo[i, k], v)
                hi[i, k] = max(hi[i, k], v)
        for i in range(d):
            for k in range(mb):
                mean[i, k] /= cnt[k]
        sxx = np.zeros((d, mb))
        for j in range(n):
            for i in range(d):
                k = bins[j, i] if level == 0 else coarse[bins[j, i]]
                e = x[j, i] - mean[i, k]
                sxx[i, k] += e * e
        inv = np.zeros((d, mb))
        weight = np.empty((d, mb))
        for i in range(d):
            for k in range(mb):
                flat = not (hi[i, k] > lo[i, k] and sxx[i, k] > 0.0)
                inv[i, k] = 0.0 if flat else 1.0 / sxx[i, k]
                weight[i, k] = cnt[k] / (cnt[k] - (1.0 if flat else 2.0))
        out.append((mean, inv, weight))
    return out[0][0], out[0][1], out[0][2], out[1][0], out[1][1], out[1][2]


@njit(cache=True, error_model="numpy")
def binned_indices(lanes: np.ndarray, x: np.ndarray, bins: np.ndarray, sizes: np.ndarray,
                   coarse: np.ndarray, xbar: np.ndarray, inv_sxx: np.ndarray, weight: np.ndarray,
                   cbar: np.ndarray, inv_csxx: np.ndarray, cweight: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First-order indices ``1 - T`` ``(C, d)`` (``T`` the pooled residual variance of the bins'
    lines; NaN without variance), the sample variance of their influence function over the runs
    ``(C, d)``, and the coarse bins' indices ``(C, d)``.

    ``lanes (C, n)``: output columns, runs along each row; ``x (n, d)``: the inputs;
    ``bins (n, d)``: every run's bin ``0 .. M - 1`` per input; ``sizes (M,)``: runs per bin,
    each at least 3; ``coarse (M,)``: each bin's coarse bin; the rest from :func:`bin_lines`.
    """
    c_all, n = lanes.shape
    d = bins.shape[1]
    m = sizes.shape[0]
    mc = cbar.shape[1]
    first = np.full((c_all, d), np.nan)
    var_psi = np.full((c_all, d), np.nan)
    first_coarse = np.full((c_all, d), np.nan)
    csizes = np.zeros(mc)
    for k in range(m):
        csizes[coarse[k]] += sizes[k]
    z = np.empty(n)
    acc = np.zeros((d, m, 3))  # sums of z, z dx, z^2
    # per bin: its mean x, the line's intercept and slope, the residual weight, 1 / Sxx, 1 / n_b
    par = np.zeros((d, m, 6))
    for i in range(d):
        for k in range(m):
            par[i, k, 0] = xbar[i, k]
            par[i, k, 3] = weight[i, k]
            par[i, k, 4] = inv_sxx[i, k]
            par[i, k, 5] = 1.0 / sizes[k]
    csum = np.zeros((mc, 3))
    sums = np.zeros((d, 4))  # T, sum e^2, sum e^4, sum z^2 e^2 (e leave-one-out)
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
            for i in range(d):
                k = bins[j, i]
                acc[i, k, 0] += v
                acc[i, k, 1] += v * (x[j, i] - par[i, k, 0])
                acc[i, k, 2] += v * v
        for i in range(d):
            # the coarse bins' residual sums of squares from their bins' sums (the bias bound
            # only: rounding there moves no index); sum z (x - cbar) adds sum z (xbar - cbar)
            csum[:] = 0.0
            for k in range(m):
                par[i, k, 1] = acc[i, k, 0] * par[i, k, 5]
                par[i, k, 2] = acc[i, k, 1] * par[i, k, 4]
                kc = coarse[k]
                csum[kc, 0] += acc[i, k, 0]
                csum[kc, 1] += acc[i, k, 1] + (xbar[i, k] - cbar[i, kc]) * acc[i, k, 0]
                csum[kc, 2] += acc[i, k, 2]
            t_coarse = 0.0
            for k in range(mc):
                rss = (csum[k, 2] - csum[k, 0] * csum[k, 0] / csizes[k]
                       - csum[k, 1] * csum[k, 1] * inv_csxx[i, k])
                t_coarse += max(rss, 0.0) * cweight[i, k]
            first_coarse[c, i] = 1.0 - t_coarse / n
        # the bins' residuals run by run: exact where the output is a line in the input
        sums[:] = 0.0
        z2 = 0.0
        z4 = 0.0
        for j in range(n):
            v = z[j]
            v2 = v * v
            z2 += v2
            z4 += v2 * v2
            for i in range(d):
                k = bins[j, i]
                dx = x[j, i] - par[i, k, 0]
                e = v - par[i, k, 1] - par[i, k, 2] * dx
                e2 = e * e
                sums[i, 0] += e2 * par[i, k, 3]
                # leave-one-out residual: e / (1 - leverage)
                r = 1.0 / (1.0 - par[i, k, 5] - dx * dx * par[i, k, 4])
                el2 = e2 * r * r
                sums[i, 1] += el2
                sums[i, 2] += el2 * el2
                sums[i, 3] += v2 * el2
        for i in range(d):
            t = sums[i, 0] / n
            # psi = (1 - S) z^2 - e^2 = t z^2 - e^2: its mean and mean square from the sums
            mean_psi = (t * z2 - sums[i, 1]) / n
            mean_sq = (t * t * z4 - 2.0 * t * sums[i, 3] + sums[i, 2]) / n
            first[c, i] = 1.0 - t
            var_psi[c, i] = max(mean_sq - mean_psi * mean_psi, 0.0)
    return first, var_psi, first_coarse
