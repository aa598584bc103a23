"""First-order Sobol' indices from a plain Monte Carlo sample ("given data": no special design).

Per input the runs are cut by rank into :func:`n_bins` bins of equal counts; within each bin the
output's least-squares line in the input leaves a residual, and the index is one minus the pooled
residual variance over the output's variance. The interval is ``S_i -+ 1.96 se`` from the
influence function (at least the rounding's width), its upper end raised by a bound on the bias
(twice what the index from bins twice as wide reads lower); the sums come from
:mod:`uqguide.stats.sobol_bins_kernel`.
Derivation and measured coverage: docs/error-budget.md#the-given-data-estimator-in-detail.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The smallest sample that gets indices: two bins of six runs (a line in each, with residual
#: degrees of freedom to spare).
MIN_RUNS = 12

#: Half-width of a 95% normal interval in standard errors.
Z95 = 1.959963984540054

#: The bias bound over the coarse bins' shortfall: ``1 / (2^q - 1)`` for a bias falling at least
#: as ``h^q`` with ``q = log2 1.5``, margin for a jump in ``E[y | x_i]`` (``q = 1`` on average,
#: less for some places of the jump in its bin); docs/error-budget.md.
BIAS_MARGIN = 2.0


def half_width(se: np.ndarray, n: int) -> np.ndarray:
    """The half-width of a 95% interval of an index from ``n`` runs, ``1.96 se``, and at least
    ``n`` machine epsilons: the worst-case rounding of the ``n``-term sums the index is made
    of. Where the influence function vanishes (an output that is a line in one input: ``S =
    1`` and no residual) ``se`` is 0 and the interval would be as narrow as the rounding, so
    that another machine's last bits could fall outside it (a gate's tolerance is its width)."""
    return np.maximum(Z95 * se, n * np.finfo(float).eps)


@dataclass(frozen=True)
class FirstOrderIndices:
    """First-order indices ``first (C, d)`` of ``C`` output columns on ``d`` inputs (NaN for a
    column that does not vary), their influence-function standard errors ``se (C, d)`` and the
    bound ``bias (C, d)`` on how far the estimator reads low (:data:`BIAS_MARGIN` times the
    index less the coarse bins' index, 0 where that is negative)."""

    first: np.ndarray
    se: np.ndarray
    bias: np.ndarray
    n_bins: int
    n_runs: int

    @property
    def ci(self) -> np.ndarray:
        """95% intervals ``(2, C, d)`` (low, high): ``first - h``, ``first + h + bias``, ``h``
        the :func:`half_width` of ``se``."""
        h = half_width(self.se, self.n_runs)
        return np.stack([self.first - h, self.first + h + self.bias])


def n_bins(n: int) -> int:
    """Bins per input for ``n`` runs: ``round(sqrt(n) / 2)``, bins of ``2 sqrt(n)`` runs. The
    noise's second-order term grows with the parameters per run (a line: two per bin), the bias
    of a line falls as ``1/M^4``: bins twice as long as a bin mean's ``sqrt(n)`` keep that noise
    at the bin means' while the bias stays far below it."""
    return max(2, int(round(np.sqrt(n) / 2)))


def coarse_of(bins: int) -> np.ndarray:
    """Each of ``bins`` bins' coarse bin: pairs of neighbours, the last coarse bin taking an odd
    bin over (one coarse bin when ``bins < 4``)."""
    return np.minimum(np.arange(bins) // 2, max(1, bins // 2) - 1).astype(np.int64)


@dataclass(frozen=True)
class RankBins:
    """Every input's equal-count bins of one sample and the inputs' moments in them
    (:func:`rank_bins`): made once, used for every output column of the sample."""

    bin_of: np.ndarray  # (n, d) int32
    sizes: np.ndarray  # (M,) float
    coarse: np.ndarray  # (M,): each bin's coarse bin
    lines: tuple[np.ndarray, ...]  # sobol_bins_kernel.bin_lines of the sample

    @property
    def n_bins(self) -> int:
        return int(self.sizes.size)


def rank_bins(x: np.ndarray, bins: int | None = None) -> RankBins:
    """The bins of :func:`first_order_indices` for the inputs ``x (n, d)`` (``bins``:
    default :func:`n_bins`); ``n >= 3 * bins`` (a line through a bin needs 3 runs to leave a
    residual)."""
    from .sobol_bins_kernel import bin_lines

    x = np.ascontiguousarray(x, dtype=float)
    m = bins or n_bins(x.shape[0])
    if x.shape[0] < 3 * m:
        raise ValueError(f"{x.shape[0]} runs cannot fill {m} bins of at least 3")
    bin_of, sizes = bin_of_runs(x, m)
    coarse = coarse_of(m)
    return RankBins(bin_of, sizes, coarse,
                    bin_lines(x, bin_of, sizes, coarse, int(coarse[-1]) + 1))


def bin_of_runs(x: np.ndarray, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Equal-count bins of every input ``x (n, d)`` by rank, ``bins`` at most ``n / 2``.

    Returns each run's bin per input ``(n, d)`` (ties in NumPy's sort order, fixed by the values
    and their order: the same whatever the worker count) and the runs per bin ``(M,)``.
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

    ``x (n, d)``: the runs' inputs (bins by rank, lines in the inputs' own units); ``lanes (C,
    n)``: output columns, runs along each row (lane-major), failed runs left out, in the order of
    ``x``;
    ``bins`` default :func:`n_bins`; ``binned``: bins of ``x`` made already (:func:`rank_bins`,
    so several outputs sort the inputs once). NaN for columns without variance, and everywhere
    when ``n < MIN_RUNS``.
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
        return FirstOrderIndices(nan, nan.copy(), nan.copy(), m, n)
    if binned is None:
        binned = rank_bins(x, m)
    first, var_psi, coarse = binned_indices(
        lanes, np.ascontiguousarray(x), binned.bin_of, binned.sizes, binned.coarse,
        *binned.lines)
    return FirstOrderIndices(first, np.sqrt(var_psi / n),
                             BIAS_MARGIN * np.maximum(first - coarse, 0.0), m, n)
