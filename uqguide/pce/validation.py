"""Validation of a PCE by independent model runs: its out-of-sample error, control-variate
corrections of its moments with bootstrap intervals, and where it is not usable.

A PCE's moments are exact for the surrogate, not for the model. ``n`` model runs at independent
random inputs (a stream of their own, never used by the fit) measure the difference:

- **Out-of-sample error** per output column (time step x component): the mean squared
  model-minus-surrogate difference relative to the model's variance on the validation runs,
  ``e = mean((y - s)^2) / var(y)``: the fraction of the variance the surrogate misses, the same
  scale as the relative LOO error of the fit (0 perfect, about 1 for a constant).
- **Control-variate estimates** (the surrogate as control variate): for the raw moments about
  the PCE mean ``c``, ``M_p = E[(S - c)^p] + mean_v[(y - c)^p - (s - c)^p]``, p = 1..4, with
  ``E[(S - c)^p]`` the PCE's own (exact) central moments. Each ``M_p`` is unbiased for the
  model's ``E[(Y - c)^p]`` whatever the surrogate's quality (the validation inputs are
  independent of the fit); mean, std, skewness and kurtosis follow from the same four
  ``M_p``, so they are consistent. A perfect surrogate gives the PCE's values; a constant one
  the plain Monte Carlo moments of the validation runs.
- **95% intervals**: ``value +- t_{0.975, n-1} sqrt(n / (n-1)) se``, ``se`` the bootstrap
  standard error over the validation runs (the same resampled runs for all four raw moments
  and every column; ``n_boot`` resamples with a fixed seed). With 100 runs and a correction
  whose distribution is heavy-tailed (large errors in a small part of the input space), the
  percentile interval was too short (on Ishigami, 60-run adaptive PCE, 10 seeds: 8 and 7 of
  10 covered std and kurtosis); the t-quantile and the ``n / (n-1)`` factor undo the
  bootstrap's small-sample shrinkage. The PCE's own moments are held fixed: they are exact
  for the surrogate (sampled ones, of derived outputs, carry a sampling error far below the
  validation set's).
- **Usable**: a column whose error (validation, or the fit's LOO error) exceeds ``threshold``
  (default 0.1: the surrogate misses a tenth of the variance) has no usable surrogate; the
  PCE's own moments are withdrawn there (NaN), the corrected ones stay.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..types import OutputStats
from .design import VALIDATION_STREAM, stream

#: Default usability threshold on the relative (LOO or validation) error.
USABLE_ERROR = 0.1
LEVEL = 0.95


def validation_unit_rows(seed: int, label: str, n: int, d: int) -> np.ndarray:
    """The validation inputs ``u (n, d)`` on the unit cube: independent uniform draws from the
    method's own validation stream (keyed by its label), away from the cube's faces."""
    rng = np.random.default_rng(stream(seed, label, VALIDATION_STREAM))
    u: np.ndarray = np.clip(rng.random((n, d)), 2.0**-53, 1 - 2.0**-53)
    return u


def relative_error(y: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Out-of-sample relative error ``mean((y - s)^2) / var(y)`` per column.

    Parameters
    ----------
    y, s : ndarray, shape (n, ...)
        Model and surrogate values at the same (successful) validation runs.

    Returns
    -------
    ndarray, shape (...)
        0 where the model does not vary and the surrogate agrees with it to round-off; ``inf``
        where the model does not vary and the surrogate does.
    """
    mse = np.mean((y - s) ** 2, axis=0)
    var = y.var(axis=0)
    floor = 1e-24 * np.mean(y, axis=0) ** 2 + 1e-300
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.where(var > floor, mse / np.where(var > floor, var, 1.0),
                     np.where(mse <= floor, 0.0, np.inf))
    return np.asarray(e, dtype=float)


def _moments_from_raw(c: np.ndarray, m1: np.ndarray, m2: np.ndarray, m3: np.ndarray,
                      m4: np.ndarray) -> dict[str, np.ndarray]:
    """mean, std, skewness and kurtosis from raw moments ``m_p`` about ``c``."""
    var = m2 - m1**2
    mu3 = m3 - 3 * m1 * m2 + 2 * m1**3
    mu4 = m4 - 4 * m1 * m3 + 6 * m1**2 * m2 - 3 * m1**4
    std = np.sqrt(np.maximum(var, 0.0))
    ok = std > 1e-12 * (np.abs(c + m1) + 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        skew = np.where(ok, mu3 / np.where(ok, std, 1.0) ** 3, np.nan)
        kurt = np.where(ok, mu4 / np.where(ok, std, 1.0) ** 4, np.nan)
    return {"mean": c + m1, "std": std, "skewness": skew, "kurtosis": kurt}


@dataclass
class Corrected:
    """Control-variate estimates of one output (module docstring).

    Attributes
    ----------
    values : dict of str to ndarray, shape (...)
        mean, std, skewness, kurtosis.
    ci : dict of str to ndarray, shape (2, ...)
        Their 95% intervals (bootstrap standard error, t quantile).
    error : ndarray, shape (...)
        Out-of-sample relative error.
    n : int
        Validation runs used (successful ones).
    """

    values: dict[str, np.ndarray]
    ci: dict[str, np.ndarray]
    error: np.ndarray
    n: int


def _moments_of(w: np.ndarray, counts: np.ndarray, c: np.ndarray) -> dict[str, np.ndarray]:
    """Moments of weighted resamples: ``counts (b, n)`` weights (rows summing to 1)."""
    z = w - c
    raw = [counts @ z**p for p in range(1, 5)]
    return _moments_from_raw(c, *raw)


def sampling_se(draws: np.ndarray, n_draws: int, *, n_boot: int = 200,
                seed: int = 0) -> dict[str, np.ndarray]:
    """Standard errors of the four moments of ``n_draws`` surrogate draws, from ``m``
    draws ``(m, ...)`` in hand: the bootstrap standard error scaled by ``sqrt(m / n_draws)``."""
    m = draws.shape[0]
    shape = draws.shape[1:]
    w = draws.reshape(m, -1)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x5e]))
    counts = rng.multinomial(m, np.full(m, 1.0 / m), size=n_boot).astype(float) / m
    bv = _moments_of(w, counts, w.mean(axis=0))
    scale = np.sqrt(m / max(n_draws, 1))
    return {k: (np.sqrt(np.nanvar(v, axis=0)) * scale).reshape(shape) for k, v in bv.items()}


def corrected_moments(pce: OutputStats, y: np.ndarray, s: np.ndarray, *, n_boot: int = 1000,
                      seed: int = 0, max_floats: int = 2**24,
                      pce_se: dict[str, np.ndarray] | None = None) -> Corrected:
    """Control-variate mean, std, skewness and kurtosis with bootstrap intervals.

    Parameters
    ----------
    pce : OutputStats
        The PCE's own statistics of the output (shape ``(...)`` per statistic).
    y, s : ndarray, shape (n, ...)
        Model and surrogate values at the successful validation runs.
    n_boot : int
        Bootstrap resamples.
    seed : int
        Seed of the resampling (fixed: the same runs give the same intervals).
    max_floats : int
        Columns are bootstrapped in blocks of at most this many resample x column values.
    pce_se : dict of str to ndarray, shape (...), optional
        Standard errors of the PCE's own moments where they were sampled
        (:func:`sampling_se`), added to the interval in quadrature.

    Returns
    -------
    Corrected
    """
    n = y.shape[0]
    shape = y.shape[1:]
    c = np.asarray(pce.mean, dtype=float).reshape(-1)
    sd = np.nan_to_num(np.asarray(pce.std, dtype=float).reshape(-1))
    # A constant (or zero-variance) PCE has no skewness or kurtosis: its central moments are 0.
    sk = np.where(sd > 0, np.nan_to_num(np.asarray(pce.skewness, float).reshape(-1)), 0.0)
    ku = np.where(sd > 0, np.nan_to_num(np.asarray(pce.kurtosis, float).reshape(-1)), 0.0)
    base = [np.zeros_like(c), sd**2, sk * sd**3, ku * sd**4]
    yc = y.reshape(n, -1) - c
    sc = s.reshape(n, -1) - c
    diffs = [yc**p - sc**p for p in range(1, 5)]
    raw = [b + d.mean(axis=0) for b, d in zip(base, diffs)]
    values = _moments_from_raw(c, *raw)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x0b007]))
    counts = rng.multinomial(n, np.full(n, 1.0 / n), size=n_boot).astype(float) / n
    m = c.size
    ci = {k: np.empty((2, m)) for k in values}
    cols = max(1, max_floats // max(n_boot, 1))
    from scipy.stats import t as student

    widen = float(student.ppf((1 + LEVEL) / 2, max(n - 1, 1))) * np.sqrt(n / max(n - 1, 1))
    for a in range(0, m, cols):
        sl = slice(a, min(m, a + cols))
        boot = [b[sl] + counts @ d[:, sl] for b, d in zip(base, diffs)]
        bv = _moments_from_raw(c[sl], *boot)
        for k, v in bv.items():
            with np.errstate(invalid="ignore"):
                se = np.sqrt(np.nanvar(v, axis=0)) if np.isfinite(v).any() else np.nan
            half = widen * se
            if pce_se is not None and k in pce_se:
                half = np.hypot(half, 1.96 * np.asarray(pce_se[k]).reshape(-1)[sl])
            ci[k][0, sl] = values[k][sl] - half
            ci[k][1, sl] = values[k][sl] + half
    return Corrected(values={k: v.reshape(shape) for k, v in values.items()},
                     ci={k: v.reshape((2,) + shape) for k, v in ci.items()},
                     error=relative_error(y.reshape(n, -1), s.reshape(n, -1)).reshape(shape),
                     n=n)


def usable_mask(error: np.ndarray | None, loo: float | None, threshold: float,
                shape: tuple[int, ...]) -> np.ndarray:
    """Where the surrogate is usable: the validation error (per column, when known) and the
    fit's LOO error (one figure per output, when known) both at most ``threshold``.

    A series with a validation set is judged step by step by it alone (its LOO error is one
    figure over all steps, dominated by the worst); a scalar output by both.
    """
    ok = np.ones(shape, dtype=bool)
    if error is not None:
        ok &= np.asarray(error) <= threshold
    if loo is not None and (error is None or len(shape) < 2):
        ok &= bool(loo <= threshold)
    return ok


def withdraw(stats: OutputStats, usable: np.ndarray) -> None:
    """NaN the PCE's own moments (and Sobol' indices, quantiles) where it is not usable."""
    bad = ~usable
    if not bad.any():
        return
    for name in ("mean", "std", "skewness", "kurtosis"):
        v = np.array(getattr(stats, name), dtype=float)
        v[bad] = np.nan
        setattr(stats, name, v)
    cov = np.array(stats.cov, dtype=float)
    cov[bad] = np.nan  # the row of every unusable component
    stats.cov = cov
    for name in ("sobol_first", "sobol_total"):
        v = getattr(stats, name)
        if v is not None:
            v = np.array(v, dtype=float)
            v[bad] = np.nan
            setattr(stats, name, v)
    if stats.quantiles is not None:
        q = np.array(stats.quantiles, dtype=float)
        q[:, bad] = np.nan
        stats.quantiles = q
