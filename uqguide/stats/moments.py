"""Statistics of an output: the container and the sample estimators.

Population (``1/n``) estimators, **non-excess** kurtosis; intervals tail-aware
(:mod:`uqguide.stats.tail_intervals`), delta-method, bootstrap or studentised. Two forms of the
same estimators: in memory (:func:`sample_statistics`) and streaming (:class:`MomentSums`,
:func:`statistics_from_sums`), which Monte Carlo uses. Conventions and why two forms:
docs/statistics.md#statistics; the formulas: docs/statistics.md#mergeable-moment-sums.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, fields
from math import comb
from statistics import NormalDist
from typing import ParamSpec, TypeVar

import numpy as np

from ..core.types import RUNS_NEEDED, STAT_NAMES, OutputStats
from .tail_intervals import if_polynomial, tail_intervals

_P = ParamSpec("_P")
_R = TypeVar("_R")


def quiet_overflow() -> np.errstate:
    """A context without numpy's overflow warnings: the run says once which output overflowed
    (:func:`overflowed`) instead of a warning per line of arithmetic."""
    return np.errstate(over="ignore", invalid="ignore")


def _quiet_overflow(f: Callable[_P, _R]) -> Callable[_P, _R]:
    """``f`` run in :func:`quiet_overflow`."""
    @functools.wraps(f)
    def quiet(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        with quiet_overflow():
            return f(*args, **kwargs)
    return quiet

__all__ = ["STAT_NAMES", "MomentSums", "OutputStats", "bootstrap_intervals", "central_moments",
           "column_blocks", "covariance", "overflowed", "quiet_overflow", "sample_statistics",
           "shape_moments", "statistics_from_sums"]


def shape_moments(mean: np.ndarray, mu2: np.ndarray, mu3: np.ndarray, mu4: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """std (output unit), skewness and (non-excess) kurtosis ``(..., k)`` from the mean and
    central moments 2-4; NaN where the variance is at round-off level relative to the mean."""
    std = np.sqrt(np.maximum(mu2, 0.0))
    # A variance at rounding level relative to the mean is zero for this purpose: samples that
    # all agree (before any dispersion acts) must give NaN, not a huge ratio of round-off.
    tiny = (np.abs(mean) + 1e-300) * 1e-12
    ok = std > tiny
    with np.errstate(invalid="ignore", divide="ignore"):
        skew = np.where(ok, mu3 / np.where(ok, std, 1.0) ** 3, np.nan)
        kurt = np.where(ok, mu4 / np.where(ok, std, 1.0) ** 4, np.nan)
    return std, skew, kurt


def overflowed(mean: np.ndarray | float, std: np.ndarray | float,
               skewness: np.ndarray | float, kurtosis: np.ndarray | float,
               sample: bool = True, n_used: int | None = None) -> dict[str, np.ndarray]:
    """Per statistic name, where moments of finite values overflowed double precision
    (docs/statistics.md#overflow).

    ``sample`` False (PCE, multi-fidelity: their NaN means withheld): only infinite values count.
    ``n_used``: a moment NaN for want of runs (:func:`founded`) did not overflow.
    """
    mean, std = np.asarray(mean, dtype=float), np.asarray(std, dtype=float)
    skew, kurt = np.asarray(skewness, dtype=float), np.asarray(kurtosis, dtype=float)
    enough = {k: sample and (n_used is None or n_used >= RUNS_NEEDED[k]) for k in STAT_NAMES}
    with np.errstate(invalid="ignore", over="ignore"):
        spread = np.isfinite(mean) & (std > (np.abs(mean) + 1e-300) * 1e-12)
        bad_std = np.isinf(std) | (enough["std"] & np.isnan(std) & np.isfinite(mean))
    shape = {k: bad_std | np.isinf(v) | (enough[k] & np.isnan(v) & spread)
             for k, v in (("skewness", skew), ("kurtosis", kurt))}
    return {"mean": np.isinf(mean), "std": bad_std, **shape}


def founded(n: int, std: np.ndarray, skew: np.ndarray, kurt: np.ndarray,
            ci: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """std, skewness and kurtosis of ``n`` runs, NaN (and their intervals removed from ``ci``)
    where ``n`` is below the runs each needs (:data:`~uqguide.core.types.RUNS_NEEDED`)."""
    out = []
    for name, v in (("std", std), ("skewness", skew), ("kurtosis", kurt)):
        if n < RUNS_NEEDED[name]:
            v = np.full_like(v, np.nan)
            ci.pop(name, None)
        out.append(v)
    return out[0], out[1], out[2]


@_quiet_overflow
def column_blocks(cols: int, step: int) -> list[slice]:
    """``cols`` columns in blocks of ``step`` (at least 2), the last one wider rather than a
    lone column: NumPy reduces a lone column pairwise, a wider block row by row, so each
    column's arithmetic is that of the whole array in every block."""
    starts = list(range(0, cols, max(2, step)))
    if len(starts) > 1 and cols - starts[-1] == 1:
        starts.pop()
    return [slice(a, b) for a, b in zip(starts, starts[1:] + [cols])]


def central_moments(y: np.ndarray, axis: int = 0
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Mean and central moments 2-4 of ``y`` along ``axis`` (population estimators, two-pass);
    ``mu_p`` in the p-th power of ``y``'s unit."""
    mean = y.mean(axis=axis)
    d = y - np.expand_dims(mean, axis)
    d2 = d * d
    mu2 = d2.mean(axis=axis)
    mu3 = (d2 * d).mean(axis=axis)
    mu4 = (d2 * d2).mean(axis=axis)
    return mean, mu2, mu3, mu4


def covariance(y: np.ndarray) -> np.ndarray:
    """Population covariance ``(..., k, k)`` (divided by ``n``) of ``y (n, ..., k)``, in the
    square of ``y``'s unit."""
    d = y - y.mean(axis=0)
    return np.einsum("n...i,n...j->...ij", d, d) / y.shape[0]


@_quiet_overflow
def bootstrap_intervals(
    y: np.ndarray, n_resamples: int = 200, seed: int = 0, level: float = 0.95,
    block: int = 25, max_bytes: int = 256 * 2**20,
) -> dict[str, np.ndarray]:
    """Percentile-bootstrap intervals ``(2, ...)`` of mean, std, skewness and kurtosis of
    ``y (n, ...)``.

    Resample block ``j`` draws from the stream ``(seed, j)``, so every column block (sized so
    the data's powers stay under ``max_bytes``) sees the same resamples.
    """
    n = y.shape[0]
    shape = y.shape[1:]
    flat = y.reshape(n, -1)
    m = flat.shape[1]
    full_mean = flat.mean(axis=0)
    cols = max(1, int(max_bytes // (4 * 8 * n)))
    alpha = (1.0 - level) / 2
    res = {k: np.empty((2, m)) for k in STAT_NAMES}
    for c0 in range(0, m, cols):
        sl_c = slice(c0, min(m, c0 + cols))
        d = flat[:, sl_c] - full_mean[sl_c]
        d2 = d * d
        powers = (d, d2, d2 * d, d2 * d2)
        draws = {k: np.empty((n_resamples, d.shape[1])) for k in STAT_NAMES}
        for j, r0 in enumerate(range(0, n_resamples, block)):
            b = min(block, n_resamples - r0)
            counts = resample_counts(np.random.default_rng([seed, j]), b, n)
            m1, m2, m3, m4 = (counts @ p / n for p in powers)
            mu2 = m2 - m1**2
            mu3 = m3 - 3 * m1 * m2 + 2 * m1**3
            mu4 = m4 - 4 * m1 * m3 + 6 * m1**2 * m2 - 3 * m1**4
            mean = full_mean[sl_c] + m1
            std, skew, kurt = shape_moments(mean, mu2, mu3, mu4)
            sl_r = slice(r0, r0 + b)
            draws["mean"][sl_r], draws["std"][sl_r] = mean, std
            draws["skewness"][sl_r], draws["kurtosis"][sl_r] = skew, kurt
        for k, v in draws.items():
            res[k][:, sl_c] = _nan_safe_percentile(v, alpha)
    return {k: v.reshape((2,) + shape) for k, v in res.items()}


def resample_counts(rng: np.random.Generator, b: int, n: int) -> np.ndarray:
    """Multiplicities ``(b, n)`` of ``b`` bootstrap resamples (with replacement) of ``n`` rows."""
    idx = rng.integers(0, max(n, 1), size=(b, n)) + (np.arange(b) * n)[:, None]
    return np.bincount(idx.ravel(), minlength=b * n).reshape(b, n).astype(float)


def _nan_safe_percentile(v: np.ndarray, alpha: float) -> np.ndarray:
    """Percentiles over resamples (axis 0), ignoring NaN resamples; all-NaN columns stay NaN."""
    q = [100 * alpha, 100 * (1 - alpha)]
    nan = np.isnan(v)
    if not nan.any():
        return np.percentile(v, q, axis=0)
    res = np.full((2, v.shape[1]), np.nan)
    ok = ~nan.all(axis=0)
    if ok.any():
        res[:, ok] = np.nanpercentile(v[:, ok], q, axis=0)
    return res


def delta_standard_errors(
    mu: tuple[np.ndarray, ...], n: float | np.ndarray,
) -> dict[str, np.ndarray]:
    """Delta-method standard errors of mean, std, skewness, kurtosis
    (docs/statistics.md#delta-method-standard-errors).

    ``mu``: central moments ``(mu_2, ..., mu_8)``; ``n`` broadcasts against them (a bootstrap's
    per resample). NaN where the variance is zero.
    """
    mu2 = mu[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        sigma = np.sqrt(np.maximum(mu2, 0.0))
        inv = np.where(sigma > 0, 1.0 / np.where(sigma > 0, sigma, 1.0), np.nan)
        r = [np.ones_like(mu2), np.zeros_like(mu2), np.ones_like(mu2)]
        r += [mu[k - 2] * inv**k for k in range(3, 9)]
        out: dict[str, np.ndarray] = {}
        for name in STAT_NAMES:
            c = if_polynomial(name, r)
            var = np.zeros_like(mu2)
            for i, ci in enumerate(c):
                for j, cj in enumerate(c):
                    var = var + ci * cj * r[i + j]
            se = np.sqrt(np.maximum(var, 0.0) / n)
            out[name] = se * sigma if name in ("mean", "std") else se
    return out


def delta_intervals(mean: np.ndarray, mu: tuple[np.ndarray, ...], n: float, level: float = 0.95
                    ) -> dict[str, np.ndarray]:
    """Normal-theory intervals ``estimate +- z_(1+level)/2 SE`` ``(2, ...)`` of the statistics of
    ``mean`` and the central moments ``(mu_2, ..., mu_8)``, with delta-method SEs
    (:func:`delta_standard_errors`)."""
    z = NormalDist().inv_cdf(0.5 + level / 2)
    se = delta_standard_errors(mu, n)
    est = dict(zip(STAT_NAMES, (mean, *shape_moments(mean, mu[0], mu[1], mu[2]))))
    return {k: np.stack([est[k] - z * se[k], est[k] + z * se[k]]) for k in STAT_NAMES}


@_quiet_overflow
def sample_statistics(
    y: np.ndarray, *, bootstrap: int = 200, seed: int = 0, level: float = 0.95,
    ci_index: np.ndarray | None = None, intervals: str = "bootstrap",
) -> OutputStats:
    """Statistics of samples ``y (n, T, k)`` or ``(n, k)`` over the first axis (failed runs
    removed): moments ``(..., k)``, covariance ``(..., k, k)``, intervals ``(2, ..., k)``.

    ``ci_index``: for a series, the time indices to bootstrap at (NaN intervals elsewhere;
    default all). ``intervals``: ``"bootstrap"``, ``"delta"`` or ``"tail"`` (every step);
    ``bootstrap`` 0 switches intervals off.
    """
    y = np.asarray(y, dtype=float)
    n = y.shape[0]
    if n == 0:
        nan = np.full(y.shape[1:], np.nan)
        return OutputStats(nan, nan, nan, nan, np.full(y.shape[1:] + y.shape[-1:], np.nan), 0)
    mean, mu2, mu3, mu4 = central_moments(y)
    std, skew, kurt = shape_moments(mean, mu2, mu3, mu4)
    ci: dict[str, np.ndarray] = {}
    if intervals in ("delta", "tail") and bootstrap > 0 and n > 1:
        d = y - mean
        top = HIGH_ORDER if intervals == "tail" else 8
        mus = [mu2, mu3, mu4] + [np.mean(d**k, axis=0) for k in range(5, top + 1)]
        ci = delta_intervals(mean, tuple(mus), n, level) if intervals == "delta" \
            else tail_intervals(mean, tuple(mus), n, level)[0]
    elif bootstrap > 0 and n > 1:
        if ci_index is None or y.ndim != 3:
            ci = bootstrap_intervals(y, bootstrap, seed, level)
        else:
            idx = np.unique(np.asarray(ci_index, dtype=int))
            part = bootstrap_intervals(y[:, idx], bootstrap, seed, level)
            ci = {k: _placed(v, y.shape[1:], idx) for k, v in part.items()}
    std, skew, kurt = founded(n, std, skew, kurt, ci)
    return OutputStats(
        mean=mean, std=std, skewness=skew, kurtosis=kurt, cov=covariance(y), n_used=n,
        moments_method="sample", sem=std / np.sqrt(n), ci=ci,
    )


@dataclass
class MomentSums:
    """Mergeable sums of (possibly weighted) samples: total weight ``n``, ``mean``, central sums
    ``m2``-``m4``, comoments ``cm`` (docs/statistics.md#mergeable-moment-sums).

    ``n``: ``(B, 1)`` for ``B`` bootstrap resamples; fields ``(..., k)`` or ``(B, c)``;
    ``cm (..., k, k)``; ``high (H, ..., k)``: central sums of orders 5 to ``4 + H`` (5-16 for
    plain samples, 5-8 for a bootstrap's).
    """

    n: float | np.ndarray
    mean: np.ndarray
    m2: np.ndarray
    m3: np.ndarray
    m4: np.ndarray
    cm: np.ndarray | None = None
    high: np.ndarray | None = None

    @classmethod
    @_quiet_overflow
    def of(cls, y: np.ndarray, comoments: bool = True, high: bool = False) -> MomentSums:
        """Sums of plain samples ``y (n, ..., k)`` (not modified; a view of a model's buffer is
        fine) over the first axis (two-pass); ``cm (..., k, k)`` with ``comoments``,
        ``high (12, ..., k)`` with ``high``."""
        y = np.asarray(y, dtype=float)
        n = y.shape[0]
        if n == 0:
            z = np.zeros(y.shape[1:])
            cm = np.zeros(y.shape[1:] + y.shape[-1:]) if comoments else None
            hi = np.zeros((HIGH_ORDER - 4,) + y.shape[1:]) if high else None
            return cls(0.0, z, z.copy(), z.copy(), z.copy(), cm, hi)
        # imported here: commands that compute no statistics do not load numba
        from .moment_sums_kernel import column_sums, comoment_sums

        shape = y.shape[1:]
        # explicit width: reshape(n, -1) is ambiguous for zero columns (no scalar outputs)
        flat = np.ascontiguousarray(y).reshape(n, int(np.prod(shape)))
        mean_flat, sums = column_sums(flat, high)
        mean = mean_flat.reshape(shape)
        m2, m3, m4 = (sums[r].reshape(shape) for r in range(3))
        cm = None
        if comoments:
            k = shape[-1] if shape else 1
            if k == 1:
                # sum d d over the samples in order: the same additions as m2's
                cm = m2[..., None].copy()
            else:
                lead = int(np.prod(shape[:-1])) if len(shape) > 1 else 1
                cm = comoment_sums(flat.reshape(n, lead, k), mean.reshape(lead, k)
                                   ).reshape(shape + (k,))
        hi = sums[3:].reshape((HIGH_ORDER - 4,) + shape) if high else None
        return cls(float(n), mean, m2, m3, m4, cm, hi)

    def central_sums(self) -> list[np.ndarray]:
        """``[m_2, ..., m_p]``: the fields and, when kept, the orders 5 and up."""
        out = [self.m2, self.m3, self.m4]
        if self.high is not None:
            out += list(self.high)
        return out

    @classmethod
    @_quiet_overflow
    def weighted(cls, y: np.ndarray, w: np.ndarray, high: bool = False) -> MomentSums:
        """Sums of ``y (n, c)`` under ``B`` weight vectors ``w (B, n)`` (bootstrap multiplicities):
        ``n (B, 1)``, fields ``(B, c)``, no comoments; ``high``: orders 5-8, ``(4, B, c)``
        (the studentised bootstrap's per-resample standard errors)."""
        y = np.asarray(y, dtype=float)
        B = w.shape[0]
        if y.shape[0] == 0:
            z = np.zeros((B, y.shape[1]))
            hi = np.zeros((4, B, y.shape[1])) if high else None
            return cls(np.zeros((B, 1)), z, z.copy(), z.copy(), z.copy(), None, hi)
        c = y.mean(axis=0)
        d = y - c
        d2 = d * d
        W = w.sum(axis=1, keepdims=True)
        p1, p2, p3, p4 = (w @ p for p in (d, d2, d2 * d, d2 * d2))
        with np.errstate(invalid="ignore", divide="ignore"):
            a = np.where(W > 0, p1 / np.where(W > 0, W, 1.0), 0.0)  # weighted mean - c
        m2 = p2 - a * p1
        m3 = p3 - 3 * a * p2 + 2 * a * a * p1
        m4 = p4 - 4 * a * p3 + 6 * a * a * p2 - 3 * a**3 * p1
        hi = None
        if high:
            # sum w (d - a)^p = sum_j C(p, j) P_j (-a)^(p - j), P_j = sum w d^j (P_0 = W)
            raw = [W * np.ones_like(p1), p1, p2, p3, p4]
            pw = d2 * d2
            for _ in range(4):
                pw = pw * d
                raw.append(w @ pw)
            hi = np.stack([sum(comb(p, j) * raw[j] * (-a) ** (p - j) for j in range(p + 1))
                           for p in range(5, 9)])
        return cls(W, c + a, m2, m3, m4, None, hi)

    @_quiet_overflow
    def merge(self, other: MomentSums,
              outer: Callable[[np.ndarray], np.ndarray] | None = None) -> MomentSums:
        """Sums of the union of two disjoint sample sets (Pébay 2008, eqs 3.1-3.2); comoments only
        where both sides have them. ``outer``: the outer products of the means' difference shaped
        as ``cm`` (default ``einsum`` over the last axis)."""
        na, nb = self.n, other.n
        if np.ndim(na) == 0 and np.ndim(nb) == 0:
            # Whole-chunk sums: an empty side is the other side exactly.
            if nb == 0:
                return self
            if na == 0:
                return other
        n = na + nb
        safe = np.where(n > 0, n, 1.0)
        delta = other.mean - self.mean
        fa, fb = na / safe, nb / safe
        mean = self.mean + delta * fb
        d2 = delta * delta
        nab = na * nb / safe
        m2 = self.m2 + other.m2 + d2 * nab
        m3 = (self.m3 + other.m3 + d2 * delta * nab * (fa - fb)
              + 3 * delta * (fa * other.m2 - fb * self.m2))
        m4 = (self.m4 + other.m4 + d2 * d2 * nab * (fa * fa - fa * fb + fb * fb)
              + 6 * d2 * (fa * fa * other.m2 + fb * fb * self.m2)
              + 4 * delta * (fa * other.m3 - fb * self.m3))
        cm = None
        if self.cm is not None and other.cm is not None:
            products = np.einsum("...i,...j->...ij", delta, delta) if outer is None \
                else outer(delta)
            cm = self.cm + other.cm + products * nab
        high = None
        if self.high is not None and other.high is not None:
            top = 4 + len(self.high)
            high = np.stack([_merge_order(p, self.central_sums(), other.central_sums(), na, nb,
                                          delta) for p in range(5, top + 1)])
        return MomentSums(n, mean, m2, m3, m4, cm, high)

    def arrays(self) -> dict[str, np.ndarray]:
        """The fields as named arrays for storage (``cm`` where present); inverse of
        :meth:`from_arrays`."""
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        return {**{k: v for k, v in d.items() if v is not None},
                "n": np.asarray(self.n, dtype=float)}

    @classmethod
    def from_arrays(cls, d: dict[str, np.ndarray]) -> MomentSums:
        """The sums stored by :meth:`arrays`."""
        n = d["n"]
        return cls(float(n) if n.ndim == 0 else n, d["mean"], d["m2"], d["m3"], d["m4"],
                   d.get("cm"), d.get("high"))

    @_quiet_overflow
    def central_moments(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Mean and population central moments 2-4 (``m_p / n``), NaN where ``n`` is 0."""
        with np.errstate(invalid="ignore", divide="ignore"):
            inv = np.where(np.asarray(self.n) > 0, 1.0 / np.asarray(self.n), np.nan)
        return self.mean, self.m2 * inv, self.m3 * inv, self.m4 * inv


#: The highest central sum :meth:`MomentSums.of` keeps with ``high`` (the tail-aware
#: intervals' kurtosis diagnostic reads the 16th, :mod:`uqguide.stats.tail_intervals`).
HIGH_ORDER = 16

def _merge_order(p: int, a: list[np.ndarray], b: list[np.ndarray], na: float | np.ndarray,
                 nb: float | np.ndarray,
                 delta: np.ndarray) -> np.ndarray:
    """Central sum of order ``p`` of the union of two sample sets (Pébay 2008, eq 3.1 general
    order): ``a``, ``b`` are ``[m_2, ..., m_p]`` of each side, ``delta = mean_b - mean_a``."""
    n = na + nb
    if np.ndim(n) != 0:
        # Per-resample weights (a bootstrap's): a chunk may give a resample no weight at all,
        # so divide by n only (0/0 guarded), never by na or nb: the last term written as
        # delta^p na nb (na^(p-1) - (-nb)^(p-1)) / n^p.
        n = np.where(n > 0, n, 1.0)
    out = a[p - 2] + b[p - 2]
    for k in range(1, p - 1):
        # m_{p-k}; the first central sum is zero, so k stops at p - 2
        out = out + comb(p, k) * delta**k * ((-nb / n) ** k * a[p - k - 2]
                                             + (na / n) ** k * b[p - k - 2])
    if np.ndim(na) != 0 or np.ndim(nb) != 0:
        return out + delta**p * na * nb * (na ** (p - 1) - (-nb) ** (p - 1)) / n**p
    out = out + (na * nb * delta / n) ** p * (1.0 / nb ** (p - 1) - (-1.0 / na) ** (p - 1))
    return out


@_quiet_overflow
def statistics_from_sums(
    sums: MomentSums, boot: MomentSums | None = None, ci_index: np.ndarray | None = None,
    level: float = 0.95, delta: MomentSums | None = None, tail: bool = False,
    uncertain: bool = True,
) -> OutputStats:
    """OutputStats from merged :class:`MomentSums` (the streaming form of
    :func:`sample_statistics`, the same to round-off).

    ``sums``: plain sums. ``boot``: Poisson-bootstrap sums ``(B, c)`` of the interval columns
    (all columns flattened, or the steps ``ci_index`` of a series): percentile intervals, or
    studentised when ``boot`` and ``delta`` hold orders 5-8. ``delta``: plain sums with the
    higher orders of those columns alone: delta-method intervals, tail-aware with ``tail``.
    ``uncertain``: the runs are draws of uncertain inputs, so a moment of fewer runs than it
    needs is NaN.
    """
    n = int(round(float(sums.n)))
    shape = sums.mean.shape
    if n == 0:
        nan = np.full(shape, np.nan)
        return OutputStats(nan, nan, nan, nan, np.full(shape + shape[-1:], np.nan), 0)
    mean, mu2, mu3, mu4 = sums.central_moments()
    std, skew, kurt = shape_moments(mean, mu2, mu3, mu4)
    cov = sums.cm / n if sums.cm is not None else np.full(shape + shape[-1:], np.nan)
    found: dict[str, np.ndarray] = {}
    if delta is None or delta.high is None or n < 2:
        delta = None  # no delta-method interval: sums without orders 5-8, or a single run
    if delta is not None and boot is not None and boot.high is not None:
        found = studentized_intervals(delta, boot, level)
    elif delta is not None and boot is None:
        inv = 1.0 / float(delta.n)
        mus = tuple(m * inv for m in delta.central_sums())
        if tail and len(mus) >= HIGH_ORDER - 1:
            found = tail_intervals(delta.mean, mus, n, level)[0]
        else:
            found = delta_intervals(delta.mean, mus, n, level)
    elif boot is not None and n > 1:
        bm, b2, b3, b4 = boot.central_moments()
        bstd, bskew, bkurt = shape_moments(bm, b2, b3, b4)
        alpha = (1.0 - level) / 2
        draws = {"mean": bm, "std": bstd, "skewness": bskew, "kurtosis": bkurt}
        found = {name: _nan_safe_percentile(v, alpha) for name, v in draws.items()}
    ci = {name: _placed(q, shape, ci_index) for name, q in found.items()}
    if uncertain:
        std, skew, kurt = founded(n, std, skew, kurt, ci)
    return OutputStats(mean=mean, std=std, skewness=skew, kurtosis=kurt, cov=cov, n_used=n,
                       moments_method="sample", sem=std / np.sqrt(n), ci=ci)


def _placed(q: np.ndarray, shape: tuple[int, ...], ci_index: np.ndarray | None) -> np.ndarray:
    """Intervals ``q (2, c)`` of the interval columns laid out ``(2,) + shape``, NaN off the
    steps ``ci_index`` (None: every column)."""
    if ci_index is None:
        return q.reshape((2,) + shape)
    full = np.full((2,) + shape, np.nan)
    full[:, ci_index] = q.reshape((2, len(ci_index)) + shape[1:])
    return full


@_quiet_overflow
def studentized_intervals(sums: MomentSums, boot: MomentSums, level: float = 0.95
                          ) -> dict[str, np.ndarray]:
    """Studentised (bootstrap-t) intervals ``(2, c)`` of mean, std, skewness and kurtosis
    (docs/statistics.md#studentised-bootstrap). ``sums`` fields ``(c,)``, ``boot`` fields
    ``(B, c)``, both with orders 5-8. NaN where the variance is zero.
    """
    n = float(sums.n)
    mus = tuple(m / n for m in sums.central_sums())
    std, skew, kurt = shape_moments(sums.mean, mus[0], mus[1], mus[2])
    est = {"mean": sums.mean, "std": std, "skewness": skew, "kurtosis": kurt}
    se = delta_standard_errors(mus, n)
    W = np.asarray(boot.n, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        inv = np.where(W > 0, 1.0 / np.where(W > 0, W, 1.0), np.nan)
        bmus = tuple(m * inv for m in boot.central_sums())
        bstd, bskew, bkurt = shape_moments(boot.mean, bmus[0], bmus[1], bmus[2])
        bse = delta_standard_errors(bmus, W)
        draws = {"mean": boot.mean, "std": bstd, "skewness": bskew, "kurtosis": bkurt}
        alpha = (1.0 - level) / 2
        out = {}
        for name in STAT_NAMES:
            t = (draws[name] - est[name]) / bse[name]
            t = np.where(np.isfinite(t), t, np.nan)
            q = _nan_safe_percentile(t, alpha)
            out[name] = np.stack([est[name] - q[1] * se[name], est[name] - q[0] * se[name]])
    return out
