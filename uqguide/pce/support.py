"""Whether a PCE's moments are supported by the model runs it made, or withheld.

A polynomial fitted to a few runs can put enormous values in tails no run looked at, and the
``+cv`` correction cannot see them either. Per statistic and column: the PCE's own skewness or
kurtosis is withheld unless it agrees with every estimate its runs give (the control-variate
value, and within :data:`RUNS_FACTOR` half-widths the runs' own Monte Carlo estimate); its mean
and std likewise against the runs' estimate; a ``+cv`` value the runs refute, or less precise
than they are, is withheld (:func:`corrections_to_withhold`); a skewness goes with its
withheld kurtosis (:func:`with_the_kurtosis`). The report then gives the runs' own estimate.

The rules, "agrees", the margins and the cases that set them:
docs/methods.md#validation-corrected-moments-no-usable-surrogate-the-kept-surrogate and
docs/methods.md#agreeing-and-the-runs-own-estimate.
"""

from __future__ import annotations

import warnings

import numpy as np

from .validation import MATERIAL, Corrected

#: Half-widths of the difference's 95% interval beyond which two estimates disagree.
FACTOR = 1.0
#: The same for a PCE value against the runs' plain Monte Carlo estimate: the delta-method
#: interval of a sample skewness or kurtosis from a few dozen runs is too short (the sample
#: underestimates the 8th moment that sets it; 65-85% coverage at n = 1000 on a lognormal, and
#: less at n = 60), so one half-width would withhold correct values: a 60-run PCE's kurtosis
#: 3.82 of a GMM approach whose 200-run Monte Carlo gives 3.88.
RUNS_FACTOR = 2.0
#: A fit whose corrected leave-one-out error (relative to the variance) is at most this
#: reproduces every held-out run to 1e-4 of the output's std: the surrogate is the model
#: wherever the runs are (a model that is a polynomial of the basis, e.g. ``a x1 + b x2^2``).
#: The runs' plain Monte Carlo estimate, a sample skewness or kurtosis biased low at a few
#: dozen runs, is then a worse judge of the tails than the fit itself and does not withhold
#: its values (a 40-run fit of ``a x1 + b x2^2`` has the exact kurtosis 4.959; its 40 runs
#: gave 2.51, interval [1.69, 3.34]). The control-variate check, when there is one, applies.
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


def _floor(name: str, std: np.ndarray) -> np.ndarray | float:
    return MATERIAL * np.nan_to_num(np.abs(std)) if name in ("mean", "std") else MATERIAL


def unsupported(own: dict[str, np.ndarray], corrected: Corrected | None,
                runs: Corrected | None, loo: float | None = None,
                own_se: dict[str, np.ndarray] | None = None,
                twin_disagreed: dict[str, np.ndarray] | None = None,
                **deprecated: dict[str, np.ndarray] | None) -> dict[str, np.ndarray]:
    """Where the PCE's own moments are not supported by its runs: per statistic of
    :data:`LOCATION_STATS` and :data:`SHAPE_STATS`, True where withheld.

    ``own``: the PCE's ``std``, ``skewness``, ``kurtosis`` (and ``mean``, judged where given);
    ``corrected``: the control-variate estimates (None without a validation set); ``runs``: the
    runs' Monte Carlo estimate (None with too few runs); ``loo`` at most :data:`EXACT_LOO`: the
    runs are not consulted. ``own_se``: standard errors of sampled PCE moments (a derived
    output's, or from the far tails, :mod:`uqguide.pce.far_tails`): a value whose 95% half-width
    exceeds the runs' is withheld, as a control-variate value is
    (:func:`corrections_to_withhold`). ``twin_disagreed``: where the runs disagreed with the
    control-variate value (:func:`disagrees_with_runs`); the PCE's own skewness and kurtosis are
    judged there at one half-width where the runs bound them, and withheld where they cannot (a
    user's pendulum printed a kurtosis of 5.07, model 4.19, beside a withheld ``+cv`` twin of
    5.06 [5.00, 5.11], the runs' kurtosis a floor).
    """
    twin_disagreed = _renamed(deprecated, "twin_refuted", twin_disagreed)
    out = {}
    if loo is not None and loo <= EXACT_LOO:
        runs = None
    for k in [k for k in LOCATION_STATS if k in own]:
        out[k] = np.zeros(np.shape(own[k]), dtype=bool)
        if runs is not None:
            out[k] = _disagree(np.asarray(own[k], dtype=float), 0.0, runs.values[k],
                               RUNS_FACTOR * _half(runs, k), _floor(k, own["std"]))
    for k in SHAPE_STATS:
        bad = np.zeros(np.shape(own[k]), dtype=bool)
        if corrected is not None:
            # the correction alone: the PCE's value and the corrected one share the surrogate
            # (its sampling error and its part beyond the runs' range, which widen ``ci``)
            bad |= _disagree(np.asarray(own[k], dtype=float), 0.0, corrected.values[k],
                             np.asarray(corrected.correction_half[k], dtype=float), MATERIAL)
        if runs is not None:
            bad |= _disagree(np.asarray(own[k], dtype=float), 0.0, runs.values[k],
                             RUNS_FACTOR * _half(runs, k), MATERIAL)
            if twin_disagreed is not None and k in twin_disagreed:
                # the runs refuted the twin, which shares the surrogate's tails: where they
                # bound the statistic, the PCE's value must lie within one half-width of
                # theirs; where they cannot (a floor), nothing vouches for those tails
                near = ~_disagree(np.asarray(own[k], dtype=float), 0.0, runs.values[k],
                                  _half(runs, k), MATERIAL)
                bad |= (np.asarray(twin_disagreed[k], dtype=bool)
                        & ~(_bounded(runs, k) & near) & np.isfinite(own[k]))
        out[k] = bad
    if runs is not None and own_se:
        for k in out:
            if k in own_se:
                with np.errstate(invalid="ignore"):
                    worse = 1.96 * np.asarray(own_se[k], dtype=float) > _half(runs, k)
                out[k] = out[k] | (worse & np.isfinite(np.asarray(own[k], dtype=float)))
    return out


def with_the_kurtosis(kurtosis_withheld: np.ndarray, skewness: np.ndarray) -> np.ndarray:
    """Where the PCE's skewness goes with its withheld kurtosis (see the module's rule): True
    where the kurtosis is withheld and the skewness is a value (NaN is none to withhold)."""
    return np.asarray(kurtosis_withheld, dtype=bool) & np.isfinite(skewness)


def _bounded(runs: Corrected, name: str) -> np.ndarray:
    """Where the runs' printed (tail-aware) interval of a statistic has two finite ends."""
    lo, hi = (runs.ci if runs.shown_ci is None else runs.shown_ci)[name]
    return np.isfinite(lo) & np.isfinite(hi)


def disagrees_with_runs(corrected: Corrected, runs: Corrected | None, std: np.ndarray
                        ) -> dict[str, np.ndarray]:
    """Where a control-variate value and the runs' Monte Carlo estimate disagree (the first
    half of :func:`corrections_to_withhold`; all False without ``runs``)."""
    out = {}
    for k, v in corrected.values.items():
        if runs is None:
            out[k] = np.zeros(np.shape(v), dtype=bool)
            continue
        out[k] = _disagree(v, _half(corrected, k), runs.values[k], _half(runs, k),
                           _floor(k, std))
    return out


def corrections_to_withhold(corrected: Corrected, runs: Corrected | None, std: np.ndarray
                            ) -> dict[str, np.ndarray]:
    """Where the control-variate estimates disagree with the runs' Monte Carlo estimate, or
    have a wider interval than it: the ``+cv`` values withheld (all False without ``runs``).
    ``std``: a scale of the output (the runs' std) for the immaterial floor of mean and std."""
    return either(disagrees_with_runs(corrected, runs, std), less_precise(corrected, runs))


def less_precise(corrected: Corrected, runs: Corrected | None) -> dict[str, np.ndarray]:
    """Where a control-variate value's interval is wider than the runs' own (the second half
    of :func:`corrections_to_withhold`; all False without ``runs``)."""
    out = {}
    for k, v in corrected.values.items():
        if runs is None:
            out[k] = np.zeros(np.shape(v), dtype=bool)
            continue
        hc, hr = _half(corrected, k), _half(runs, k)
        with np.errstate(invalid="ignore"):
            out[k] = (hc > hr) & np.isfinite(hr) & np.isfinite(v)
    return out


def either(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The union, per statistic, of two masks."""
    return {k: a[k] | b[k] for k in a}


def refuted(corrected: Corrected, runs: Corrected | None, std: np.ndarray
            ) -> dict[str, np.ndarray]:
    """Deprecated name of :func:`corrections_to_withhold`."""
    warnings.warn("uqguide.pce.support.refuted is deprecated: use corrections_to_withhold",
                  DeprecationWarning, stacklevel=2)
    return corrections_to_withhold(corrected, runs, std)


def _renamed(given: dict[str, dict[str, np.ndarray] | None], old: str,
             value: dict[str, np.ndarray] | None) -> dict[str, np.ndarray] | None:
    """``value``, or the deprecated keyword ``old`` of it (with a warning)."""
    unknown = set(given) - {old}
    if unknown:
        raise TypeError(f"unexpected keyword argument(s): {', '.join(sorted(unknown))}")
    if old not in given:
        return value
    warnings.warn(f"the keyword {old} is deprecated: use twin_disagreed", DeprecationWarning,
                  stacklevel=3)
    return given[old] if value is None else value
