"""The adaptive PCE's plan when the config gives no run counts: how far the design may grow
(:func:`default_budget`), when the fit's own evidence says to stop (:func:`settled`) or that
refitting on the way is wasted (:func:`stalled`), and how many validation runs check it
(:func:`default_validation`).

The rules, why these numbers and the bound behind the stopping rule:
docs/methods.md#defaults-that-are-rules-not-numbers.
"""

from __future__ import annotations

import math

import numpy as np

#: Default fit budget: this many times the initial design ...
BUDGET_FACTOR = 10
#: ... at least this many runs ...
BUDGET_MIN = 100
#: ... and at most this many (unless the initial design itself is larger).
BUDGET_MAX = 1000
#: Default validation runs: this share of the fit's runs ...
VALIDATION_SHARE = 0.25
#: ... and at least this many.
VALIDATION_MIN = 20
#: Two fits of LOO error ``e`` may differ in mean and std by ``MOMENT_FACTOR sqrt(e) std``.
MOMENT_FACTOR = 2.0
#: A design stalls when this many fits in a row (two enrichments, a 2.25-fold growth) ...
STALL_FITS = 3
#: ... have a LOO error above the usable error, the last not below this share of the first.
STALL_SHARE = 0.5


def default_budget(n0: int) -> int:
    """Fit runs the adaptive PCE may make at its defaults, for an initial design of ``n0`` runs."""
    return max(n0, min(max(BUDGET_FACTOR * n0, BUDGET_MIN), BUDGET_MAX))


def default_validation(n_fit: int) -> int:
    """Validation runs after a default fit of ``n_fit`` runs."""
    return max(VALIDATION_MIN, math.ceil(VALIDATION_SHARE * n_fit))


def mean_and_std(coef: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation ``(m,)`` of every column of an orthonormal expansion's
    coefficients ``coef (P, m)`` (row 0 the constant term)."""
    return coef[0], np.sqrt(np.sum(coef[1:] ** 2, axis=0))


def settled(previous: dict[str, tuple[np.ndarray, np.ndarray]],
            now: dict[str, tuple[np.ndarray, np.ndarray]], loo: dict[str, float],
            target: float) -> bool:
    """Whether the design may stop growing.

    ``previous``, ``now``: per output, the previous and current fit's mean and std, each
    ``(m,)`` (``previous`` empty: the first fit); ``loo``: the current fit's corrected LOO error
    per output, relative to the variance; ``target``: ``target_loo``.
    """
    if max(loo.values(), default=0.0) > target:
        return False
    for name, (mean, std) in now.items():
        if name not in previous:
            continue
        mean0, std0 = previous[name]
        tol = MOMENT_FACTOR * math.sqrt(max(loo.get(name, target), 0.0)) * np.maximum(std, std0)
        # round-off of a column that does not vary (a series' initial state) is no movement
        tol = np.maximum(tol, 1e-9 * (np.max(np.abs(mean), initial=0.0)
                                      + np.max(std, initial=0.0)))
        if np.any(np.abs(mean - mean0) > tol) or np.any(np.abs(std - std0) > tol):
            return False
    return True


def stalled(history: np.ndarray, usable_error: float) -> bool:
    """Whether the fits so far say the design will not settle before its budget: the worst
    corrected LOO error ``history`` (one per fit, the last the current) above ``usable_error``
    at each of the last :data:`STALL_FITS` fits, and the last not below :data:`STALL_SHARE`
    of the first of them. The runs still matter (they are the Monte Carlo estimate that
    stands in where the surrogate is refused); the refits between them do not."""
    last = np.asarray(history, dtype=float)[-STALL_FITS:]
    return bool(last.size == STALL_FITS and np.all(last > usable_error)
                and last[-1] >= STALL_SHARE * last[0])
