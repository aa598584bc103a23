"""First-order and total Sobol' indices of a pick-freeze (Saltelli) design, from mergeable sums.

First order by Saltelli 2010, total by Jansen; a chunk of base rows reduces to
:class:`PickFreezeSums`, which merge exactly; intervals are a Poisson bootstrap over the base
rows (:func:`percentile_interval`). The estimators, the centring, the bootstrap and the
comparison with SALib and OpenTURNS: docs/error-budget.md#totals-a-pick-freeze-design.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np


@dataclass
class PickFreezeSums:
    """Weighted sums of a pick-freeze design over some base rows, about a shift per lane.

    Row ``0`` of the leading axis is the sample itself (every weight 1); rows ``1..R`` are
    bootstrap resamples. ``shift (L,)``: ``c``, each lane's centre; ``w (R + 1,)``: sum of the
    weights; ``p1``, ``p2 (R + 1, L)``: ``sum w ((f_A - c) + (f_B - c))`` and
    ``sum w ((f_A - c)^2 + (f_B - c)^2)``; ``d``, ``x``, ``j (R + 1, L, m)``: per frozen set
    ``sum w D``, ``sum w (f_B - c) D``, ``sum w (f_A - f_AB)^2``; ``q (R + 1, L)``:
    ``sum w sum_u (f_AB^u - c)``, with ``p1`` the mean of all runs.
    """

    shift: np.ndarray
    w: np.ndarray
    p1: np.ndarray
    p2: np.ndarray
    d: np.ndarray
    x: np.ndarray
    j: np.ndarray
    q: np.ndarray

    @classmethod
    def of(cls, f_a: np.ndarray, f_b: np.ndarray, f_ab: np.ndarray,
           weights: np.ndarray) -> PickFreezeSums:
        """The sums of one block of base rows: ``f_a``, ``f_b (b, L)`` on the good rows of ``A`` and
        ``B``, ``f_ab (m, b, L)`` on ``A_B^u`` of each frozen set, ``weights (R + 1, b)`` (row 0
        ones, then bootstrap counts)."""
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
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_arrays(cls, a: dict[str, np.ndarray]) -> PickFreezeSums:
        return cls(*(np.asarray(a[f.name]) for f in fields(cls)))

    def indices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """First-order and total indices ``(R + 1, L, m)`` of the sample and every resample (NaN
        where the variance is zero or no base row is counted), and the population variance of
        ``f(A), f(B)`` ``(R + 1, L)``."""
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
    """First-order and total indices ``(L, m)`` and their percentile intervals ``(2, L, m)``,
    from sums merged over every base row."""
    first, total, _ = sums.indices()
    return (first[0], total[0], percentile_interval(first[1:], level),
            percentile_interval(total[1:], level))
