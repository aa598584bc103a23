"""Whether a PCE's skewness and kurtosis are supported by the model runs it made.

A PCE's moments are exact for the surrogate. Its skewness and kurtosis are carried by the
surrogate's tails, and a polynomial fitted to a few runs can put enormous values where no run
looked: a 20-run, degree-16 fit of a damped oscillator (issue 27) gave kurtosis 2.7e3 where
the model's is 2.4. The control-variate estimate (``+cv``) does not repair that: it corrects
the surrogate only where the validation runs are, and the tails that carry the moment lie
beyond them (its interval, from the same runs, is narrow and wrong).

Rule (per statistic and column, i.e. time step x component):

- the PCE's own skewness or kurtosis is **withheld** unless it agrees with every estimate of
  it its runs give: the control-variate value (with a validation set) and the plain Monte
  Carlo estimate of the fit and validation runs (:mod:`uqguide.pce.runs_estimate`);
- its mean and std likewise, against the runs' Monte Carlo estimate (against the
  control-variate value they are judged by :func:`uqguide.pce.validation.disagreeing`). A
  high-degree fit of a kinked series extrapolates beyond every run: the zoo's ramp at 248 runs
  (seed 8) printed a std of 0.201 where the model's is 0.163 and its runs' own estimate said so,
  while its validation runs, which seldom reach that far, did not;
- a control-variate value (any of the four moments) is **refuted** where it disagrees with the
  runs' Monte Carlo estimate: it is then not reported either, and no message says it holds.
  It is also dropped where its interval is wider than the runs' Monte Carlo interval: the
  surrogate then adds variance instead of removing it (a control variate worse than none; a
  kurtosis of 1.5e5 with an interval reaching down to the model's 2.9 is no answer);
- where the runs refuted the control-variate skewness or kurtosis by *disagreeing* with it
  (not merely by being more precise), the PCE's own value, which shares the surrogate's tails
  with it, is judged against the runs at one half-width instead of :data:`RUNS_FACTOR`, wherever
  the runs' tail-aware interval bounds the statistic on both sides, and is withheld where that
  interval is a floor (a heavy tail's: the runs' sample value is biased low and cannot vouch
  for the tails the refuted twin shares). A damped pendulum's final angle (2 inputs, a user's
  script, default ``pce_adaptive``, 250 runs) printed a PCE kurtosis of 3.58 against the
  model's 2.83 (2e4 Monte Carlo runs): its ``+cv`` twin was refuted by the runs' 2.69 +- 0.56,
  but the PCE's value passed the two-half-width check; another printed 5.07 against 4.19
  beside a twin of 5.06 [5.00, 5.11] and the runs' floor;
- where the PCE's own kurtosis is withheld (by its runs or its validation runs), its skewness
  is **withheld with it** (:func:`with_the_kurtosis`): both are carried by the surrogate's
  tails, and a fourth moment the runs refute says those tails are not the model's. A contact
  kink (a user's 3-input beam, 234 runs) had its PCE kurtosis at 1.0e3 against the model's
  2.36; its skewness, -0.043 against the model's -0.209, passed both checks only because the
  runs' own skewness interval ([-0.40, -0.04]) was wide.

"Agrees": the difference lies within the 95% interval of the difference, ``sqrt(h_a^2 +
h_b^2)`` for half-widths ``h_a``, ``h_b`` (a PCE value is exact for its surrogate, ``h = 0``:
it must lie within the other estimate's interval), or is below the immaterial amount
:data:`~uqguide.pce.validation.MATERIAL`. One half-width, as the issue asks ("within their
intervals"): a correct PCE then loses about 5% of its points to chance, and those points get
the runs' estimate instead, never no answer. Two half-widths (about four standard errors)
kept a 20-run oscillator's kurtosis of 2.7e3 within its control-variate interval
([2.1e3, 4.0e3]), whose own validation runs never reach the tails that carry it. Against the
runs' plain Monte Carlo estimate the margin is :data:`RUNS_FACTOR` half-widths instead (see
there): that check exists to catch values off by orders of magnitude, which it does (the same
oscillator's kurtosis 2.7e3 against 2.0 +- 0.9 from its 77 runs).

What the rule costs: a correct PCE of a heavy-tailed output whose few runs have not seen the
tail (a lognormal's kurtosis from 30 runs) is withheld too; the report then gives the runs'
own estimate, labelled as such. Nothing the runs contain supports the tail the PCE
extrapolated; the issue's rule is "never an absurd number", and withholding with an answer
beside it is the honest form of it.
"""

from __future__ import annotations

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
                twin_refuted: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """Where the PCE's own moments are not supported by its runs.

    Parameters
    ----------
    own : dict of str to ndarray, shape (...)
        The PCE's own ``std``, ``skewness`` and ``kurtosis``, and its ``mean`` (judged where
        given).
    corrected : Corrected, optional
        The control-variate estimates (None without a validation set).
    runs : Corrected, optional
        The runs' Monte Carlo estimate (None when there are too few runs).
    loo : float, optional
        The fit's corrected LOO error; at most :data:`EXACT_LOO`, ``runs`` is not consulted.
    own_se : dict of str to ndarray, optional
        Standard errors of PCE moments that were sampled (a derived output's, or where the
        exact moments came from the far tails, :mod:`uqguide.pce.far_tails`): a value whose
        95% half-width exceeds the runs' own is withheld, as a control-variate value is
        (:func:`refuted`): the runs' estimate is then the better one.
    twin_refuted : dict of str to ndarray of bool, optional
        Where the runs disagreed with the control-variate value of a statistic
        (:func:`disagrees_with_runs`, before it was dropped): the PCE's own skewness and
        kurtosis are judged there at one half-width where the runs bound them, and withheld
        where the runs cannot bound them (a stated floor): a user's pendulum at defaults
        printed a kurtosis of 5.07 (model 4.19) beside a refuted ``+cv`` twin of 5.06
        [5.00, 5.11], the runs' kurtosis a floor.

    Returns
    -------
    dict of str to ndarray of bool, shape (...)
        Per statistic of :data:`LOCATION_STATS` and :data:`SHAPE_STATS`: True where it is
        withheld.
    """
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
            if twin_refuted is not None and k in twin_refuted:
                # the runs refuted the twin, which shares the surrogate's tails: where they
                # bound the statistic, the PCE's value must lie within one half-width of
                # theirs; where they cannot (a floor), nothing vouches for those tails
                near = ~_disagree(np.asarray(own[k], dtype=float), 0.0, runs.values[k],
                                  _half(runs, k), MATERIAL)
                bad |= (np.asarray(twin_refuted[k], dtype=bool)
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
    half of :func:`refuted`; all False without ``runs``)."""
    out = {}
    for k, v in corrected.values.items():
        if runs is None:
            out[k] = np.zeros(np.shape(v), dtype=bool)
            continue
        out[k] = _disagree(v, _half(corrected, k), runs.values[k], _half(runs, k),
                           _floor(k, std))
    return out


def refuted(corrected: Corrected, runs: Corrected | None, std: np.ndarray
            ) -> dict[str, np.ndarray]:
    """Where the control-variate estimates disagree with the runs' Monte Carlo estimate.

    Parameters
    ----------
    corrected : Corrected
    runs : Corrected, optional
    std : ndarray, shape (...)
        A scale of the output (the runs' std) for the immaterial floor of mean and std.

    Returns
    -------
    dict of str to ndarray of bool, shape (...)
        Per moment: True where the ``+cv`` value is refuted or its interval is wider than the
        runs' (all False without ``runs``).
    """
    return either(disagrees_with_runs(corrected, runs, std), less_precise(corrected, runs))


def less_precise(corrected: Corrected, runs: Corrected | None) -> dict[str, np.ndarray]:
    """Where a control-variate value's interval is wider than the runs' own (the second half
    of :func:`refuted`; all False without ``runs``)."""
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
