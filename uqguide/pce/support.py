"""Whether a PCE's moments are supported by the model runs it made, or withheld.

The PCE's own moments against its runs (:func:`unsupported`, :func:`with_the_kurtosis`) and the
``+cv`` values against the runs' Monte Carlo estimate (:func:`corrections_to_withhold`).

The rules, "agrees", the margins and the cases that set them: docs/pce.md#what-a-pce-may-print,
docs/methods.md#validation-corrected-moments-no-usable-surrogate-the-kept-surrogate and
docs/methods.md#agreeing-and-the-runs-own-estimate.
"""

from __future__ import annotations

import warnings

import numpy as np

from .validation import MATERIAL, SCALAR_FACTOR, Corrected

#: Half-widths of the difference's 95% interval beyond which two estimates disagree.
FACTOR = 1.0
#: The same for a PCE value against the runs' plain Monte Carlo estimate, whose delta-method
#: interval is too short at a few dozen runs (docs/pce.md#two-half-widths-against-the-runs).
RUNS_FACTOR = 2.0
#: A fit whose corrected leave-one-out error is at most this is the model wherever the runs
#: are: its runs' estimate does not judge it (docs/pce.md#an-exact-fit).
EXACT_LOO = 1e-8
#: The PCE statistics judged against the control-variate value here (its mean and std are
#: judged against it by :func:`uqguide.pce.validation.disagreeing`, and against the runs here).
SHAPE_STATS = ("skewness", "kurtosis")
#: The PCE statistics judged against the runs' Monte Carlo estimate only.
LOCATION_STATS = ("mean", "std")


def _half(est: Corrected, name: str) -> np.ndarray:
    lo, hi = est.ci[name]
    return np.asarray(0.5 * (hi - lo), dtype=float)


def _disagree(a: np.ndarray, ha: np.ndarray | float, b: np.ndarray, hb: np.ndarray,
              floor: np.ndarray | float) -> np.ndarray:
    """Where two finite estimates differ by more than FACTOR half-widths of the difference
    (and more than ``floor``); False where either is NaN (nothing to compare)."""
    with np.errstate(invalid="ignore"):
        width = FACTOR * np.hypot(np.nan_to_num(ha), np.nan_to_num(hb))
        out = np.abs(a - b) > np.maximum(width, floor)
    return out & np.isfinite(a) & np.isfinite(b)


def _refute(value: np.ndarray, half: np.ndarray | float, runs: Corrected, name: str,
            factor: float, floor: np.ndarray | float, tails: bool = True) -> np.ndarray:
    """Where the runs' Monte Carlo estimate refutes ``value`` (of 95% half-width ``half``):
    it lies more than ``factor`` half-widths of the difference from the runs' value (and more
    than ``floor``) and outside their printed, tail-aware interval widened by ``half``. On a
    heavy tail the delta-method interval of a few dozen runs is far too short and their sample
    skewness and kurtosis sit low; the tail-aware interval, one-sided there, is what they can
    refute (docs/pce.md#refuted-by-the-runs). ``tails`` False: the delta-method test alone.
    False where either value is NaN."""
    value = np.asarray(value, dtype=float)
    out = _disagree(value, factor * np.asarray(half, dtype=float), runs.values[name],
                    factor * _half(runs, name), floor)
    if not tails or runs.shown_ci is None or name not in runs.shown_ci:
        return out
    lo, hi = runs.shown_ci[name]
    h = np.nan_to_num(np.asarray(half, dtype=float))
    with np.errstate(invalid="ignore"):
        inside = (value + h >= lo) & (value - h <= hi)
    return out & ~inside


def _floor(name: str, std: np.ndarray) -> np.ndarray | float:
    return MATERIAL * np.nan_to_num(np.abs(std)) if name in ("mean", "std") else MATERIAL


def unsupported(own: dict[str, np.ndarray], corrected: Corrected | None,
                runs: Corrected | None, loo: float | None = None,
                own_se: dict[str, np.ndarray] | None = None,
                twin_disagreed: dict[str, np.ndarray] | None = None, *,
                twin_refuted: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """Where the PCE's own moments are not supported by its runs: per statistic of
    :data:`LOCATION_STATS` and :data:`SHAPE_STATS`, True where withheld.

    ``own``: the PCE's ``std``, ``skewness``, ``kurtosis`` (and ``mean``, judged where given);
    ``corrected``: the control-variate estimates (None without a validation set); ``runs``: the
    runs' Monte Carlo estimate (None with too few runs); ``loo`` at most :data:`EXACT_LOO`: the
    runs are not consulted. ``own_se``: standard errors of sampled PCE moments: a value whose
    95% half-width exceeds the runs' is withheld. ``twin_disagreed``: where the runs disagreed
    with the control-variate value (:func:`disagrees_with_runs`); the PCE's own skewness and
    kurtosis are judged there at one half-width where the runs bound them, else withheld.
    ``twin_refuted``: deprecated name of ``twin_disagreed``.
    """
    if twin_refuted is not None:
        warnings.warn("the keyword twin_refuted is deprecated: use twin_disagreed",
                      DeprecationWarning, stacklevel=2)
        twin_disagreed = twin_refuted if twin_disagreed is None else twin_disagreed
    out = {}
    if loo is not None and loo <= EXACT_LOO:
        runs = None
    # a value the runs cannot refute (their tail-aware interval holds it) stands only where a
    # validation set bounds its error (credibility.bound_own); without one, the delta-method
    # test alone decides, as it must catch values off by orders of magnitude
    # (docs/pce.md#refuted-by-the-runs: a 20-run kurtosis 21.5 against 2.4)
    tails = corrected is not None
    for k in [k for k in LOCATION_STATS if k in own]:
        out[k] = np.zeros(np.shape(own[k]), dtype=bool)
        if runs is not None:
            out[k] = _refute(np.asarray(own[k], dtype=float), 0.0, runs, k, RUNS_FACTOR,
                             _floor(k, own["std"]), tails)
    for k in SHAPE_STATS:
        bad = np.zeros(np.shape(own[k]), dtype=bool)
        if corrected is not None:
            # the correction's own width (both values share the surrogate's sampling error and
            # its part beyond the runs' range), two of them as check_own's: at one, a value
            # within the printed +cv interval and 0.3% off was withheld at 1 seed in 4
            # (docs/pce.md#refuted-by-the-runs); a value kept carries that interval (bound_own)
            bad |= _disagree(np.asarray(own[k], dtype=float), 0.0, corrected.values[k],
                             SCALAR_FACTOR * np.asarray(corrected.correction_half[k],
                                                        dtype=float), MATERIAL)
        if runs is not None:
            bad |= _refute(np.asarray(own[k], dtype=float), 0.0, runs, k, RUNS_FACTOR,
                           MATERIAL, tails)
            if twin_disagreed is not None and k in twin_disagreed:
                # the twin shares the surrogate's tails: where the runs refuted it, the own
                # value is judged at one half-width (a floor refutes only what lies below it)
                bad |= (np.asarray(twin_disagreed[k], dtype=bool)
                        & _refute(np.asarray(own[k], dtype=float), 0.0, runs, k, FACTOR,
                                  MATERIAL, tails))
        out[k] = bad
    if runs is not None and own_se:
        for k in out:
            if k in own_se:
                with np.errstate(invalid="ignore"):
                    worse = 1.96 * np.asarray(own_se[k], dtype=float) > _half(runs, k)
                out[k] = out[k] | (worse & np.isfinite(np.asarray(own[k], dtype=float)))
    return out


def near_the_runs(value: np.ndarray, runs: Corrected, name: str, std: np.ndarray
                  ) -> np.ndarray:
    """Where ``value`` of statistic ``name`` lies within :data:`RUNS_FACTOR` delta-method
    half-widths of the runs' estimate (or an immaterial amount, ``std`` its scale): where the
    runs' interval may stand as its bound (:func:`uqguide.pce.credibility.bound_own`)."""
    value = np.asarray(value, dtype=float)
    far = _disagree(value, 0.0, runs.values[name], RUNS_FACTOR * _half(runs, name),
                    _floor(name, std))
    return ~far & np.isfinite(value) & np.isfinite(runs.values[name])


def with_the_kurtosis(kurtosis_withheld: np.ndarray, skewness: np.ndarray) -> np.ndarray:
    """Where the PCE's skewness goes with its withheld kurtosis (see the module's rule): True
    where the kurtosis is withheld and the skewness is a value (NaN is none to withhold)."""
    return np.asarray(kurtosis_withheld, dtype=bool) & np.isfinite(skewness)


def disagrees_with_runs(corrected: Corrected, runs: Corrected | None, std: np.ndarray
                        ) -> dict[str, np.ndarray]:
    """Where a control-variate value and the runs' Monte Carlo estimate disagree (the first
    half of :func:`corrections_to_withhold`; all False without ``runs``)."""
    if runs is None:
        return _nowhere(corrected)
    return {k: _refute(v, _half(corrected, k), runs, k, FACTOR, _floor(k, std))
            for k, v in corrected.values.items()}


def corrections_to_withhold(corrected: Corrected, runs: Corrected | None, std: np.ndarray
                            ) -> dict[str, np.ndarray]:
    """Where the control-variate estimates disagree with the runs' Monte Carlo estimate, or
    have a wider interval than it: the ``+cv`` values withheld (all False without ``runs``).
    ``std``: a scale of the output (the runs' std) for the immaterial floor of mean and std."""
    return either(disagrees_with_runs(corrected, runs, std), less_precise(corrected, runs))


def less_precise(corrected: Corrected, runs: Corrected | None) -> dict[str, np.ndarray]:
    """Where a control-variate value's interval is wider than the runs' own (the second half
    of :func:`corrections_to_withhold`; all False without ``runs``). The runs' half-width is
    their printed, tail-aware interval's, at most :data:`RUNS_FACTOR` of their delta-method
    half-widths: the delta method alone is too short at a few dozen runs (a 43-run kurtosis
    3.2 +- 1.2 withheld a +cv 4.4 +- 1.4 that held the truth 4.32), and a tail-aware interval
    that says nothing ([1, inf]) would prefer any +cv value (a 214 +- 640 against 2.4)."""
    if runs is None:
        return _nowhere(corrected)
    out = {}
    for k, v in corrected.values.items():
        hc, hr = _half(corrected, k), _half(runs, k)
        if runs.shown_ci is not None and k in runs.shown_ci:
            lo, hi = runs.shown_ci[k]
            with np.errstate(invalid="ignore"):
                tail = np.fmin(np.asarray(0.5 * (hi - lo), dtype=float), RUNS_FACTOR * hr)
                hr = np.fmax(hr, tail)
        with np.errstate(invalid="ignore"):
            out[k] = (hc > hr) & np.isfinite(hr) & np.isfinite(v)
    return out


def _nowhere(corrected: Corrected) -> dict[str, np.ndarray]:
    return {k: np.zeros(np.shape(v), dtype=bool) for k, v in corrected.values.items()}


def either(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The union, per statistic, of two masks."""
    return {k: a[k] | b[k] for k in a}


def refuted(corrected: Corrected, runs: Corrected | None, std: np.ndarray
            ) -> dict[str, np.ndarray]:
    """Deprecated name of :func:`corrections_to_withhold`."""
    warnings.warn("uqguide.pce.support.refuted is deprecated: use corrections_to_withhold",
                  DeprecationWarning, stacklevel=2)
    return corrections_to_withhold(corrected, runs, std)
