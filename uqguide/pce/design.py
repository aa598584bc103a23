"""Experimental designs on the unit cube for regression PCE, and the surrogate's draws, all
deterministic from the seed and keyed by the method's label (:func:`stream`), so adding a method
to a config does not change another's numbers.
"""

from __future__ import annotations

import zlib
from collections.abc import Iterator

import numpy as np

_U_EPS = 2.0**-53  # a coordinate of exactly 0 or 1 would map to an infinite normal input

DESIGN_STREAM, SURROGATE_STREAM, VALIDATION_STREAM = 0, 1, 2


def stream(seed: int, label: str, kind: int, batch: int = 0) -> np.random.SeedSequence:
    """The SeedSequence of one use (``kind``: design or surrogate draws) of a method entry."""
    return np.random.SeedSequence([int(seed), zlib.crc32(label.encode()), kind, batch])


def unit_design(d: int, start: int, stop: int, sampling: str, seed: int, label: str,
                batch: int = 0) -> np.ndarray:
    """Rows ``start..stop-1`` of the method's design on the open unit cube, ``(stop-start, d)``.

    ``"sobol"``: rows of one scrambled sequence, so every enrichment extends a single
    low-discrepancy set; ``"lhs"``: a new Latin hypercube drawn from stream ``batch``.
    """
    n = stop - start
    if n <= 0:
        return np.empty((0, d))
    from scipy.stats import qmc

    if sampling == "sobol":
        rng = np.random.default_rng(stream(seed, label, DESIGN_STREAM))
        power = int(np.ceil(np.log2(max(stop, 1))))
        u = qmc.Sobol(d=d, scramble=True, seed=rng).random_base2(power)[start:stop]
    elif sampling == "lhs":
        rng = np.random.default_rng(stream(seed, label, DESIGN_STREAM, batch))
        u = qmc.LatinHypercube(d=d, seed=rng).random(n)
    else:
        raise ValueError(f"unknown sampling '{sampling}' (sobol or lhs)")
    return np.clip(u, _U_EPS, 1 - _U_EPS)


def surrogate_draws(d: int, n: int, seed: int | np.random.SeedSequence, chunk: int,
                    sampling: str = "random") -> Iterator[np.ndarray]:
    """Points ``(m, d)`` on the open unit cube, in chunks, for sampling a surrogate.

    ``"random"``: ``n`` rows of one Generator stream; ``"sobol"``: scrambled Sobol' points, ``n``
    rounded up to a power of two. Either gives the same points whatever the chunking.
    """
    rng = np.random.default_rng(seed)
    if sampling == "random":
        for start in range(0, n, max(1, chunk)):
            yield np.clip(rng.random((min(chunk, n - start), d)), _U_EPS, 1 - _U_EPS)
        return
    if sampling != "sobol":
        raise ValueError(f"unknown surrogate sampling '{sampling}' (random or sobol)")
    total = 1 << max(0, int(np.ceil(np.log2(max(n, 1)))))
    step = 1 << max(0, int(np.floor(np.log2(max(1, min(chunk, total))))))
    from scipy.stats import qmc

    sampler = qmc.Sobol(d=d, scramble=True, seed=rng)
    for _ in range(total // step):
        yield np.clip(sampler.random(step), _U_EPS, 1 - _U_EPS)
