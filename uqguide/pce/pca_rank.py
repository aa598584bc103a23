"""How many principal components a series keeps: the moments' rule (:func:`choose`), the
smallest count whose truncation error of the four moments at every step is at most the
surrogate's own error.

Why not a fraction of the variance, and how the errors are scaled:
docs/methods.md#time-series-in-the-adaptive-pce.
"""

from __future__ import annotations

import numpy as np

from .pca import Decomposition

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
