"""Principal components of a time-series output: a correlation PCA of its ``(N, T k)`` runs,
whose scores are fitted and mapped back to the columns (``Expansion.mix``); constant columns
keep their value and take no component.

Why correlation scaling: docs/methods.md#time-series-in-the-adaptive-pce.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Components:
    """Principal components of ``N`` runs of an output with ``m`` columns.

    ``scores (N, r)``: zero-mean; ``mix (r + 1, m)``: rows 0..r-1 the components in output
    units, row r the sample mean (scores extended by a constant-one column map back through
    it); ``explained``: fraction of the scaled variance kept.
    """

    scores: np.ndarray
    mix: np.ndarray
    explained: float

    @property
    def n_components(self) -> int:
        return int(self.scores.shape[1])


def constant_columns(y: np.ndarray) -> np.ndarray:
    """Columns ``(m,)`` of ``y (N, m)`` whose values agree to round-off (1e-12 relative)."""
    spread = y.max(axis=0) - y.min(axis=0)
    return spread <= 1e-12 * np.maximum(np.abs(y).max(axis=0), 1e-300)


@dataclass
class Decomposition:
    """Every principal component of ``N`` runs of an output with ``m`` columns (correlation
    PCA); :meth:`components` keeps the first ``r``.

    ``scores (N, K)``: largest first; ``axes (K, m)``: in output units (zero on constant
    columns); ``mean (m,)``; ``energy (K,)``: squared singular values (scaled variance times
    ``N``); ``varying (m,)``: columns that are not constant.
    """

    scores: np.ndarray
    axes: np.ndarray
    mean: np.ndarray
    energy: np.ndarray
    varying: np.ndarray

    @property
    def size(self) -> int:
        return int(self.energy.size)

    def count_for_fraction(self, variance_fraction: float) -> int:
        """The fewest components that keep ``variance_fraction`` of the scaled variance."""
        if not self.size:
            return 0
        cum = np.cumsum(self.energy) / self.energy.sum()
        return min(int(np.searchsorted(cum, variance_fraction - 1e-15) + 1), self.size)

    def explained(self, r: int) -> float:
        total = self.energy.sum()
        return float(self.energy[:r].sum() / total) if total > 0 else 1.0

    def components(self, r: int) -> Components:
        """The first ``r`` components."""
        r = min(r, self.size)
        mix = np.vstack([self.axes[:r], self.mean[None, :]])
        return Components(self.scores[:, :r], mix, self.explained(r) if r else 1.0)

    def reconstruct(self, scores: np.ndarray) -> np.ndarray:
        """Output columns ``(n, m)`` of scores ``(n, r)`` of the first ``r`` components."""
        return self.mean + scores @ self.axes[: scores.shape[1]]


def decompose(y: np.ndarray) -> Decomposition:
    """Correlation PCA of ``y (N, m)``: every component."""
    n, m = y.shape
    mean = y.mean(axis=0)
    varying = ~constant_columns(y)
    mean = np.where(varying, mean, y[0] if n else 0.0)
    if not varying.any() or n < 2:
        return Decomposition(np.zeros((n, 0)), np.zeros((0, m)), mean, np.zeros(0), varying)
    scale = y[:, varying].std(axis=0)
    z = (y[:, varying] - mean[varying]) / scale
    u, s, vt = np.linalg.svd(z, full_matrices=False)
    axes = np.zeros((s.size, m))
    axes[:, varying] = vt * scale
    return Decomposition(u * s, axes, mean, s**2, varying)


def principal_components(y: np.ndarray, variance_fraction: float = 0.9999) -> Components:
    """Correlation PCA of ``y (N, m)`` keeping ``variance_fraction`` in (0, 1] of the variance."""
    dec = decompose(y)
    if not dec.size:
        return dec.components(0)
    return dec.components(dec.count_for_fraction(variance_fraction))
