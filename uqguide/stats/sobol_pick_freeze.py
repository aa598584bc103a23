"""First-order and total Sobol' indices of a pick-freeze (Saltelli) design, from mergeable sums.

The design (Saltelli et al. 2010, Comput. Phys. Commun. 181(2)) evaluates the model on two
independent samples ``A`` and ``B`` of ``N`` base rows and, per frozen set ``u`` (an input, or
a group of inputs frozen together), on ``A_B^u``: ``A`` with the columns of ``u`` taken from
``B``. With ``V`` the variance of the ``2N`` values ``f(A), f(B)``:

- first order, Saltelli 2010's estimator (its table 2, b):
  ``S_u = mean(f(B) (f(A_B^u) - f(A))) / V``;
- total, Jansen's (1999) estimator: ``ST_u = mean((f(A) - f(A_B^u))^2) / (2 V)``.

Both are means over the base rows, so a chunk of base rows reduces to sums that merge exactly
(:class:`PickFreezeSums`): per lane (an output component at a step) ``sum (f_A - c) + (f_B -
c)``, ``sum (f_A - c)^2 + (f_B - c)^2`` and per set ``sum D``, ``sum (f_B - c) D``, ``sum
(f_A - f_AB)^2`` with ``D = f_AB - f_A``, and ``sum (f_AB - c)`` over all sets, each about
a shift ``c`` (the chunk's own mean). Shifts are exchanged by exact identities when chunks
merge, and the first-order numerator is taken about the mean of all ``N (m + 2)`` values at
the end (every run's inputs are a draw from the inputs, so all estimate ``E[f]``). That
centring is the estimator SALib computes (it standardises ``Y`` by all its values first):
``mean(f(B) D)`` without it carries a term ``mean(f) mean(D)`` whose noise grows with the
output's mean, which for a miss distance of 1 km +- 1 m would swamp the index; about the
mean the product has no such term. Centred on the ``2N`` values of ``A`` and ``B`` only, the
G-function's first-order errors at ``N = 1000`` were 15% larger than SALib's.

Intervals: a Poisson bootstrap over the base rows (each row weighted by a Poisson(1) count per
resample, the same weights for all of its ``d + 2`` runs, so the pairing of ``A``, ``B`` and
``A_B^u`` is kept), percentile 95% intervals. Chosen over the asymptotic (delta-method)
variance because the weights are mergeable sums like the estimates (one more leading axis),
because it needs no per-estimator variance formula (first order, total, groups alike) and
because the ratio estimator's skewness at small ``N`` is in the percentiles; its cost is
``R`` weighted sums per base row, small beside ``d + 2`` model runs
(``benchmarks/sensitivity_peers.py`` measures the coverage).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class PickFreezeSums:
    """Weighted sums of a pick-freeze design over some base rows, about a shift per lane.

    Row ``0`` of the leading axis is the sample itself (every weight 1); rows ``1..R`` are
    bootstrap resamples.

    Attributes
    ----------
    shift : ndarray, shape (L,)
        ``c``: the value each lane's sums are taken about.
    w : ndarray, shape (R + 1,)
        Sum of the weights (base rows counted).
    p1, p2 : ndarray, shape (R + 1, L)
        ``sum w ((f_A - c) + (f_B - c))`` and ``sum w ((f_A - c)^2 + (f_B - c)^2)``.
    d, x, j : ndarray, shape (R + 1, L, m)
        Per frozen set: ``sum w D``, ``sum w (f_B - c) D`` and ``sum w (f_A - f_AB)^2``.
    q : ndarray, shape (R + 1, L)
        ``sum w sum_u (f_AB^u - c)``: with ``p1``, the mean of all runs.
    """

    shift: np.ndarray
    w: np.ndarray
    p1: np.ndarray
    p2: np.ndarray
    d: np.ndarray
    x: np.ndarray
    j: np.ndarray
    q: np.ndarray

    FIELDS = ("shift", "w", "p1", "p2", "d", "x", "j", "q")

    @classmethod
    def of(cls, f_a: np.ndarray, f_b: np.ndarray, f_ab: np.ndarray,
           weights: np.ndarray) -> PickFreezeSums:
        """The sums of one block of base rows.

        Parameters
        ----------
        f_a, f_b : ndarray, shape (b, L)
            The model's values on the rows of ``A`` and ``B`` (only good rows).
        f_ab : ndarray, shape (m, b, L)
            Its values on ``A_B^u`` of each frozen set ``u``.
        weights : ndarray, shape (R + 1, b)
            Row 0 all ones; rows 1.. the bootstrap counts of each base row.

        Returns
        -------
        PickFreezeSums
        """
        b, n_lanes = f_a.shape
        m = f_ab.shape[0]
        c = 0.5 * (f_a.mean(axis=0) + f_b.mean(axis=0)) if b else np.zeros(n_lanes)
        a, bb = f_a - c, f_b - c
        diff = np.moveaxis(f_ab, 0, -1) - f_a[:, :, None]          # (b, L, m)
        cols = np.concatenate([
            (a + bb)[:, :, None], (a * a + bb * bb)[:, :, None],
            diff, bb[:, :, None] * diff, diff * diff,
            (f_ab - c).sum(axis=0)[:, :, None]], axis=2)             # (b, L, 3 + 3m)
        s = (weights @ cols.reshape(b, -1)).reshape(weights.shape[0], n_lanes, 3 + 3 * m)
        return cls(c, weights.sum(axis=1), s[:, :, 0], s[:, :, 1], s[:, :, 2:2 + m],
                   s[:, :, 2 + m:2 + 2 * m], s[:, :, 2 + 2 * m:2 + 3 * m], s[:, :, -1])

    def shifted(self, c: np.ndarray) -> PickFreezeSums:
        """The same sums about ``c`` (exact: ``f - c = (f - shift) + (shift - c)``)."""
        delta = self.shift - c
        w = self.w[:, None]
        return PickFreezeSums(
            c, self.w, self.p1 + 2 * delta * w,
            self.p2 + 2 * delta * self.p1 + 2 * delta ** 2 * w,
            self.d, self.x + delta[:, None] * self.d, self.j,
            self.q + self.d.shape[-1] * delta * w)

    def merge(self, other: PickFreezeSums) -> PickFreezeSums:
        """The sums of both blocks of base rows, about this one's shift."""
        o = other.shifted(self.shift)
        return PickFreezeSums(self.shift, self.w + o.w, self.p1 + o.p1, self.p2 + o.p2,
                              self.d + o.d, self.x + o.x, self.j + o.j, self.q + o.q)

    def arrays(self) -> dict[str, np.ndarray]:
        return {f: getattr(self, f) for f in self.FIELDS}

    @classmethod
    def from_arrays(cls, a: dict[str, np.ndarray]) -> PickFreezeSums:
        return cls(*(np.asarray(a[f]) for f in cls.FIELDS))

    def indices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """First-order and total indices of the sample and of every resample, and ``V``.

        Returns
        -------
        first, total : ndarray, shape (R + 1, L, m)
            NaN where the variance is zero or no base row is counted.
        variance : ndarray, shape (R + 1, L)
            The variance of ``f(A), f(B)`` (population, ``1 / 2N``).
        """
        with np.errstate(divide="ignore", invalid="ignore"):
            w = self.w[:, None]
            mu = self.p1 / (2 * w)                                   # mean of A, B - shift
            var = self.p2 / (2 * w) - mu ** 2
            m = self.d.shape[-1]
            mu_all = (self.p1 + self.q) / ((m + 2) * w)              # mean of all - shift
            # a variance of round-off (a step where every run agrees) is no variance
            scale = self.p2 / (2 * w)
            var = np.where(var > 1e-12 * scale, var, np.nan)
            first = (self.x - mu_all[:, :, None] * self.d) / (w[:, :, None] * var[:, :, None])
            total = self.j / (2 * w[:, :, None] * var[:, :, None])
        return first, total, var


def percentile_interval(resampled: np.ndarray, level: float = 0.95) -> np.ndarray:
    """The percentile interval ``(2, ...)`` of resampled estimates along axis 0 (NaN where a
    resample is NaN: an interval from the defined resamples alone would be too narrow)."""
    if resampled.shape[0] == 0:
        return np.full((2,) + resampled.shape[1:], np.nan)
    lo, hi = 0.5 * (1 - level), 0.5 * (1 + level)
    with np.errstate(invalid="ignore"):
        return np.quantile(resampled, [lo, hi], axis=0)


def pick_freeze_indices(sums: PickFreezeSums, level: float = 0.95
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """First-order and total indices ``(L, m)`` and their percentile intervals ``(2, L, m)``.

    Parameters
    ----------
    sums : PickFreezeSums
        Merged over every base row (row 0 the sample, the others bootstrap resamples).
    level : float
        Interval probability.

    Returns
    -------
    first, total, first_ci, total_ci : ndarray
    """
    first, total, _ = sums.indices()
    return (first[0], total[0], percentile_interval(first[1:], level),
            percentile_interval(total[1:], level))
