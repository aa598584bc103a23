"""The next runs to make after a data file's rows: a space-filling extension of its design
(``uqguide suggest``).

Rule: **greedy maximin over scrambled Sobol' candidates, in the inputs' probability space.**

1. The existing rows are mapped to the unit hypercube by the inputs' CDFs
   (:meth:`~uqguide.core.inputs.InputSpace.to_unit`; a correlated group decorrelated first),
   where distance measures how far apart two runs are in probability: a normal input's tails
   take no more room than their probability.
2. Candidates are ``max(64 n, 4096)`` points (rounded up to a power of two) of a scrambled
   Sobol' sequence seeded by the config's seed and the number of rows, so each round of the
   loop (run, append, fit again) gets fresh candidates.
3. ``n`` times: the candidate farthest from every row and every point already picked
   (Euclidean distance to its nearest neighbour) is picked; ties go to the first candidate.
4. The picks are mapped back to the inputs by :meth:`~uqguide.core.inputs.InputSpace.from_unit`.

Maximin fills the largest holes of the existing design first, whatever design it was (iid,
Sobol', a grid with gaps), which is what a regression PCE's next fit needs most; the Sobol'
candidates keep the picks themselves spread, and 64 candidates per pick make the chosen
points' nearest-neighbour distances within a few percent of the best possible greedy choice.
The added points are not iid draws: Monte Carlo on the grown file is then a quasi-random
design (its intervals an upper bound), a PCE fit is unaffected.
"""

from __future__ import annotations

import numpy as np

from ...core.inputs import InputSpace

#: Candidates per point asked for (and their least number).
CANDIDATES_PER_POINT, MIN_CANDIDATES = 64, 4096
#: Keeps points off the cube's faces, where a normal's inverse CDF is infinite.
_U_EPS = 2.0**-53


def suggest_runs(space: InputSpace, x: np.ndarray, n: int, seed: int) -> np.ndarray:
    """``n`` new runs that extend the design ``x`` (module docstring: the rule).

    Parameters
    ----------
    space : InputSpace
        The config's inputs.
    x : ndarray, shape (N, d)
        The existing rows (SI units, columns in ``space.names`` order); may be empty.
    n : int
        Runs to suggest, at least 1.
    seed : int
        The config's seed.

    Returns
    -------
    ndarray, shape (n, d)
        The new runs' inputs, SI units.
    """
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
