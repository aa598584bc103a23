"""First-order Sobol' indices of groups of inputs from a plain Monte Carlo sample (given data).

A group's index ``Var(E[y | x_G]) / Var(y)``: the bin-mean form of
:mod:`uqguide.stats.sobol_given_data`'s estimator with the bin replaced by each run's
:data:`NEIGHBOURS` nearest neighbours in the group's normal scores. The interval covers the
estimator's noise, not the neighbourhood's bias. Formulas and measured bias:
docs/error-budget.md#groups-of-inputs.
"""

from __future__ import annotations

import numpy as np

from .sobol_given_data import MIN_RUNS, first_order_indices, half_width


#: Neighbours per run (module docstring).
NEIGHBOURS = 2


def group_indices(x: np.ndarray, lanes: np.ndarray, groups: list[tuple[int, ...]]
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Given-data first-order indices ``(C, G)`` of groups of inputs and their 95%
    influence-function intervals ``(2, C, G)``.

    ``lanes (C, n)``: runs along each row (failed runs left out); ``groups``: each group's input
    columns, at least two (a single input's is
    :func:`uqguide.stats.sobol_given_data.first_order_indices`). NaN without variance or with
    fewer than ``MIN_RUNS`` runs.
    """
    from scipy.spatial import cKDTree
    from scipy.special import ndtri

    x = np.asarray(x, dtype=float)
    lanes = np.asarray(lanes, dtype=float)
    n = x.shape[0]
    c_all = lanes.shape[0]
    first = np.full((c_all, len(groups)), np.nan)
    se = np.full((c_all, len(groups)), np.nan)
    mean = lanes.mean(axis=1, keepdims=True)
    std = lanes.std(axis=1, ddof=1, keepdims=True) if n > 1 else np.zeros((c_all, 1))
    varies = std[:, 0] > 1e-12 * np.maximum(np.abs(mean[:, 0]), 1e-300)
    if n < MIN_RUNS or not varies.any():
        return first, np.stack([first, first])
    single = [gi for gi, cols in enumerate(groups) if len(cols) == 1]
    if single:
        one = first_order_indices(x[:, [groups[gi][0] for gi in single]], lanes)
        first[:, single], se[:, single] = one.first, one.se
    rows = np.flatnonzero(varies)
    z = (lanes[rows] - mean[rows]) / std[rows]
    ranks = ndtri((np.argsort(np.argsort(x, axis=0, kind="stable"), axis=0) + 0.5) / n)
    for gi, cols in enumerate(groups):
        if len(cols) == 1:
            continue
        k = min(NEIGHBOURS, n - 1)
        tree = cKDTree(ranks[:, list(cols)])
        _, near = tree.query(ranks[:, list(cols)], k=k + 1)
        near = near[:, 1:]  # (n, k): the run itself (distance 0) left out
        for r, zr in zip(rows, z):  # a column at a time: (n, k) values, not (C, n, k)
            g = zr[near].mean(axis=1)
            s = float(np.mean(zr * g)) + 1.0 / n
            psi = g * (2.0 * zr - g) - s * (zr * zr)
            first[r, gi] = s
            se[r, gi] = np.sqrt(psi.var() / n)
    h = half_width(se, n)
    return first, np.stack([first - h, first + h])
