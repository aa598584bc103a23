"""Thruster output error of [C] section 4.2 as a keyed, counter-based random stream.

A factor ``1 + U(-w, w)`` per body axis and control period (A25), from a SplitMix64 stream per
sample keyed by its inputs (:func:`sample_keys`, :func:`uniform`), so that a sample's outputs do
not depend on its batch: docs/papers.md#gmm-ftc-target-thruster-error-and-inputs.
"""

from __future__ import annotations

import numpy as np

_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)


def _mix(z: np.ndarray) -> np.ndarray:
    """SplitMix64 output function (a bijection of uint64)."""
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


def sample_keys(seed: int, values: np.ndarray) -> np.ndarray:
    """Stream keys (n,) uint64 from the noise seed (``0 <= seed < 2**64``) and each sample's inputs
    (n, d), nominal ones included; only their single-precision roundings enter the key."""
    single = np.ascontiguousarray(values, dtype=np.float32)
    n = single.shape[0]
    with np.errstate(over="ignore"):
        key = np.full(n, _mix(np.uint64(seed) + _GAMMA), dtype=np.uint64)
        for col in single.view(np.uint32).T.astype(np.uint64):
            key = _mix(key ^ col + _GAMMA)
    return key


def seed_keys(seeds: np.ndarray) -> np.ndarray:
    """Stream keys for explicit replicate seeds (e.g. the nominal report's noise seeds)."""
    with np.errstate(over="ignore"):
        return _mix(np.asarray(seeds, dtype=np.uint64) + _GAMMA)


def uniform(keys: np.ndarray, index: int, size: int = 3) -> np.ndarray:
    """Elements ``index * size + (0 .. size-1)`` of each stream, uniform in [0, 1), shape (n, size):
    ``index`` the control period, ``size`` the 3 axes."""
    j = np.uint64(index * size + 1) + np.arange(size, dtype=np.uint64)
    with np.errstate(over="ignore"):
        z = _mix(keys[:, None] + j[None, :] * _GAMMA)
    return (z >> np.uint64(11)).astype(np.float64) * 2.0**-53
