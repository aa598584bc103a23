"""The Monte Carlo estimate of the model runs a PCE method already made (its ``+mc`` fallback):
the sample moments of its fit and validation runs, with the union of the delta-method and the
tail-aware interval (:data:`INTERVAL` says what it assumes).

The mixture, its variance and why the union:
docs/methods.md#agreeing-and-the-runs-own-estimate.
"""

from __future__ import annotations

import numpy as np

from ..core.types import OutputStats
from ..stats.tail_intervals import MAX_ORDER, tail_intervals
from .validation import Corrected, corrected_moments
from .validation_design import ValidationDesign

#: What the ``+mc`` interval assumes (the report's legend and the diagnostics).
INTERVAL = ("95% delta-method interval of the method's own fit and validation runs, the fit "
            "runs treated as independent draws (an upper bound for a scrambled Sobol' design "
            "of a smooth output), widened to the tail-aware interval (one-sided where a few "
            "runs carry the statistic's variance)")


def runs_estimate(fit: np.ndarray | None, validation: np.ndarray | None,
                  design: ValidationDesign | None) -> Corrected | None:
    """Sample mean, std, skewness and kurtosis of a PCE's own model runs, with intervals.

    ``fit (n_fit, ...)``: the output at the successful fit runs (None: not a random design, e.g.
    quadrature nodes); ``validation (n_val, ...)`` with ``design`` restricted to the successful
    runs (:meth:`~uqguide.pce.validation_design.ValidationDesign.successful`). Returns ``values``
    and ``ci`` (``(...)``, ``(2, ...)``), ``error`` zeros; None with fewer than 3 runs.
    """
    parts, weights, strata, shares = [], [], [], []
    n_fit = 0 if fit is None else fit.shape[0]
    n_val = 0 if validation is None or design is None else validation.shape[0]
    total = n_fit + n_val
    if total < 3:
        return None
    if n_fit:
        assert fit is not None
        parts.append(fit)
        weights.append(np.full(n_fit, 1.0 / total))
        strata.append(np.zeros(n_fit, dtype=int))
        shares.append(np.array([n_fit / total]))
    pool = 0
    if n_val:
        assert validation is not None and design is not None
        parts.append(validation)
        weights.append(design.weight * (n_val / total))
        strata.append(design.stratum + (1 if n_fit else 0))
        shares.append(design.share * (n_val / total))
        pool = design.pool
    y = np.concatenate(parts).astype(float)
    w = np.concatenate(weights)
    c = np.tensordot(w, y, axes=(0, 0))
    flat = np.zeros(y.shape[1:])
    # A constant surrogate at the runs' mean: the "correction" is then the runs' own moments.
    constant = OutputStats(mean=c, std=flat, skewness=flat, kurtosis=flat,
                           cov=np.zeros(y.shape[1:] + y.shape[-1:]), n_used=total)
    s = np.broadcast_to(c, y.shape)
    found = corrected_moments(constant, y, s, weight=w, stratum=np.concatenate(strata),
                              share=np.concatenate(shares), pool=pool)
    _bound_tails(found, y, w)
    return found


#: The least value a statistic can take (any distribution).
LOWEST = {"std": 0.0, "kurtosis": 1.0}


def _bound_tails(found: Corrected, y: np.ndarray, weight: np.ndarray) -> None:
    """Set ``found.shown_ci``: ``found.ci`` united with the tail-aware interval of the runs,
    weighted as the estimate (Kish's ``n = (sum w)^2 / sum w^2``)."""
    w = weight / weight.sum()
    mean = np.tensordot(w, y, axes=(0, 0))
    d = y - mean
    mus, pw = [], d * d
    with np.errstate(over="ignore", invalid="ignore"):
        for _ in range(2, MAX_ORDER + 1):
            mus.append(np.tensordot(w, pw, axes=(0, 0)))
            pw = pw * d
        tail = tail_intervals(mean, tuple(mus), 1.0 / float(np.sum(w * w)))[0]
    shown = {}
    for name, q in (found.ci if found.shown_ci is None else found.shown_ci).items():
        t = tail[name]
        lo = np.where(np.isnan(t[0]), q[0], np.fmin(q[0], t[0]))
        hi = np.where(np.isnan(t[1]), q[1], np.fmax(q[1], t[1]))
        lo = np.maximum(lo, LOWEST.get(name, -np.inf))
        shown[name] = np.stack([lo, hi])
    found.shown_ci = shown


def unresolved(found: Corrected, name: str) -> np.ndarray:
    """Where the runs' printed interval of statistic ``name`` says nothing its definition does
    not: one end infinite and the other at the least value any distribution takes (a std
    ``>= 0``, a kurtosis ``>= 1``). Such a floor is "not resolved by N runs", not an estimate
    (docs/pce.md#not-resolved-by-the-runs)."""
    lo, hi = (found.ci if found.shown_ci is None else found.shown_ci)[name]
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if name not in LOWEST:
        return np.zeros(lo.shape, dtype=bool)
    with np.errstate(invalid="ignore"):
        trivial = lo <= LOWEST[name]
    one_sided = np.isinf(lo) | np.isinf(hi)
    return one_sided & trivial & np.isfinite(np.asarray(found.values[name], dtype=float))
