"""Principal components of a time-series output: a correlation PCA of its ``(N, T k)`` runs,
whose scores are fitted and mapped back to the columns (``Expansion.mix``); constant columns
keep their value and take no component. How many are kept: the moments' rule (:func:`choose`),
the smallest count whose truncation error of the four moments at every step is at most the
surrogate's own error.

Why correlation scaling and not a fraction of the variance, and how the errors are scaled:
docs/methods.md#time-series-in-the-adaptive-pce.
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


#: The least number of components kept: those that hold this fraction of the scaled variance
#: (the former default ``variance_fraction``).
FLOOR_FRACTION = 0.9999
#: Components fitted as candidates at most (one joint fit; more cost time for variance below
#: round-off on smooth series, and on rough ones are fits of noise).
MAX_COMPONENTS = 40
#: A component whose singular value is below this fraction of the first holds round-off.
ROUNDOFF = 1e-8
_FLAT = 1e-7  # std / |mean| at or below which a step's spread is round-off


def candidates(dec: Decomposition, n_runs: int) -> int:
    """How many components to fit before choosing: every component above round-off, at
    least :data:`FLOOR_FRACTION`'s count, at most :data:`MAX_COMPONENTS` and ``n_runs - 2``."""
    if not dec.size:
        return 0
    s = np.sqrt(dec.energy)
    above = int(np.count_nonzero(s > ROUNDOFF * s[0]))
    floor = dec.count_for_fraction(FLOOR_FRACTION)
    return max(floor, min(above, MAX_COMPONENTS, max(n_runs - 2, 1)))


def _moments(y: np.ndarray) -> np.ndarray:
    """Sample mean, std, skewness and kurtosis ``(4, m)`` of ``y (N, m)``."""
    mean = y.mean(axis=0)
    z = y - mean
    m2 = np.mean(z * z, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.array([mean, np.sqrt(m2), np.mean(z**3, axis=0) / m2**1.5,
                         np.mean(z**4, axis=0) / m2**2])


def _scaled(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Errors ``(4, m)`` of moments ``a`` against ``b`` on the rule's scale."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.array([np.abs(a[0] - b[0]) / b[1], np.abs(a[1] - b[1]) / b[1],
                         np.abs(a[2] - b[2]), np.abs(a[3] - b[3]) / b[3]])


def moment_steps(y: np.ndarray) -> np.ndarray:
    """Columns ``(m,)`` of ``y`` the rule judges: spread above round-off."""
    mom = _moments(y)
    return mom[1] > _FLAT * np.maximum(np.abs(mom[0]), 1e-300)


def truncation_errors(dec: Decomposition, y: np.ndarray, r: int, steps: np.ndarray,
                      full: np.ndarray | None = None) -> np.ndarray:
    """Truncation errors ``(4, s)`` of ``r`` components at the judged steps (``full``: the
    moments of ``y`` there, if already computed)."""
    full = _moments(y[:, steps]) if full is None else full
    return _scaled(_moments(dec.reconstruct(dec.scores[:, :r])[:, steps]), full)


def surrogate_errors(dec: Decomposition, loo_resid: np.ndarray, steps: np.ndarray
                     ) -> np.ndarray:
    """The surrogate's errors ``(4,)`` (root mean square over the judged steps) of the first
    ``r = loo_resid.shape[1]`` components, from their leave-one-out residuals ``(N, r)``."""
    r = loo_resid.shape[1]
    kept = dec.reconstruct(dec.scores[:, :r])[:, steps]
    loo = dec.reconstruct(dec.scores[:, :r] - loo_resid)[:, steps]
    err = _scaled(_moments(loo), _moments(kept))
    return np.sqrt(np.mean(np.where(np.isfinite(err), err, 0.0) ** 2, axis=1))


def choose(dec: Decomposition, y: np.ndarray, loo_resid: np.ndarray) -> int:
    """The number of components the rule keeps, from the leave-one-out residuals ``(N, R)``
    of the ``R`` fitted candidates."""
    n_fit = loo_resid.shape[1]
    floor = min(dec.count_for_fraction(FLOOR_FRACTION), n_fit)
    steps = moment_steps(y)
    if not steps.any():
        return floor
    full = _moments(y[:, steps])
    for r in range(max(floor, 1), n_fit + 1):
        trunc = truncation_errors(dec, y, r, steps, full)
        worst = np.max(np.where(np.isfinite(trunc), trunc, 0.0), axis=1)
        if np.all(worst <= surrogate_errors(dec, loo_resid[:, :r], steps)):
            return r
    return n_fit
