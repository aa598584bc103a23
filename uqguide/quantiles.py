"""Quantiles from order statistics, with distribution-free intervals.

For ``n`` independent draws of ``Y`` the ``p``-quantile is estimated by the order statistic
``Y_(r)``, ``r = ceil(n p)`` (the inverse of the empirical CDF). Its 95% interval is
``[Y_(l), Y_(u)]`` with ranks from the binomial law of the number of draws below the true
quantile, ``B ~ Bin(n, p)``: ``P(Y_(l) <= q_p <= Y_(u)) = P(l <= B <= u - 1)``; ``l`` is the
2.5% point of ``B`` and ``u - 1`` its 97.5% point, so the coverage is at least 95% for every
continuous distribution (:func:`coverage` gives it exactly). When ``l < 1`` (too few draws for
the tail: ``n p`` below about 3.7) the lower end is ``-inf``, and when ``u > n`` the upper end
is ``+inf``: an honest "unbounded", never a made-up number.

Monte Carlo keeps each chunk's values at the steps it reports quantiles for and sorts the
union at the end, so the quantiles are exact and do not depend on the chunking or the workers.
"""

from __future__ import annotations

import numpy as np

LEVEL = 0.95
#: ``quantiles: 3sigma``: the median and the 3-sigma envelope (the probabilities of a
#: Gaussian's mean -+ 3 std).
#: scipy.stats.norm.cdf(-3), 0.5, norm.cdf(3), as literals so importing this module does not
#: import scipy.stats (tests/test_startup.py checks them against scipy).
THREE_SIGMA = (0.0013498980316300933, 0.5, 0.9986501019683699)


def resolve_levels(value: list[float] | str | None) -> tuple[float, ...] | None:
    """The config's ``quantiles`` as sorted probabilities (``"3sigma"`` expanded)."""
    if value is None:
        return None
    if isinstance(value, str):
        return THREE_SIGMA
    return tuple(sorted(dict.fromkeys(float(p) for p in value)))


def ranks(n: int, p: float, level: float = LEVEL) -> tuple[int, int, int]:
    """1-based ranks ``(r, l, u)`` of the estimate and of the interval's ends (``l`` may be 0,
    ``u`` may be ``n + 1``: unbounded ends)."""
    r = min(max(int(np.ceil(n * p - 1e-12)), 1), n)
    a = (1.0 - level) / 2.0
    from scipy import stats as _st

    lo = int(_st.binom.ppf(a, n, p))
    hi = int(_st.binom.ppf(1.0 - a, n, p)) + 1
    return r, lo, hi


def coverage(n: int, p: float, level: float = LEVEL) -> float:
    """Exact coverage of the interval of :func:`ranks` for any continuous distribution."""
    _, lo, hi = ranks(n, p, level)
    from scipy import stats as _st

    return float(_st.binom.cdf(hi - 1, n, p) - _st.binom.cdf(lo - 1, n, p))


def order_statistic_quantiles(y: np.ndarray, levels: tuple[float, ...], level: float = LEVEL,
                              presorted: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Quantiles ``(q, ...)`` of ``y (n, ...)`` along axis 0 and their intervals
    ``(2, q, ...)``. NaN values (none expected: failed runs are left out before) sort last."""
    n = y.shape[0]
    q = len(levels)
    vals = np.full((q,) + y.shape[1:], np.nan)
    ci = np.full((2, q) + y.shape[1:], np.nan)
    if n == 0:
        return vals, ci
    s = y if presorted else np.sort(y, axis=0)
    for i, p in enumerate(levels):
        r, lo, hi = ranks(n, p, level)
        vals[i] = s[r - 1]
        ci[0, i] = s[lo - 1] if lo >= 1 else -np.inf
        ci[1, i] = s[hi - 1] if hi <= n else np.inf
    return vals, ci


def level_name(p: float) -> str:
    """Column name of a quantile level: ``q0.05``, ``q0.99865``."""
    return f"q{p:.6g}"
