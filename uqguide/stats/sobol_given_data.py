"""First-order Sobol' indices from a plain Monte Carlo sample ("given data": no special design).

The estimator
-------------
For input ``i`` the runs are sorted by ``x_i`` and cut into ``M`` bins of equal counts
(``M = round(sqrt(n))``, so a bin holds ``n_b ~ sqrt(n)`` runs). Within a bin every pair of runs
is a pick-freeze pair: their ``x_i`` nearly agree and everything else is independent. With the
output centred (``y~ = y - mean``) and ``S_b``, ``Q_b`` the bin's sum and sum of squares,

    V_i = 1/n sum_b (S_b^2 - Q_b) / (n_b - 1) + D / n,        S_i = V_i / D,

``D`` the sample variance. ``(S_b^2 - Q_b) / (n_b - 1)`` is the U-statistic of all pairs in the
bin: it estimates ``n_b E[y | bin]^2`` without the ``sigma_b^2 / n_b`` noise bias that makes the
plain binned variance of bin means (EASI's, Plischke 2010) read ``M / n`` too high (a 0.022
floor on a null index at ``n = 2000``); the ``D / n`` term is the U-statistic's correction
for centring on the sample mean. This is the all-pairs form of the rank-neighbour estimator of
Gamboa, Klein & Lagnoux (2022, "Global sensitivity analysis: a novel generation of mighty
estimators based on rank statistics", Bernoulli 28(4)), which pairs each run with its rank
neighbour only (Chatterjee's xi with bins of two): using every pair of a bin instead of one
neighbour cuts its variance (at ``n = 2000`` on Ishigami, over 50 seeds: standard deviation
0.014 against 0.018 for ``S_1``, 0.007 against 0.030 for the null ``S_3``;
benchmarks/sensitivity_peers.py). SALib's RBD-FAST is as accurate on Ishigami (a periodic
function, its home ground) at 250 times the CPU; a Saltelli design of the same 2000 runs is
three times less accurate on ``S_1`` and ``S_3``.

Bias and variance
-----------------
- Bias: the binning replaces ``E[y | x_i]`` by its bin average, which loses the variance of
  ``E[y | x_i]`` within a bin: ``-E[g'(x)^2] h^2 / 12`` for a smooth ``g = E[y | x_i]`` and bins
  of width ``h`` (in the input's quantile scale ``h = 1 / M``). On Ishigami at ``n = 2000``:
  below 0.003 for every index (mean error over 50 seeds: 0.0004, -0.0023, 0.0007). It
  vanishes as ``M`` grows.
- Variance: the estimator is asymptotically normal with the efficient influence function of
  ``V_i / D`` (Da Veiga & Gamboa 2013, "Efficient estimation of sensitivity indices", J.
  Nonparametr. Stat. 25(3)), in standardised units ``psi = 2 y~ g~ - g~^2 - S_i y~^2``,
  ``g~ = E[y~ | x_i]``: ``Var(S_i) ~ Var(psi) / n``. The standard error uses ``psi`` at every
  run with ``g~`` the run's leave-one-out bin mean; the noise of that mean (variance
  ``sigma_b^2 / (n_b - 1)``) makes the estimate a little large, which stands in for the
  estimator's own second-order term (``2 (1 - S_i)^2 / (n (n_b - 1))``, the U-statistics'
  degenerate part). So the 95% interval ``S_i -+ 1.96 se`` is slightly conservative: it holds
  the exact values of the Ishigami indices in 98%, 98% and 100% of 50 seeds at 2000 runs
  (benchmarks/sensitivity_peers.py), and at a null index (whose influence function vanishes) it
  is about 1.4 times as wide as the estimator's spread (mean se 0.009 against 0.007).

A correlated input's index is its full first-order index, ``Var(E[y | x_i]) / Var(y)``, which
includes what it carries of the inputs it is correlated with: the indices then need not sum to
at most 1 (a group index, :mod:`uqguide.stats.sobol_groups`, is the clean quantity).

Cost: per input one sort of ``x_i``; per output column one pass over its runs that sums the
powers 1-4 of its standardised values into every input's bins
(:mod:`uqguide.stats.sobol_bins_kernel`); the index and its standard error follow from those
bin sums.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The smallest sample that gets indices: at least four bins of at least three runs.
MIN_RUNS = 12

#: Half-width of a 95% normal interval in standard errors.
Z95 = 1.959963984540054


@dataclass(frozen=True)
class FirstOrderIndices:
    """First-order indices of ``C`` output columns on ``d`` inputs.

    Attributes
    ----------
    first : ndarray, shape (C, d)
        The estimates (NaN for a column that does not vary).
    se : ndarray, shape (C, d)
        Their standard errors (influence function, module docstring).
    n_bins : int
        Bins per input.
    n_runs : int
        Runs used.
    """

    first: np.ndarray
    se: np.ndarray
    n_bins: int
    n_runs: int

    @property
    def ci(self) -> np.ndarray:
        """95% intervals ``(2, C, d)`` (low, high): ``first -+ 1.96 se``."""
        return np.stack([self.first - Z95 * self.se, self.first + Z95 * self.se])


def n_bins(n: int) -> int:
    """Bins per input for ``n`` runs: ``round(sqrt(n))`` (bias ``~ 1/M^2`` against the
    noise's second-order term ``~ 1/n_b``: both fall as ``1/n``, neither dominates)."""
    return max(2, int(round(np.sqrt(n))))


@dataclass(frozen=True)
class RankBins:
    """Every input's equal-count bins of one sample (:func:`rank_bins`): made once, used for
    every output column of the sample."""

    bin_of: np.ndarray  # (n, d) int32
    sizes: np.ndarray  # (M,) float

    @property
    def n_bins(self) -> int:
        return int(self.sizes.size)


def rank_bins(x: np.ndarray, bins: int | None = None) -> RankBins:
    """The bins of :func:`first_order_indices` for the inputs ``x (n, d)`` (``bins``:
    default :func:`n_bins`); ``n >= 3 * bins`` (else a bin could hold fewer than 2 runs)."""
    x = np.asarray(x, dtype=float)
    m = bins or n_bins(x.shape[0])
    if x.shape[0] < 2 * m:
        raise ValueError(f"{x.shape[0]} runs cannot fill {m} bins of at least 2")
    return RankBins(*bin_of_runs(x, m))


def bin_of_runs(x: np.ndarray, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Equal-count bins of every input by rank.

    Parameters
    ----------
    x : ndarray, shape (n, d)
    bins : int
        ``M``, at most ``n / 2``.

    Returns
    -------
    bin_of : ndarray of int32, shape (n, d)
        Run ``j``'s bin for input ``i`` (the order of tied values is NumPy's sort's, fixed by
        the values and their order: the same numbers whatever the worker count).
    sizes : ndarray of float, shape (M,)
        Runs per bin (``floor`` or ``ceil`` of ``n / M``).
    """
    n, d = x.shape
    starts = (np.arange(bins) * n) // bins
    sizes = np.diff(np.append(starts, n))
    label = np.repeat(np.arange(bins, dtype=np.int32), sizes)
    bin_of = np.empty((n, d), dtype=np.int32)
    # one contiguous row per input: argsort of a row is a third faster than of a column
    for i, order in enumerate(np.argsort(np.ascontiguousarray(x.T), axis=1)):
        bin_of[order, i] = label
    return bin_of, sizes.astype(float)


def first_order_indices(x: np.ndarray, lanes: np.ndarray, bins: int | None = None,
                        binned: RankBins | None = None) -> FirstOrderIndices:
    """Given-data first-order Sobol' indices of every output column on every input.

    Parameters
    ----------
    x : ndarray, shape (n, d)
        The runs' inputs (any units: only their ranks matter).
    lanes : ndarray, shape (C, n)
        Output columns, the runs along each row (lane-major, as Monte Carlo keeps its
        per-run series values); failed runs left out, in the order of ``x``.
    bins : int, optional
        Bins per input (default :func:`n_bins`).
    binned : RankBins, optional
        The bins of ``x`` made already (:func:`rank_bins`): several outputs of one sample
        sort the inputs once.

    Returns
    -------
    FirstOrderIndices
        ``first`` and ``se`` of shape ``(C, d)``; NaN for columns without variance, and
        everywhere when ``n < MIN_RUNS``.
    """
    from .sobol_bins_kernel import binned_indices

    x = np.asarray(x, dtype=float)
    lanes = np.ascontiguousarray(lanes, dtype=float)
    n, d = x.shape
    if lanes.shape[1] != n:
        raise ValueError(f"lanes hold {lanes.shape[1]} runs, x {n}")
    m = binned.n_bins if binned is not None else (bins or n_bins(n))
    if n < MIN_RUNS or m < 2 or n < 3 * m or d == 0:
        nan = np.full((lanes.shape[0], d), np.nan)
        return FirstOrderIndices(nan, nan.copy(), m, n)
    if binned is None:
        binned = RankBins(*bin_of_runs(x, m))
    first, var_psi = binned_indices(lanes, binned.bin_of, binned.sizes)
    return FirstOrderIndices(first, np.sqrt(var_psi / n), m, n)
