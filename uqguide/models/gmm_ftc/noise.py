"""Thruster output error of [C] section 4.2 as a keyed, counter-based random stream.

The paper's "thruster output error of +-5 %" is read (spec 8, A25) as a multiplicative factor
``1 + delta`` per body axis and per control period, ``delta ~ U(-w, w)``, independent across
axes, periods and runs.

A model must be a function of its inputs (uq-methods.md 1): the same sample must give the same
outputs whatever batch or chunk it is evaluated in. So the errors are not drawn from a
generator shared by the batch; each sample owns a SplitMix64 stream (Steele, Lea & Flood 2014)
whose key is a hash of the noise seed and the sample's input values rounded to single precision
(a key from the full double would hand a sample a new noise history whenever its inputs move by
round-off, e.g. another CPU's last bit of an inverse CDF; single precision moves only when a
value lies within round-off of a float32 rounding boundary, about 1 in 1e5 for a 1e-12 move),
and the error of period
``k``, axis ``i`` is element ``3 k + i`` of that stream. SplitMix64 outputs are a bijective
mix of ``key + j * gamma``, so the element is computed directly from its index, vectorised over
the batch, with no per-sample generator objects.
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
    """Stream keys from a seed and each sample's input values.

    Parameters
    ----------
    seed : int
        Noise seed (a model parameter), ``0 <= seed < 2**64``.
    values : ndarray, shape (n, d)
        The sample's inputs (all of them, nominal ones included); only their single-precision
        roundings enter the key.

    Returns
    -------
    ndarray of uint64, shape (n,)
    """
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
    """Elements ``index * size + (0 .. size-1)`` of each stream, uniform in [0, 1).

    Parameters
    ----------
    keys : ndarray of uint64, shape (n,)
    index : int
        Block index (the control period).
    size : int
        Block length (3 axes).

    Returns
    -------
    ndarray, shape (n, size)
    """
    j = np.uint64(index * size + 1) + np.arange(size, dtype=np.uint64)
    with np.errstate(over="ignore"):
        z = _mix(keys[:, None] + j[None, :] * _GAMMA)
    return (z >> np.uint64(11)).astype(np.float64) * 2.0**-53
