"""Moment intervals that account for the estimator's skew and for tails the sample cannot bound.

Monte Carlo's default intervals (``intervals: tail``): Hall's (1992) skew-corrected interval of
each statistic's influence function (:func:`hall_interval`), one-sided where fewer than
:data:`MIN_EFFECTIVE_RUNS` effective runs carry its variance, a skewness's or kurtosis' side
toward the tail on Student's t with the effective runs beyond that threshold as degrees of
freedom (continuous from the floor), read from the central moments up to order
:data:`MAX_ORDER`. Derivation, design decisions and measured coverage:
docs/statistics.md#how-the-tail-aware-interval-is-built.
"""

from __future__ import annotations

from statistics import NormalDist

import numpy as np

from ..core.types import STAT_NAMES

__all__ = ["MIN_EFFECTIVE_RUNS", "STUDENT_TAIL", "hall_interval", "if_moments", "if_polynomial",
           "tail_intervals"]

#: Below this many effective runs carrying a statistic's variance (Kish), its interval is
#: one-sided (module docstring).
MIN_EFFECTIVE_RUNS = 10.0

#: The statistics whose side toward the tail takes Student's t (module docstring): the mean's
#: and the std's intervals, measured within noise of 95% with the normal quantile, keep it.
STUDENT_TAIL = ("skewness", "kurtosis")

#: The highest central moment the intervals read (the kurtosis' ``E[IF^4]``).
MAX_ORDER = 16

#: The power ``2p`` of ``d`` whose sum carries each statistic's variance.
_ORDER = {"mean": 2, "std": 4, "skewness": 6, "kurtosis": 8}


def if_polynomial(name: str, r: list[np.ndarray]) -> list[np.ndarray]:
    """Coefficients ``c_0 .. c_deg`` (in powers of ``z``) of a statistic's influence function,
    in units of ``sigma`` for mean and std (Serfling 1980, section 2.2.3; Wright & Herrington
    2011), from standardised moments ``r_k = E z^k``."""
    one = np.ones_like(r[0])
    zero = np.zeros_like(r[0])
    g, k = r[3], r[4]
    return {
        "mean": [zero, one],
        "std": [-0.5 * one, zero, 0.5 * one],
        "skewness": [0.5 * g, -3.0 * one, -1.5 * g, one],
        "kurtosis": [k, -4.0 * g, -2.0 * k, zero, one],
    }[name]


def _power(c: list[np.ndarray], m: int) -> list[np.ndarray]:
    """Coefficients of the polynomial ``c`` raised to the power ``m``."""
    out = [np.ones_like(c[0])]
    for _ in range(m):
        nxt = [np.zeros_like(c[0]) for _ in range(len(out) + len(c) - 1)]
        for i, a in enumerate(out):
            for j, b in enumerate(c):
                nxt[i + j] = nxt[i + j] + a * b
        out = nxt
    return out


def if_moments(name: str, r: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """``E[IF^2]`` and ``E[IF^3]`` of a statistic from the standardised moments ``r_0 ..
    r_12`` (shapes ``(...)``); ``E[IF] = 0`` by construction."""
    c = if_polynomial(name, r)
    out = []
    for m in (2, 3):
        p = _power(c, m)
        out.append(sum(p[i] * r[i] for i in range(len(p))))
    return out[0], out[1]


def tail_intervals(mean: np.ndarray, mus: tuple[np.ndarray, ...], n: float,
                   level: float = 0.95) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Skew-corrected intervals of mean, std, skewness and kurtosis, one-sided where the runs
    cannot bound the statistic (module docstring).

    ``mus``: central moments ``(mu_2, ..., mu_16)``; ``level``: two-sided coverage (a one-sided
    interval's finite end is the same bound). Returns ``ci (2, ...)`` per statistic, ``+inf``
    (``-inf``) where the runs cannot bound it above (below), NaN where the variance is zero; and
    per statistic the effective number of runs carrying its variance.
    """
    if len(mus) < MAX_ORDER - 1:
        raise ValueError(f"tail_intervals needs the central moments up to order {MAX_ORDER} "
                         f"(got {len(mus) + 1})")
    z = NormalDist().inv_cdf(0.5 + level / 2)
    mu2 = np.asarray(mus[0], dtype=float)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        sigma = np.sqrt(np.maximum(mu2, 0.0))
        tiny = (np.abs(mean) + 1e-300) * 1e-12
        ok = sigma > tiny
        inv = np.where(ok, 1.0 / np.where(ok, sigma, 1.0), np.nan)
        r = [np.ones_like(mu2), np.zeros_like(mu2), np.ones_like(mu2)]
        r += [np.asarray(mus[k - 2], dtype=float) * inv**k for k in range(3, MAX_ORDER + 1)]
        est = {"mean": mean, "std": sigma, "skewness": r[3], "kurtosis": r[4]}
        ci: dict[str, np.ndarray] = {}
        n_eff: dict[str, np.ndarray] = {}
        for name in STAT_NAMES:
            v2, v3 = if_moments(name, r)
            scale = sigma if name in ("mean", "std") else np.ones_like(sigma)
            se = np.sqrt(np.maximum(v2, 0.0) / n) * scale
            g = v3 / np.maximum(v2, 1e-300) ** 1.5
            q = _ORDER[name]
            ne = n * r[q] ** 2 / r[2 * q]
            bounded = np.isfinite(ne) & (ne >= MIN_EFFECTIVE_RUNS) & np.isfinite(g)
            # Where the runs cannot bound the statistic, the skewness of IF (read from even
            # higher moments) is not estimated either: the floor is the plain delta one.
            g = np.where(np.isfinite(g) & bounded, g, 0.0)
            low, high = hall_interval(est[name], se, z, g / np.sqrt(n))
            if name in STUDENT_TAIL:
                # the side toward IF's tail: Student's t on the effective runs beyond the
                # floor's threshold, so it closes continuously from the floor as the runs grow
                # (docs/statistics.md#how-the-tail-aware-interval-is-built)
                q_tail = _tail_quantile(np.where(bounded, ne, np.nan), level)
                t_low, t_high = hall_interval(est[name], se, q_tail, g / np.sqrt(n))
                with np.errstate(invalid="ignore"):
                    high = np.where(bounded & (g >= 0), t_high, high)
                    low = np.where(bounded & (g < 0), t_low, low)
            # unbounded on the side of IF's heavy tail: right-skewed IF, truth above
            high = np.where(bounded | (g < 0), high, np.inf)
            low = np.where(bounded | (g >= 0), low, -np.inf)
            if name == "std":
                low = np.maximum(low, 0.0)
            elif name == "kurtosis":
                low = np.maximum(low, 1.0)
            nan = ~ok | ~np.isfinite(se)
            if name == "mean":
                nan = ~np.isfinite(se)  # a constant output has a mean and a zero-width interval
            ci[name] = np.stack([np.where(nan, np.nan, low), np.where(nan, np.nan, high)])
            n_eff[name] = np.where(ok, ne, np.nan)
    return ci, n_eff


def _tail_quantile(n_eff: np.ndarray, level: float) -> np.ndarray:
    """Student's ``t`` quantile of two-sided ``level`` on ``n_eff - MIN_EFFECTIVE_RUNS``
    degrees of freedom; ``inf`` at or below the threshold (and where ``n_eff`` is NaN)."""
    from scipy.special import stdtrit  # slow to import: only a run's statistics need it

    nu = np.asarray(n_eff, dtype=float) - MIN_EFFECTIVE_RUNS
    usable = np.isfinite(nu) & (nu > 0)
    q = stdtrit(np.where(usable, nu, 1.0), 0.5 + level / 2)
    return np.where(usable, q, np.inf)


def hall_interval(value: np.ndarray, se: np.ndarray, q: np.ndarray | float,
                  skew: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Hall's (1992) skew-corrected interval ``[T - SE G^-1(q), T - SE G^-1(-q)]``.

    ``q``: the symmetric interval's quantile (1.96, or a t quantile); ``skew``: of the
    estimator's own distribution (``g / sqrt(n)`` for a mean of ``n`` values of skewness ``g``;
    for a stratified mean ``sum_k W_k^3 mu3_k / n_k^2`` over its se cubed). ``T -+ q SE`` where
    the skew is 0; the longer side toward a positive skew.
    """
    a = np.asarray(skew, dtype=float) / 3.0
    return value - se * _hall_inverse(q, a), value - se * _hall_inverse(-q, a)


def _hall_inverse(u: np.ndarray | float, a: np.ndarray) -> np.ndarray:
    """``G^-1(u)`` of Hall's transformation ``G(t) = ((1 + a t)^3 - 1) / (3 a) + a / 2``
    (monotone in ``t``; the real cube root keeps it so for any ``u``); ``u`` itself where ``a``
    is 0."""
    small = np.abs(a) < 1e-12
    safe = np.where(small, 1.0, a)
    t = (np.cbrt(1.0 + 3.0 * safe * (u - safe / 2.0)) - 1.0) / safe
    return np.where(small, u, t)
