"""The step every PCE method shares after its fit: keep the surrogate, validate it on
independent runs, correct its moments and withdraw them where it is not usable; withhold a
skewness or kurtosis its own runs do not support (:mod:`uqguide.pce.support`) and give, where
any moment is withheld, the Monte Carlo estimate of the runs it made
(:mod:`uqguide.pce.runs_estimate`, the ``+mc`` rows).

Settings (every PCE method)::

    validation: {n_samples: 100}   # independent model runs after the fit
    validation: {n_samples: 0}     # none (the opt-out of pce_adaptive's default set)
    validation: {n_samples: 100, design: random}   # plain random runs, not stratified
    usable_error: 0.1              # LOO / validation error above which a PCE reports no moments

The validation runs come from the method's own stream (keyed by its label), are chosen once the
surrogate is fitted (stratified by its value, :mod:`uqguide.pce.validation_design`), are
appended after the fit's runs in the design and never reach the fit. What they give is
described in :mod:`uqguide.pce.validation`.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any, Literal

import numpy as np
from pydantic import ConfigDict, Field, field_validator

from ..core.strict import StrictModel

from ..core.inputs import InputSpace
from ..pce.surrogate import Surrogate
from ..pce.validation import (
    USABLE_ERROR, corrected_moments, disagreeing, sampling_se, sustained, usable_mask,
    validation_unit_rows, withdraw,
)
from ..pce.far_tails import beyond_the_runs, can_swing, far_draws, replace_far_tails
from ..pce.point_choice import better_points
from ..pce.runs_estimate import INTERVAL, runs_estimate
from ..pce.support import (disagrees_with_runs, either, less_precise, unsupported,
                           with_the_kurtosis)
from ..pce.loo import FitRuns
from ..pce.validation import Corrected
from ..pce.validation_design import (ValidationDesign, curved_inputs, random_validation,
                                     stratified_validation)
from ..core.types import STAT_NAMES, Estimate, ModelOutput

log = logging.getLogger(__name__)


class ValidationSettings(StrictModel):
    """``validation:`` of a PCE method.

    Attributes
    ----------
    n_samples : int
        Independent model runs after the fit; 0 (or 2 and more): 0 is the explicit opt-out
        of a method's default validation set (``pce_adaptive`` at its default design).
    design : {"stratified", "random"}
        Stratified by the fitted surrogate's value (default; the tails get runs of their own,
        :mod:`uqguide.pce.validation_design`) or plain random.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    n_samples: int = Field(ge=0, le=10_000_000,
                           description="independent model runs that validate the surrogate "
                                       "(0: none, the explicit opt-out of a method's default)")
    design: Literal["stratified", "random"] = Field(
        default="stratified", description="stratified by the surrogate's value, or random")

    @field_validator("n_samples")
    @classmethod
    def _none_or_two(cls, v: int) -> int:
        # one run has no spread: no validation error, no interval of a corrected moment
        if v == 1:
            raise ValueError("The 'n_samples' parameter of validation must be 0 (no validation "
                             "runs) or an integer >= 2. Got 1 instead.")
        return v


def validation_design(settings: ValidationSettings | None, n: int, surrogate: Surrogate,
                      outputs: tuple[str, ...], *, seed: int, label: str, d: int
                      ) -> ValidationDesign:
    """The ``n`` validation runs of a fitted surrogate: stratified by the value of the
    ``outputs`` it reports (all it predicts when none is named) unless ``settings`` asks for
    random runs or there are none (the legacy ``validation_runs``)."""
    if settings is None or settings.design == "random":
        return random_validation(seed, label, n, d)
    names = [o for o in outputs if o in surrogate.names] or surrogate.names
    fitted = [surrogate.expansions[o].trimmed().alpha for o in names
              if o in surrogate.expansions] or [e.trimmed().alpha
                                                for e in surrogate.expansions.values()]
    return stratified_validation(lambda u: surrogate.at_unit(u, names), seed, label, n, d,
                                 curved=curved_inputs(fitted, d))


#: Fields the PCE methods' settings add (annotations and defaults), one definition for all.
VALIDATION_FIELD = Field(default=None, description="independent runs that validate the "
                                                    "surrogate and correct its moments")
USABLE_FIELD = Field(default=USABLE_ERROR, gt=0.0, le=10.0,
                     description="relative LOO / validation error above which the PCE reports "
                                 "no moments ('no usable surrogate')")


#: Fresh surrogate draws that measure the sampling error of sampled PCE moments.
SE_DRAWS = 20_000


def _values(out: ModelOutput, name: str) -> np.ndarray | None:
    if name in out.series:
        return np.asarray(out.series[name], dtype=float)
    if name in out.scalars:
        return np.asarray(out.scalars[name], dtype=float)
    return None


def finish(estimate: Estimate, surrogate: Surrogate, *, space: InputSpace,
           validation: ModelOutput | None, design: ValidationDesign | None,
           loo: Mapping[str, float], threshold: float, seed: int,
           n_draws: int = 1_000_000, fit: ModelOutput | None = None,
           fit_u: np.ndarray | None = None,
           fit_loo_values: Mapping[str, np.ndarray] | None = None) -> None:
    """Keep the surrogate in ``estimate``; validate, correct and judge every output in place.

    Parameters
    ----------
    estimate : Estimate
        The PCE's estimate (its own statistics of every fitted and derived output).
    surrogate : Surrogate
    space : InputSpace
    validation : ModelOutput, optional
        The validation runs' outputs (None: no validation set).
    design : ValidationDesign, optional
        Their inputs on the unit cube, weights and strata.
    loo : mapping of str to float
        The fit's relative LOO error per fitted output (empty for quadrature PCEs).
    threshold : float
        ``usable_error``.
    seed : int
        The run's seed (keys the draws that measure sampled moments' sampling error).
    n_draws : int
        Surrogate draws behind sampled moments (their sampling error joins the intervals).
    fit : ModelOutput, optional
        The fit's runs when they are a sample of the input distribution (a regression
        design; not quadrature nodes): with the validation runs they give the Monte Carlo
        estimate that judges the PCE's skewness and kurtosis (:mod:`uqguide.pce.support`)
        and stands in where a statistic is withheld (:mod:`uqguide.pce.runs_estimate`).
    fit_u : ndarray, shape (n_fit, d), optional
        The fit's runs on the unit cube: with the validation runs they give the range beyond
        which the surrogate extrapolates, whose share of each statistic widens the ``+cv``
        interval (:func:`uqguide.pce.far_tails.beyond_the_runs`).
    fit_loo_values : mapping of str to ndarray, shape (n_ok, ...), optional
        The surrogate's leave-one-out values at the fit's successful runs, per fitted output
        (:mod:`uqguide.pce.loo_values`): with ``fit`` and ``fit_u`` they floor the ``+cv``
        intervals' variance (:func:`uqguide.pce.validation.stratified_se`).
    """
    estimate.surrogate = surrogate
    diag = estimate.diagnostics
    diag["usable_error"] = threshold
    ok = None
    used = None
    if validation is not None and design is not None:
        ok = ~validation.failed
        used = design.successful(ok)
        diag["n_validation"] = int(validation.n)
        diag["n_validation_failed"] = int(validation.failed.sum())
        pool_kind = "" if design.ratio is None else " arcsine, importance-weighted"
        diag["validation_design"] = (f"stratified ({design.share.size} strata of a "
                                     f"{design.pool}-point{pool_kind} pool)"
                                     if design.stratified else "random")
    time = validation.time if validation is not None else None
    if (time is None or time.size == 0) and fit is not None:
        time = fit.time
    box = _runs_box(fit_u, fit, used)
    for name, st in estimate.stats.items():
        beyond = _far_tails(diag, estimate.label, name, st, surrogate, space, seed, box)
        err = None
        corrected = None
        y = _values(validation, name) if validation is not None else None
        if y is not None and ok is not None and used is not None and int(ok.sum()) >= 2:
            s = surrogate.at_unit(used.u, [name])[name].reshape(y[ok].shape)
            pce_se = None
            if st.sampling_se:
                pce_se = st.sampling_se
            elif st.moments_method == "surrogate-sampling":
                cols = int(np.prod(y.shape[1:]))
                m = min(SE_DRAWS, n_draws, max(1000, 2_000_000 // max(cols, 1)))
                u = validation_unit_rows(seed, f"{estimate.label}/se", m, space.dim)
                draws = surrogate.at_unit(u, [name])[name].reshape((m,) + y.shape[1:])
                pce_se = sampling_se(draws, n_draws, seed=seed)
            cv = corrected_moments(st, y[ok], s, weight=used.weight, stratum=used.stratum,
                                   share=used.share, pool=used.pool, pce_se=pce_se,
                                   fit_runs=_fit_runs(name, surrogate, used, fit, fit_u,
                                                      fit_loo_values))
            if beyond is not None:
                _widen(cv, beyond)
            st.corrected = cv.values
            st.corrected_ci = _printed(cv)
            st.validation_error = err = cv.error
            diag[f"validation_error.{name}"] = float(np.max(err)) if err.size else 0.0
            corrected = cv
        runs = _runs_estimate(name, fit, validation, ok, used)
        twin_refuted = None
        if corrected is not None:
            twin_refuted = _drop_refuted(diag, estimate.label, name, st, corrected, runs)
        # Derived outputs have no LOO of their own: their carriers' LOO judges them.
        fit_loo = loo.get(name)
        if fit_loo is None and name in surrogate.derived:
            carriers = [loo[c] for c in surrogate.derived[name].carriers if c in loo]
            fit_loo = max(carriers) if carriers else None
        usable = usable_mask(err, fit_loo, threshold, np.shape(st.mean))
        # A scalar every fit run gave the same value (a collision flag that never fired) has
        # an exactly constant expansion: its std 0 says nothing about how often it varies,
        # so it is no result (the validation runs' corrected moments, if any, remain).
        constant = np.ndim(st.mean) == 1 and bool(np.any(np.asarray(st.std) == 0.0))
        if constant:
            usable = usable & (np.asarray(st.std) != 0.0)
        st.usable = usable
        refuted_own = {}
        if corrected is not None:
            refuted_own = _withhold_refuted(diag, estimate.label, name, st, corrected, time,
                                            usable)
        _withhold_unsupported(diag, estimate.label, name, st, corrected, runs, usable, time,
                              fit_loo, refuted_own, twin_refuted)
        if corrected is not None:
            _choose_points(diag, name, st, corrected, usable)
        if st.fallback:
            diag["fallback_interval"] = INTERVAL
        if usable.all():
            continue
        withdraw(st, usable)
        why = (f"validation error {float(np.max(err)):.3g}" if err is not None
               else f"LOO error {fit_loo:.3g}")
        if constant:
            diag[f"unusable.{name}"] = (f"constant on all {st.n_used} fit runs: a PCE cannot "
                                        f"tell a constant from a rare event")
            log.warning("%s: %s: no usable surrogate (constant on all %d fit runs); its "
                        "moments are not reported", estimate.label, name, st.n_used)
            continue
        if usable.ndim == 2 and time is not None and time.size == usable.shape[0]:
            bad_t = np.flatnonzero(~usable.all(axis=1))
            diag[f"unusable_from.{name}"] = float(time[bad_t[0]])
            diag[f"unusable_steps.{name}"] = int(bad_t.size)
            log.warning("%s: %s: no usable surrogate from t = %g s (%d of %d steps; %s > %g)",
                        estimate.label, name, time[bad_t[0]], bad_t.size, usable.shape[0],
                        why, threshold)
        else:
            diag[f"unusable.{name}"] = f"{why} > {threshold:g}"
            log.warning("%s: %s: no usable surrogate (%s > %g); its moments are not reported",
                        estimate.label, name, why, threshold)


def _fit_runs(name: str, surrogate: Surrogate, used: ValidationDesign,
              fit: ModelOutput | None, fit_u: np.ndarray | None,
              fit_loo: Mapping[str, np.ndarray] | None) -> FitRuns | None:
    """The fit's successful runs as a second sample of ``name``'s differences (None where
    a piece is missing: a random design, a derived output whose carriers have no
    leave-one-out values, given germ points)."""
    sorter = used.sorter
    if (sorter is None or fit is None or fit_u is None or fit_loo is None
            or name not in fit_loo or fit_u.shape[0] != fit.n):
        return None
    ok = ~fit.failed
    y = _values(fit, name)
    if y is None or int(ok.sum()) != fit_loo[name].shape[0]:
        return None
    u = np.asarray(fit_u, dtype=float)[ok]
    at = surrogate.at_unit(u, list(sorter.scale))
    return FitRuns(y=y[ok], s_loo=fit_loo[name].reshape(y[ok].shape),
                   stratum=sorter.strata(at), ratio=sorter.ratios(u),
                   input_share=sorter.input_share)


def _runs_box(fit_u: np.ndarray | None, fit: ModelOutput | None,
              used: ValidationDesign | None) -> tuple[np.ndarray, np.ndarray] | None:
    """The range (low, high per coordinate of the unit cube) of the successful fit and
    validation runs; None without the fit's points."""
    if fit_u is None or fit is None or fit_u.shape[0] != fit.n:
        return None
    pts = [np.asarray(fit_u, dtype=float)[~fit.failed]]
    if used is not None:
        pts.append(np.asarray(used.u, dtype=float))
    u = np.vstack(pts)
    if u.shape[0] == 0:
        return None
    return u.min(axis=0), u.max(axis=0)


def _far_tails(diag: dict[str, Any], label: str, name: str, st: Any, surrogate: Surrogate,
               space: InputSpace, seed: int, box: tuple[np.ndarray, np.ndarray] | None
               ) -> dict[str, np.ndarray] | None:
    """Where a fitted output's exact moments come from inputs too rare for any run, take them
    from surrogate draws instead (:mod:`uqguide.pce.far_tails`); diagnostics
    ``far_tails.<output>`` count the columns.

    Returns
    -------
    dict of str to ndarray, optional
        With the runs' range ``box`` (low, high on the unit cube): per statistic, the part the
        surrogate takes from beyond it (:func:`uqguide.pce.far_tails.beyond_the_runs`), which
        widens the ``+cv`` interval. None where the polynomial cannot swing.
    """
    if name not in surrogate.expansions or st.sampling_se:
        return None  # derived outputs are sampled already
    if not can_swing(surrogate.expansions[name]):
        return None
    shape = np.shape(st.mean)
    m = far_draws(int(np.prod(shape)))
    u = validation_unit_rows(seed, f"{label}/far", m, space.dim)
    draws = surrogate.at_unit(u, [name])[name].reshape((m,) + shape)
    beyond = None
    if box is not None:
        clipped = surrogate.at_unit(np.clip(u, *box), [name])[name].reshape((m,) + shape)
        beyond = beyond_the_runs(draws, clipped)
    cols = replace_far_tails(st, draws)
    if not cols.any():
        return beyond
    diag[f"far_tails.{name}"] = int(cols.sum())
    log.warning("%s: %s: the PCE's exact moments at %d of %d points come from inputs rarer than "
                "1 in %d, beyond every run (its polynomial swings there); its statistics there "
                "are those of %d surrogate draws, with their sampling error", label, name,
                int(cols.sum()), cols.size, m, m)
    return beyond


def _printed(cv: Corrected) -> dict[str, np.ndarray]:
    """The intervals the report prints: ``shown_ci`` (else ``ci``) with the std's lower end at
    least 0 and the kurtosis' at least 1, as for Monte Carlo (a skew-corrected interval widened
    beyond the runs' range printed a kurtosis down to -1058, which no distribution has)."""
    ci = dict(cv.ci if cv.shown_ci is None else cv.shown_ci)
    for k, floor in (("std", 0.0), ("kurtosis", 1.0)):
        if k in ci:
            v = np.array(ci[k], dtype=float)
            with np.errstate(invalid="ignore"):
                v[0] = np.where(np.isnan(v[0]), np.nan, np.maximum(v[0], floor))
            ci[k] = v
    return ci


def _widen(cv: Corrected, beyond: Mapping[str, np.ndarray]) -> None:
    """Widen the control-variate intervals, in place, by the part of each statistic the
    surrogate takes from beyond its runs, on either side (the check of the PCE's own value,
    ``correction_half``, keeps the correction's own width: the extrapolation moves both)."""
    for k, extra in beyond.items():
        sides = np.array([-1.0, 1.0]).reshape((2,) + (1,) * extra.ndim) * extra
        cv.ci[k] = cv.ci[k] + sides
        if cv.shown_ci is not None and k in cv.shown_ci:
            cv.shown_ci[k] = cv.shown_ci[k] + sides


def _runs_estimate(name: str, fit: ModelOutput | None, validation: ModelOutput | None,
                   ok: np.ndarray | None, used: ValidationDesign | None) -> Corrected | None:
    """The Monte Carlo estimate of the output's fit and validation runs (None: no runs of
    it, e.g. a derived output, or fewer than three)."""
    yf = _values(fit, name) if fit is not None else None
    if yf is not None and fit is not None:
        yf = yf[~fit.failed]
    yv = _values(validation, name) if validation is not None else None
    if yv is not None and ok is not None and used is not None:
        yv = yv[ok]
    else:
        yv, used = None, None
    if yf is None and yv is None:
        return None
    return runs_estimate(yf, yv, used)


def _drop_refuted(diag: dict[str, Any], label: str, name: str, st: Any, cv: Corrected,
                  runs: Corrected | None) -> dict[str, np.ndarray] | None:
    """Remove the control-variate values the runs' own Monte Carlo estimate refutes
    (:func:`uqguide.pce.support.refuted`): they are not reported, and nothing says they
    hold. Returns where the runs disagreed with them (None without runs), which judges the
    PCE's own values next (:func:`uqguide.pce.support.unsupported`)."""
    if runs is None:
        return None
    disagreed = disagrees_with_runs(cv, runs, runs.values["std"])
    bad = either(disagreed, less_precise(cv, runs))
    names = [k for k, m in bad.items() if m.any()]
    if not names:
        return disagreed
    for k in names:
        v = np.array(cv.values[k], dtype=float)
        v[bad[k]] = np.nan
        ci = np.array(cv.ci[k], dtype=float)
        ci[:, bad[k]] = np.nan
        cv.values[k], cv.ci[k] = v, ci
        if cv.shown_ci is not None:
            shown = np.array(cv.shown_ci[k], dtype=float)
            shown[:, bad[k]] = np.nan
            cv.shown_ci[k] = shown
    st.corrected = cv.values
    st.corrected_ci = _printed(cv)
    n_bad = int(np.sum(np.any([bad[k] for k in names], axis=0)))
    diag[f"cv_refuted.{name}"] = ", ".join(names)
    log.warning("%s: %s: the corrected (+cv) %s disagree with, or are less precise than, the "
                "Monte Carlo estimate of the method's own runs at %d point(s) (the surrogate's "
                "tails beyond its validation runs carry them); they are not reported there",
                label, name, ", ".join(names), n_bad)
    return disagreed


def _withhold_unsupported(diag: dict[str, Any], label: str, name: str, st: Any,
                          cv: Corrected | None, runs: Corrected | None, usable: np.ndarray,
                          time: np.ndarray | None, loo: float | None = None,
                          refuted_own: dict[str, np.ndarray] | None = None,
                          twin_refuted: dict[str, np.ndarray] | None = None) -> None:
    """Withhold the PCE's moments where its runs do not support them
    (:func:`uqguide.pce.support.unsupported`), and give the runs' Monte Carlo estimate
    (``fallback``) wherever one of its moments is withheld, here or by its validation runs
    (``refuted_own``, :func:`_withhold_refuted`)."""
    own = {k: np.asarray(st.stat(k), dtype=float) for k in STAT_NAMES}
    bad = unsupported(own, cv, runs, loo, st.sampling_se or None, twin_refuted)
    bad = {k: m & usable for k, m in bad.items()}  # elsewhere all four go anyway
    none = np.zeros_like(usable)
    tails = with_the_kurtosis(bad["kurtosis"] | (refuted_own or {}).get("kurtosis", none),
                              own["skewness"]) & usable & ~bad["skewness"]
    bad["skewness"] = bad["skewness"] | tails
    for k, m in bad.items():
        if m.any():
            v = np.array(getattr(st, k), dtype=float)
            v[m] = np.nan
            setattr(st, k, v)
    withheld = {k: ~usable | bad.get(k, none) | (refuted_own or {}).get(k, none)
                for k in STAT_NAMES}
    if runs is not None and any(m.any() for m in withheld.values()):
        # kept only where something is withheld: a PCE that gives every moment has no +mc
        for k, m in withheld.items():
            st.fallback[k] = np.where(m, runs.values[k], np.nan)
            shown = runs.ci if runs.shown_ci is None else runs.shown_ci
            st.fallback_ci[k] = np.where(m, shown[k], np.nan)
    names = [k for k, m in bad.items() if m.any()]
    if not names:
        return
    if tails.any():
        diag[f"skewness_with_kurtosis.{name}"] = int(tails.sum())
        log.warning("%s: %s: the PCE's skewness is withheld with its kurtosis at %d point(s): "
                    "both rest on the surrogate's tails, which its runs refute", label, name,
                    int(tails.sum()))
        bad["skewness"] = bad["skewness"] & ~tails
        names = [k for k, m in bad.items() if m.any()]
        if not names:
            return
    any_bad = np.any([bad[k] for k in names], axis=0)
    what = " and ".join(names)
    instead = ("the Monte Carlo estimate of its own runs (+mc) is given" if runs is not None
               else "no estimate of its own runs is at hand")
    if any_bad.ndim == 2 and time is not None and time.size == any_bad.shape[0]:
        steps = np.flatnonzero(any_bad.any(axis=1))
        diag[f"withheld_steps.{name}"] = int(steps.size)
        diag[f"withheld_from.{name}"] = float(time[steps[0]])
        log.warning("%s: %s: the PCE's %s disagree with its own runs at %d of %d steps (from "
                    "t = %g s) and are withheld there; %s", label, name, what, steps.size,
                    any_bad.shape[0], time[steps[0]], instead)
    else:
        diag[f"withheld.{name}"] = what
        log.warning("%s: %s: the PCE's %s disagree with its own runs and are withheld; %s",
                    label, name, what, instead)


def _withhold_refuted(diag: dict[str, Any], label: str, name: str, st: Any, cv: Corrected,
                      time: np.ndarray | None, usable: np.ndarray) -> dict[str, np.ndarray]:
    """Withhold the PCE's own statistics where its validation runs refute them
    (:func:`uqguide.pce.validation.disagreeing`; a series' steps only within a sustained run
    of them, :func:`uqguide.pce.validation.sustained`), among the columns where it is usable
    (the others already say "no usable surrogate"); record (diagnostics
    ``disagrees.<output>`` / ``disagrees_from.<output>``) and log it.

    Why withhold and not only warn: a value its own evidence refutes is not a result (issue
    27: "a PCE statistic is printed only when its own validation runs support it"). A kinked
    ramp's PCE std was printed 24% off beside the warning. The ``+cv`` row gives the corrected
    value there, and the ``+mc`` row the runs' own estimate.

    Returns
    -------
    dict of str to ndarray of bool
        Per statistic, where it was withheld.
    """
    own = {k: np.asarray(st.stat(k), dtype=float) for k in STAT_NAMES}
    series = own["mean"].ndim == 2 and time is not None and time.size == own["mean"].shape[0]
    masks = {k: m & usable for k, m in disagreeing(own, cv, series).items()}
    if series:
        masks = {k: sustained(m) for k, m in masks.items()}
    names = [k for k, m in masks.items() if m.any()]
    if not names:
        return {}
    for k in names:
        v = np.array(getattr(st, k), dtype=float)
        v[masks[k]] = np.nan
        setattr(st, k, v)
    if series and time is not None:
        steps = np.flatnonzero(np.any([masks[k].any(axis=1) for k in names], axis=0))
        t0 = float(time[steps[0]])
        diag[f"disagrees_from.{name}"] = t0
        log.warning("%s: %s: the PCE's %s disagree with its validation runs at %d steps from "
                    "t = %g s (outside the correction's 95%% interval) and are withheld there; "
                    "%s", label, name, " and ".join(names), steps.size, t0,
                    _instead(diag, name))
    else:
        diag[f"disagrees.{name}"] = ", ".join(names)
        log.warning("%s: %s: the PCE's %s disagree with its validation runs (more than two "
                    "95%% half-widths from the corrected value) and are withheld; %s", label,
                    name, ", ".join(names), _instead(diag, name))
    return masks


def _choose_points(diag: dict[str, Any], name: str, st: Any, cv: Corrected,
                   usable: np.ndarray) -> None:
    """Print in the ``+cv`` row, point by point, the PCE's own value or the corrected one,
    whichever has the smaller estimated mean squared error
    (:func:`uqguide.pce.point_choice.better_points`); the interval stays the correction's.
    Diagnostics ``cv_point.<output>`` say how often the PCE's value was taken."""
    if cv.se is None:
        return
    chosen, taken, total = {}, 0, 0
    for k in STAT_NAMES:
        own = np.where(usable, np.asarray(st.stat(k), dtype=float), np.nan)
        value, mask = better_points(own, st.corrected[k], cv.se[k])
        chosen[k] = value
        taken += int(mask.sum())
        total += int(np.isfinite(value).sum())
    # a new dict: the corrected values themselves (cv.values) stay what the checks judged
    st.corrected = chosen
    diag[f"cv_point.{name}"] = f"PCE value at {taken} of {total}"


def _instead(diag: dict[str, Any], name: str) -> str:
    """What stands where the PCE's statistics disagree: the corrected values, unless the
    runs refuted some of them (:func:`_drop_refuted`)."""
    refuted_cv = diag.get(f"cv_refuted.{name}")
    if refuted_cv:
        return (f"the corrected values (+cv) stand where the method's own runs do not refute "
                f"them (they refute its {refuted_cv} in places: the runs' Monte Carlo "
                f"estimate, +mc, is given there)")
    return "the corrected values (+cv) are consistent with the runs there"



def split_validation(design_data: Mapping[str, Any], outputs: ModelOutput
                     ) -> tuple[ModelOutput, ModelOutput | None]:
    """The fit's runs and the validation runs (after ``n_fit`` rows), when the design has them."""
    if "n_fit" not in design_data:
        return outputs, None
    n_fit = int(design_data["n_fit"])
    return (outputs.subset(np.arange(n_fit)),
            outputs.subset(np.arange(n_fit, outputs.n)))
