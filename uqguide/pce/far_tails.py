"""Moments a PCE's polynomial takes from inputs too rare for any run: found and replaced.

Where the expansion can swing (:func:`can_swing`), its exact mean and std are compared with
those of random draws of the surrogate; where either differs by more than :data:`FAR_FACTOR`
of the draws' standard errors, the column's statistics become the draws'
(:func:`replace_far_tails`). :func:`beyond_the_runs` measures the part from beyond the runs.

The rule, why six standard errors and only the mean and std, and the measured cases:
docs/methods.md#pce-statistics.
"""

from __future__ import annotations

import numpy as np

from ..core.types import OutputStats
from ..stats.moments import central_moments, column_blocks, shape_moments
from .expansion import Expansion
from .germ import NORMAL
from .validation import MATERIAL

#: Most surrogate draws behind the comparison (fewer for outputs of many columns, to keep the
#: draws near 8 MB; never fewer than :data:`MIN_DRAWS`).
FAR_DRAWS = 2**15
MIN_DRAWS = 2**13
#: Batches whose means give the draws' standard errors.
BATCHES = 32
#: Standard errors of the draws' estimate beyond which the exact value is not the draws'.
FAR_FACTOR = 6.0
_STATS = ("mean", "std", "skewness", "kurtosis")
#: Draws x columns of a block the statistics' temporaries span (8 MB each), so that a long
#: series' peak memory is the draws themselves (docs/performance.md#series-memory).
_CHUNK_FLOATS = 2**20


def can_swing(exp: Expansion) -> bool:
    """Whether the expansion's polynomial can reach beyond its runs: a retained term of degree
    2 or more in an unbounded (normal) germ variable (a linear term's tails are the model's)."""
    exp = exp.trimmed()
    normal = np.array([f == NORMAL for f in exp.germ.families], dtype=bool)
    return bool(normal.any() and exp.alpha[:, normal].max(initial=0) >= 2)


def far_draws(columns: int) -> int:
    """Surrogate draws for an output of ``columns`` values per draw (a multiple of
    :data:`BATCHES`)."""
    m = min(FAR_DRAWS, max(MIN_DRAWS, 2**20 // max(columns, 1)))
    return m - m % BATCHES


def _blocks(rows: int, cols: int) -> list[slice]:
    """Column blocks of about :data:`_CHUNK_FLOATS` values of ``rows`` draws."""
    return column_blocks(cols, _CHUNK_FLOATS // max(rows, 1))


def _stats(v: np.ndarray) -> np.ndarray:
    """Mean, std, skewness, kurtosis ``(4, cols)`` of draws ``(n, cols)``."""
    out = np.empty((4, v.shape[1]))
    for cols in _blocks(*v.shape):
        mean, mu2, mu3, mu4 = central_moments(v[:, cols])
        out[:, cols] = [mean, *shape_moments(mean, mu2, mu3, mu4)]
    return out


def replace_far_tails(st: OutputStats, draws: np.ndarray) -> np.ndarray:
    """Replace, in place, the exact statistics the draws refute.

    ``draws (m, ...)``: the surrogate at ``m`` random inputs (``m`` a multiple of
    :data:`BATCHES`). Returns the columns replaced, bool ``(...)``.
    """
    shape = np.shape(st.mean)
    m = draws.shape[0]
    w = np.asarray(draws.reshape(m, -1), dtype=float)
    full = _stats(w)
    b = w.reshape(BATCHES, m // BATCHES, -1)
    b_mean = b.mean(axis=1)
    b_std = np.empty_like(b_mean)
    for c in _blocks(m, w.shape[1]):
        b_std[:, c] = np.sqrt(np.mean((b[:, :, c] - b_mean[:, None, c]) ** 2, axis=1))
    se = np.full(full.shape, np.nan)
    se[0] = b_mean.std(axis=0, ddof=1) / np.sqrt(BATCHES)
    se[1] = b_std.std(axis=0, ddof=1) / np.sqrt(BATCHES)
    exact = np.array([np.asarray(st.stat(k), dtype=float).reshape(-1) for k in _STATS])
    scale = np.nan_to_num(np.abs(exact[1]))
    floor = np.array([MATERIAL * scale, MATERIAL * scale,
                      np.full_like(scale, MATERIAL), np.full_like(scale, MATERIAL)])
    with np.errstate(invalid="ignore"):
        off = (np.abs(exact - full) > np.maximum(FAR_FACTOR * se, floor)) & np.isfinite(exact)
    # Judged on the mean and std only: a heavy-tailed output's skewness and kurtosis are
    # carried by far tails that are the model's too (docs/methods.md#pce-statistics).
    cols = off[:2].any(axis=0)
    if not cols.any():
        return cols.reshape(shape)
    sub = w[:, cols].reshape(BATCHES, m // BATCHES, -1)
    per = np.array([_stats(part) for part in sub])
    se = np.zeros_like(full)
    se[:, cols] = per.std(axis=0, ddof=1) / np.sqrt(BATCHES)
    sampling = {k: np.zeros(exact.shape[1]) for k in _STATS}
    for i, k in enumerate(_STATS):
        v = exact[i].copy()
        v[cols] = full[i, cols]
        setattr(st, k, v.reshape(shape))
        sampling[k][cols] = se[i, cols]
    st.sampling_se = {k: v.reshape(shape) for k, v in sampling.items()}
    cov = np.array(st.cov, dtype=float)
    if cov.shape[-2:] and cov.shape[-1] == shape[-1]:
        diag = np.einsum("...ii->...i", cov)
        diag[...] = np.asarray(st.std, dtype=float) ** 2
        st.cov = cov
    return cols.reshape(shape)


def beyond_the_runs(draws: np.ndarray, clipped: np.ndarray) -> dict[str, np.ndarray]:
    """How much of each statistic the surrogate takes from beyond its runs.

    ``draws (m, ...)``: the surrogate at random inputs; ``clipped``: at the same inputs, each
    coordinate clipped to the range its runs (fit and validation) cover, i.e. the surrogate
    continued as a constant. Returns per statistic ``|stat(draws) - stat(clipped)|`` (0 where
    either is undefined).
    """
    m = draws.shape[0]
    shape = draws.shape[1:]
    a = _stats(np.asarray(draws.reshape(m, -1), dtype=float))
    b = _stats(np.asarray(clipped.reshape(m, -1), dtype=float))
    diff = np.nan_to_num(np.abs(a - b))
    return {k: diff[i].reshape(shape) for i, k in enumerate(_STATS)}
