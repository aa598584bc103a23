"""The next runs to make after a data file's rows: a space-filling extension of its design
(``uqguide suggest``), by greedy maximin over scrambled Sobol' candidates in the inputs'
probability space.

The rule, step by step, and why maximin: docs/config.md, "The next runs: uqguide suggest".
"""

from __future__ import annotations

import numpy as np

from ...core.inputs import InputSpace

#: Candidates per point asked for (and their least number).
CANDIDATES_PER_POINT, MIN_CANDIDATES = 64, 4096
#: Keeps points off the cube's faces, where a normal's inverse CDF is infinite.
_U_EPS = 2.0**-53


def suggest_runs(space: InputSpace, x: np.ndarray, n: int, seed: int) -> np.ndarray:
    """The inputs ``(n, d)`` [SI] of ``n >= 1`` new runs that extend the design ``x (N, d)``
    (maybe empty; columns in the order of the config's inputs ``space``), drawn with the
    config's ``seed`` (module docstring: the rule)."""
    from scipy.spatial import cKDTree
    from scipy.stats import qmc

    d = space.dim
    m = max(CANDIDATES_PER_POINT * n, MIN_CANDIDATES)
    ss = np.random.SeedSequence([int(seed), int(x.shape[0]), 0x5EED])
    cand = qmc.Sobol(d=d, scramble=True, seed=np.random.default_rng(ss)).random_base2(
        int(np.ceil(np.log2(m))))
    cand = np.clip(cand, _U_EPS, 1 - _U_EPS)
    if x.shape[0]:
        nearest, _ = cKDTree(np.clip(space.to_unit(x), 0.0, 1.0)).query(cand)
        nearest = nearest**2  # squared distances: the same order, no square roots below
    else:
        nearest = np.full(cand.shape[0], np.inf)
    picked = np.empty(n, dtype=np.intp)
    for k in range(n):
        i = int(np.argmax(nearest))  # the first of equal distances
        picked[k] = i
        np.minimum(nearest, ((cand - cand[i]) ** 2).sum(axis=1), out=nearest)
    return space.from_unit(cand[picked])
