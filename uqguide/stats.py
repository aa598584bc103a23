"""Statistics of an output (uq-methods.md section 3): the container and the sample estimators.

Conventions, for an output ``y`` of k components at one time:

- moments are the plain population (``1/n``) estimators of the paper's eq (17);
- skewness ``E[(y-mu)^3]/sigma^3`` and kurtosis ``E[(y-mu)^4]/sigma^4`` are **non-excess**
  (a Gaussian has kurtosis 3);
- a component with zero variance has skewness and kurtosis NaN, silently;
- the standard error of the mean is ``sigma/sqrt(n)``; 95% intervals of std, skewness and
  kurtosis come from a vectorised percentile bootstrap with a fixed seed.

Arrays of a time-series output carry the time axis first: ``mean (T, k)``, ``cov (T, k, k)``.
A scalar output has no time axis: ``mean (k,)``, ``cov (k, k)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

STAT_NAMES = ("mean", "std", "skewness", "kurtosis")


@dataclass
class OutputStats:
    """Statistics of one output, from samples or from a surrogate.

    Attributes
    ----------
    mean, std, skewness, kurtosis : ndarray, shape (..., k)
        ``...`` is ``(T,)`` for a time series and empty for a scalar output.
    cov : ndarray, shape (..., k, k)
    n_used : int
        Samples the estimate used (runs that did not fail), or surrogate draws.
    moments_method : str
        ``"sample"`` (population estimators on model runs), ``"exact"`` (from PCE
        coefficients) or ``"surrogate-sampling"`` (sampling a PCE surrogate).
    sem : ndarray, shape (..., k), optional
        Standard error of the mean (sample estimates only).
    ci : dict of str to ndarray, shape (2, ..., k)
        95% interval (low, high) per statistic name, where known.
    sobol_first, sobol_total : ndarray, shape (..., k, d), optional
        Sobol' indices per input (PCE only).
    """

    mean: np.ndarray
    std: np.ndarray
    skewness: np.ndarray
    kurtosis: np.ndarray
    cov: np.ndarray
    n_used: int
    moments_method: str = "sample"
    sem: np.ndarray | None = None
    ci: dict[str, np.ndarray] = field(default_factory=dict)
    sobol_first: np.ndarray | None = None
    sobol_total: np.ndarray | None = None

    def stat(self, name: str) -> np.ndarray:
        if name not in STAT_NAMES:
            raise KeyError(name)
        return getattr(self, name)


def _shape_moments(mean: np.ndarray, mu2: np.ndarray, mu3: np.ndarray, mu4: np.ndarray):
    """std, skewness and kurtosis from central moments; NaN where the variance is zero."""
    std = np.sqrt(np.maximum(mu2, 0.0))
    # A variance at rounding level relative to the mean is zero for this purpose: samples that
    # all agree (before any dispersion acts) must give NaN, not a huge ratio of round-off.
    tiny = (np.abs(mean) + 1e-300) * 1e-12
    ok = std > tiny
    with np.errstate(invalid="ignore", divide="ignore"):
        skew = np.where(ok, mu3 / np.where(ok, std, 1.0) ** 3, np.nan)
        kurt = np.where(ok, mu4 / np.where(ok, std, 1.0) ** 4, np.nan)
    return std, skew, kurt


def central_moments(y: np.ndarray, axis: int = 0):
    """Mean and central moments 2-4 of ``y`` along ``axis`` (population estimators, two-pass)."""
    mean = y.mean(axis=axis)
    d = y - np.expand_dims(mean, axis)
    d2 = d * d
    mu2 = d2.mean(axis=axis)
    mu3 = (d2 * d).mean(axis=axis)
    mu4 = (d2 * d2).mean(axis=axis)
    return mean, mu2, mu3, mu4


def covariance(y: np.ndarray) -> np.ndarray:
    """Population covariance of ``y (n, ..., k)`` over the sample axis: shape ``(..., k, k)``."""
    d = y - y.mean(axis=0)
    return np.einsum("n...i,n...j->...ij", d, d) / y.shape[0]


def bootstrap_intervals(
    y: np.ndarray, n_resamples: int = 200, seed: int = 0, level: float = 0.95,
    block: int = 25, max_bytes: int = 256 * 2**20,
) -> dict[str, np.ndarray]:
    """Percentile-bootstrap intervals of mean, std, skewness and kurtosis.

    Vectorised: a block of resamples is a matrix of multiplicities ``c (b, n)`` and the
    resampled power sums are matrix products ``c @ d**p`` of the data centred at the full-sample
    mean (centring keeps the raw-to-central conversion well conditioned). Columns (time steps x
    components) are processed in blocks so the powers of the data stay under ``max_bytes``; the
    multiplicities of resample block ``j`` come from the stream ``(seed, j)``, so every column
    sees the same resamples.

    Parameters
    ----------
    y : ndarray, shape (n, ...)
    n_resamples : int
    seed : int
        Seed of the resampling; fixed so the same data give the same intervals.
    level : float
        Coverage of the intervals.

    Returns
    -------
    dict of str to ndarray, shape (2, ...)
        ``(low, high)`` per statistic.
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
            rng = np.random.default_rng([seed, j])
            idx = rng.integers(0, n, size=(b, n)) + (np.arange(b) * n)[:, None]
            counts = np.bincount(idx.ravel(), minlength=b * n).reshape(b, n).astype(float)
            m1, m2, m3, m4 = (counts @ p / n for p in powers)
            mu2 = m2 - m1**2
            mu3 = m3 - 3 * m1 * m2 + 2 * m1**3
            mu4 = m4 - 4 * m1 * m3 + 6 * m1**2 * m2 - 3 * m1**4
            mean = full_mean[sl_c] + m1
            std, skew, kurt = _shape_moments(mean, mu2, mu3, mu4)
            sl_r = slice(r0, r0 + b)
            draws["mean"][sl_r], draws["std"][sl_r] = mean, std
            draws["skewness"][sl_r], draws["kurtosis"][sl_r] = skew, kurt
        for k, v in draws.items():
            res[k][:, sl_c] = _nan_safe_percentile(v, alpha)
    return {k: v.reshape((2,) + shape) for k, v in res.items()}


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


def sample_statistics(
    y: np.ndarray, *, bootstrap: int = 200, seed: int = 0, level: float = 0.95,
    ci_index: np.ndarray | None = None,
) -> OutputStats:
    """Statistics of samples ``y (n, ..., k)`` over the first axis.

    Parameters
    ----------
    y : ndarray, shape (n, T, k) or (n, k)
        Samples of the output (failed runs already removed).
    bootstrap : int
        Number of bootstrap resamples for the intervals (0: no intervals).
    seed : int
        Seed of the bootstrap.
    ci_index : ndarray of int, optional
        For a time series, the time indices at which to bootstrap (the intervals are NaN at the
        other steps); default all steps. The bootstrap costs ``2 * bootstrap * n`` flops per
        power, column and resample, so a 1e5-sample series is bootstrapped where it is reported.
    """
    y = np.asarray(y, dtype=float)
    n = y.shape[0]
    if n == 0:
        nan = np.full(y.shape[1:], np.nan)
        return OutputStats(nan, nan, nan, nan, np.full(y.shape[1:] + y.shape[-1:], np.nan), 0)
    mean, mu2, mu3, mu4 = central_moments(y)
    std, skew, kurt = _shape_moments(mean, mu2, mu3, mu4)
    ci: dict[str, np.ndarray] = {}
    if bootstrap > 0 and n > 1:
        if ci_index is None or y.ndim != 3:
            ci = bootstrap_intervals(y, bootstrap, seed, level)
        else:
            idx = np.unique(np.asarray(ci_index, dtype=int))
            part = bootstrap_intervals(y[:, idx], bootstrap, seed, level)
            for k, v in part.items():
                full = np.full((2,) + y.shape[1:], np.nan)
                full[:, idx] = v
                ci[k] = full
    return OutputStats(
        mean=mean, std=std, skewness=skew, kurtosis=kurt, cov=covariance(y), n_used=n,
        moments_method="sample", sem=std / np.sqrt(n), ci=ci,
    )
