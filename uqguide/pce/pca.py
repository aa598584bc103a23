"""Principal components of a time-series output (spec 4.4, vector and time-series outputs).

The ``(N, T k)`` runs of a series output are compressed to ``r`` principal-component scores, one
adaptive PCE is fitted per score, and the scores' expansions are mapped back to the ``T k``
columns (``Expansion.mix``).

Each column is scaled by its sample standard deviation before the decomposition (a correlation
PCA): the retained fraction of variance is then a fraction of every time step's variance on
average, so early steps of small dispersion (where the LOS rate's skewness and kurtosis are
largest) are represented as well as late steps of large dispersion. Columns whose runs all agree
(e.g. ``t = 0`` with no initial dispersion) are constants: they keep their value, take no
component, and get zero variance (NaN skewness and kurtosis).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Components:
    """Principal components of ``N`` runs of an output with ``m`` columns.

    Attributes
    ----------
    scores : ndarray, shape (N, r)
        Scores of the runs (zero-mean).
    mix : ndarray, shape (r + 1, m)
        Rows 0..r-1: the components in output units; row r: the sample mean. An expansion of the
        scores extended by a constant-one column maps back through ``mix``.
    explained : float
        Fraction of the (scaled) variance the ``r`` components keep.
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


def principal_components(y: np.ndarray, variance_fraction: float = 0.9999) -> Components:
    """Correlation PCA of ``y (N, m)`` keeping ``variance_fraction`` of the variance.

    Parameters
    ----------
    y : ndarray, shape (N, m)
    variance_fraction : float in (0, 1]

    Returns
    -------
    Components
    """
    n, m = y.shape
    mean = y.mean(axis=0)
    varying = ~constant_columns(y)
    mix = np.zeros((1, m))
    mix[0] = np.where(varying, mean, y[0] if n else 0.0)
    if not varying.any() or n < 2:
        return Components(np.zeros((n, 0)), mix, 1.0)
    scale = y[:, varying].std(axis=0)
    z = (y[:, varying] - mean[varying]) / scale
    u, s, vt = np.linalg.svd(z, full_matrices=False)
    energy = s**2
    cum = np.cumsum(energy) / energy.sum()
    r = int(np.searchsorted(cum, variance_fraction - 1e-15) + 1)
    r = min(r, s.size)
    comps = np.zeros((r, m))
    comps[:, varying] = vt[:r] * scale
    return Components(u[:, :r] * s[:r], np.vstack([comps, mix]), float(cum[r - 1]))
