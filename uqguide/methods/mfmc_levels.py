"""Outputs of several fidelity levels put side by side, for :mod:`uqguide.methods.mfmc`.

Levels may record their series on different grids (another step, another stop time). Every
level's series is compared on the highest level's grid: taken at the same times when its own
grid holds them (to 1e-9 of the step), else linearly interpolated per sample (held at the ends),
and the method says which levels were interpolated.
"""

from __future__ import annotations

import numpy as np

from ..core.types import ModelOutput


def on_grid(series: np.ndarray, grid: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, str]:
    """A series ``(n, T, k)`` on ``grid (T,)`` at the times ``target (T0,)``.

    Returns
    -------
    values : ndarray, shape (n, T0, k)
    how : {"same", "sampled", "interpolated"}
        Same grid; the target times picked from the grid; linear interpolation.
    """
    if grid.shape == target.shape and np.array_equal(grid, target):
        return series, "same"
    tol = 1e-9 * max(float(np.max(np.abs(grid))) if grid.size else 1.0, 1.0)
    idx = np.clip(np.searchsorted(grid, target - tol), 0, grid.size - 1)
    if np.all(np.abs(grid[idx] - target) <= tol):
        return series[:, idx], "sampled"
    hi = np.clip(np.searchsorted(grid, target), 1, grid.size - 1)
    lo = hi - 1
    span = grid[hi] - grid[lo]
    w = np.clip(np.where(span > 0, (target - grid[lo]) / np.where(span > 0, span, 1), 0), 0, 1)
    return series[:, lo] * (1 - w)[None, :, None] + series[:, hi] * w[None, :, None], \
        "interpolated"


def values(out: ModelOutput, name: str, target: np.ndarray) -> tuple[np.ndarray, str]:
    """The output ``name`` flattened to ``(n, Q)``: a scalar's ``k`` components, or a series'
    ``T0 k`` values on the highest level's grid ``target`` (time-major), with how the grid was
    matched (``"same"`` for a scalar)."""
    if name in out.scalars:
        v = out.scalars[name]
        return v.reshape(v.shape[0], -1).astype(float), "same"
    s, how = on_grid(out.series[name], out.time, target)
    return s.reshape(s.shape[0], -1).astype(float), how


def usable_rows(failed: list[np.ndarray], sizes: np.ndarray) -> np.ndarray:
    """Rows ``(m_last,)`` that failed at no level they ran at (a failed row is left out at
    every level: :mod:`uqguide.stats.mfmc_estimator`)."""
    ok = np.ones(int(sizes[-1]), dtype=bool)
    for f, m in zip(failed, sizes):
        ok[:int(m)] &= ~np.asarray(f[:int(m)], dtype=bool)
    return ok
