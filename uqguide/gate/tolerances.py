"""The gate's tolerances and their limits, the same for ``uqguide check`` and ``baseline``.

A tolerance wide enough passes anything: ``--sigmas 1e6`` let FTCAPN with a navigation constant
of 3.3 instead of 3 pass a gate that fails 20 of its 90 statistics at the default. So each
tolerance has an upper limit, and a value above it is refused (exit 2), not applied:

- ``sigmas`` (Monte Carlo: the allowed difference in combined standard errors), default 4, at
  most 10. A reseeded rerun of an unchanged study exceeds 4 standard errors in one statistic with
  probability 6e-5, and 10 with probability 2e-23: beyond 10 a wider gate buys no fewer false
  alarms, only missed regressions.
- ``pce_rtol`` (PCE: the allowed relative difference of a statistic to its scale), default 2%,
  at most 20%: a surrogate statistic 20% off its baseline is another study, not round-off.
"""

from __future__ import annotations

import math
from typing import Any

from ..errors import ResultError

DEFAULT_SIGMAS = 4.0
SIGMAS_MAX = 10.0
DEFAULT_PCE_RTOL = 0.02
PCE_RTOL_MAX = 0.2

#: option -> (largest allowed value, what it is), for the messages and the CLI help
LIMITS = {
    "--sigmas": (SIGMAS_MAX, "combined standard errors"),
    "--pce-rtol": (PCE_RTOL_MAX, "relative tolerance"),
}


def tolerance_problem(option: str, value: Any) -> str | None:
    """What is wrong with the tolerance ``option`` (``"--sigmas"`` or ``"--pce-rtol"``): a
    message naming the option, the value and the allowed range; None when it is allowed."""
    high, what = LIMITS[option]
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(value, bool) or not (math.isfinite(v) and 0 < v <= high):
        return (f"{option}: must be a number in (0, {high:g}] ({what}; a wider gate would pass "
                f"real regressions) (got {value!r})")
    return None


def check_tolerance(option: str, value: Any) -> float:
    """A gate tolerance within its limits, else ResultError (exit 2) naming the option."""
    problem = tolerance_problem(option, value)
    if problem:
        raise ResultError(problem)
    return float(value)
