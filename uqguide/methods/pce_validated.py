"""The step every PCE method shares after its fit: keep the surrogate, validate it on
independent runs and decide, statistic by statistic, what may be shown (the pipeline of
:mod:`uqguide.pce.credibility`: own, corrected ``+cv``, fallback ``+mc`` or withheld).

Settings of every PCE method: ``validation: {n_samples: 100}`` (``design: random`` for plain
random runs; ``n_samples: 0``: none) and ``usable_error``
(``docs/methods.md#validation-corrected-moments-no-usable-surrogate-the-kept-surrogate``).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from typing import Any, Literal

import numpy as np
from pydantic import ConfigDict, Field, field_validator

from ..core.failures import FAILED_SHARE
from ..core.inputs import InputSpace
from ..core.strict import StrictModel
from ..core.types import STAT_NAMES, DerivedOutput, Estimate, ModelOutput
from ..pce import credibility as cred
from ..pce.far_tails import far_draws
from ..pce.loo import FitRuns
from ..pce.runs_estimate import INTERVAL, runs_estimate
from ..pce.success_region import (BOOTSTRAP_DRAWS, RegionCheck, check_region,
                                  conditional_moments, failed_share, fit_region,
                                  region_spread)
from ..pce.expansion import Expansion
from ..pce.germ import Germ
from ..pce.outputs import OutputColumns
from ..pce.surrogate import Surrogate
from ..pce.validation import (
    USABLE_ERROR, Corrected, corrected_moments, sampling_se, validation_unit_rows, withhold_all,
)
from ..pce.validation_design import (ValidationDesign, curved_inputs, random_validation,
                                     stratified_validation)
from .base import Design

log = logging.getLogger(__name__)


class ValidationSettings(StrictModel):
    """``validation:`` of a PCE method."""

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


def validation_design(settings: ValidationSettings | None, n: int,
                      surrogate: Surrogate | None, outputs: tuple[str, ...], *, seed: int,
                      label: str, d: int) -> ValidationDesign:
    """The ``n`` validation runs of a fitted surrogate: stratified by the value of the
    ``outputs`` it reports (all it predicts when none is named), random when ``settings`` asks
    for it or is None (``validation_runs``), or without a surrogate."""
    if settings is None or settings.design == "random" or surrogate is None:
        return random_validation(seed, label, n, d)
    names = [o for o in outputs if o in surrogate.names] or surrogate.names
    fitted = [surrogate.expansions[o].trimmed().alpha for o in names
              if o in surrogate.expansions] or [e.trimmed().alpha
                                                for e in surrogate.expansions.values()]
    return stratified_validation(lambda u: surrogate.at_unit(u, names), seed, label, n, d,
                                 curved=curved_inputs(fitted, d))


def with_validation(design: Design, settings: ValidationSettings | None, n: int,
                    surrogate: Surrogate | None, outputs: tuple[str, ...], space: InputSpace,
                    label: str) -> Design:
    """``design`` (the fit's runs) with ``n`` validation runs of ``surrogate`` appended."""
    vd = validation_design(settings, n, surrogate, outputs, seed=int(design.data["seed"]),
                           label=label, d=space.dim)
    log.info("%s: %d validation runs (%s)", label, vd.n,
             "stratified" if vd.stratified else "random")
    return Design(x=np.vstack([design.x, space.from_unit(vd.u)]),
                  data=dict(design.data, n_fit=design.n_runs, **vd.to_data()))


def surrogate_of(germ: Germ, fitted: list[tuple[OutputColumns, Expansion]],
                 derived: Mapping[str, DerivedOutput]) -> Surrogate:
    """The surrogate of the fitted outputs' expansions and the ``derived`` outputs."""
    return Surrogate(germ, {c.name: e for c, e in fitted}, dict(derived),
                     {c.name: c.kind for c, _ in fitted})


#: Fields the PCE methods' settings share, one definition for all.
SURROGATE_DRAWS_FIELD = Field(default=1_000_000, ge=1_000, le=100_000_000,
                              description="surrogate samples for skewness and kurtosis where the "
                                          "exact rule is too large, and for derived outputs, "
                                          "quantiles and events")
SURROGATE_SAMPLING_FIELD: Any = Field(
    default="random", description="those samples: pseudo-random, or scrambled Sobol' "
                                  "(surrogate_draws rounded up to a power of two)")
VALIDATION_FIELD = Field(default=None, description="independent runs that validate the "
                                                    "surrogate and correct its moments")
USABLE_FIELD = Field(default=USABLE_ERROR, gt=0.0, le=10.0,
                     description="relative LOO / validation error above which the PCE reports "
                                 "no moments ('no usable surrogate')")


#: Fresh surrogate draws that measure the sampling error of sampled PCE moments.
SE_DRAWS = 20_000


def output_values(out: ModelOutput, name: str) -> np.ndarray | None:
    """``name``'s values in ``out`` (series or scalar), None where it has none."""
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
           fit_loo_values: Mapping[str, np.ndarray] | None = None,
           failed_fit: np.ndarray | None = None) -> None:
    """Keep the surrogate in ``estimate``; validate, correct and judge every output in place
    (the steps of :mod:`uqguide.pce.credibility`).

    ``validation`` and ``design`` are the validation runs' outputs and their unit-cube
    inputs, weights and strata (None: no validation set); ``loo`` the fit's relative LOO error
    per fitted output (empty for quadrature PCEs); ``threshold`` is ``usable_error``; ``seed``
    keys the draws that measure the sampling error of the ``n_draws`` behind sampled moments.
    ``fit`` (the fit's runs when they sample the input distribution, not quadrature nodes) joins
    the validation runs in the Monte Carlo estimate that judges the PCE's moments and stands in
    where one is withheld; ``fit_u (n_fit, d)`` in the range beyond which the surrogate
    extrapolates (:func:`uqguide.pce.credibility.far_tails`); ``fit_loo_values`` (per fitted
    output, at the fit's successful runs, :mod:`uqguide.pce.loo`) floor the ``+cv`` variance;
    ``failed_fit``: the fit runs' failure mask where ``fit`` is not given (quadrature nodes).
    Where any fit or validation run failed, every output is judged by
    :func:`uqguide.pce.credibility.runs_failed` alone.
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
    label = estimate.label
    fit_failed = fit.failed if fit is not None else failed_fit
    n_failed, n_runs = 0, 0
    for mask in (fit_failed, None if validation is None else validation.failed):
        if mask is not None:
            n_failed, n_runs = n_failed + int(np.sum(mask)), n_runs + int(np.size(mask))
    if n_failed:  # the joint moments of the scalars are the polynomial's too
        estimate.scalar_mean, estimate.scalar_cov = None, None
    region: RegionCheck | None = None
    spreads: dict[str, dict[str, np.ndarray]] = {}
    if n_failed and fit is not None and validation is not None and design is not None:
        # the validation runs lean to the tails: their raw count of failures is no share
        every = np.concatenate([fit.failed, validation.failed]).astype(bool)
        for key, v in zip(FAILED_SHARE, _failed_share(every, design)):
            diag[key] = v
    if n_failed:
        region = _success_region(surrogate, fit, fit_u, validation, design)
        if region is not None:
            diag["success_region"] = region.line()
            if region.passed and ok is not None and design is not None:
                spreads = _conditional_on_success(estimate, surrogate, space, fit, fit_u,
                                                  validation, design, seed, label, n_draws)
                used = design.conditional(ok)
    for name, st in estimate.stats.items():
        def keep(verdict: cred.Verdict | None, name: str = name) -> None:
            cred.record(diag, label, name, verdict)

        if n_failed and name not in spreads:
            st.usable, _ = cred.usable(name, st, None, _fit_loo(name, loo, surrogate),
                                       threshold)
            _withhold_for_failed_runs(name, st, n_failed, n_runs, fit, validation, ok,
                                      design, keep, region)
            if st.fallback:
                diag["fallback_interval"] = INTERVAL
            continue

        beyond = spreads.get(name)
        exp = surrogate.expansions.get(name)
        if n_failed:
            keep(cred.success_region(name, n_failed, n_runs, region))
        elif cred.swings(st, exp):
            draws, clipped = _far_draws(name, st, surrogate, space, seed, label, box)
            beyond, verdict = cred.far_tails(name, st, draws, clipped)
            keep(verdict)
        cv = None
        y = output_values(validation, name) if validation is not None else None
        if y is not None and ok is not None and used is not None and int(ok.sum()) >= 2:
            cv = _correct(name, st, y[ok], surrogate, space, used, seed, label, n_draws,
                          _fit_runs(name, surrogate, used, fit, fit_u, fit_loo_values))
            if beyond is not None:
                cred.widen(cv, beyond)
            st.corrected, st.corrected_ci = cv.values, cred.printed(cv)
            st.validation_error = cv.error
            keep(cred.corrected(name, cv))
        runs = _runs_estimate(name, fit, validation, ok, used)
        cv_disagreed, cv_withheld = None, ""
        if cv is not None:
            cv_disagreed, verdict = cred.check_correction(name, cv, runs)
            if verdict is not None:
                st.corrected, st.corrected_ci = cv.values, cred.printed(cv)
                cv_withheld = verdict.record[f"withheld_cv.{name}"]
            keep(verdict)
        fit_loo = _fit_loo(name, loo, surrogate)
        err = None if cv is None else cv.error
        usable, constant = cred.usable(name, st, err, fit_loo, threshold)
        st.usable = usable
        if cv is not None:
            verdict = cred.refused_correction(name, st, cv, threshold)
            if verdict is not None:
                st.corrected, st.corrected_ci = cv.values, cred.printed(cv)
            keep(verdict)
        disagreed: dict[str, np.ndarray] = {}
        if cv is not None:
            disagreed, verdict = cred.check_own(name, st, cv, time, usable, cv_withheld)
            cred.blank(st, disagreed)
            keep(verdict)
        bad, verdicts = cred.check_own_by_runs(name, st, cv, runs, usable, time, fit_loo,
                                               disagreed, cv_disagreed)
        cred.blank(st, bad)
        unbounded, bounded = cred.bound_own(name, st, cv, runs, usable)
        cred.blank(st, unbounded)
        none = np.zeros_like(usable)
        withheld = {k: ~usable | bad.get(k, none) | disagreed.get(k, none)
                    | unbounded.get(k, none) for k in STAT_NAMES}
        values, cis, given = cred.fallback(runs, withheld)
        st.fallback.update(values)
        st.fallback_ci.update(cis)
        keep(given)
        keep(cred.not_resolved(name, runs, values))
        for verdict in verdicts:
            keep(verdict)
        prior = diag.get(f"withheld.{name}")
        keep(bounded)
        if bounded is not None and prior:  # one entry per output, both reasons
            diag[f"withheld.{name}"] = f"{prior}; {diag[f'withheld.{name}']}"
        if cv is not None:
            chosen, verdict = cred.choose_points(name, st, cv, usable)
            if chosen is not None:
                # a new dict: the corrected values themselves (cv.values) stay as judged
                st.corrected = chosen
            keep(verdict)
        if st.fallback:
            diag["fallback_interval"] = INTERVAL
        verdict = cred.no_usable_surrogate(name, st, usable, constant, err, fit_loo,
                                           threshold, time)
        if verdict is not None:
            withhold_all(st, usable)
            keep(verdict)


def _withhold_for_failed_runs(name: str, st: Any, n_failed: int, n_runs: int,
                              fit: ModelOutput | None, validation: ModelOutput | None,
                              ok: np.ndarray | None, design: ValidationDesign | None,
                              keep: Callable[[cred.Verdict | None], None],
                              region: RegionCheck | None) -> None:
    """The step :func:`uqguide.pce.credibility.runs_failed`: the own and ``+cv`` values
    withheld, the Monte Carlo estimate of the successful fit and validation runs, weighted
    to be conditional on success (:meth:`ValidationDesign.conditional`), given instead
    (``st.usable`` stays what the fit's error says: the values are withheld for another
    reason); ``region``: the success region's check, where one was fitted and failed it."""
    cond = design.conditional(ok) if design is not None and ok is not None and ok.any() \
        else None
    runs = _runs_estimate(name, fit, validation, ok, cond)
    verdict = cred.runs_failed(name, st, n_failed, n_runs, runs, region)
    assert verdict is not None
    withhold_all(st, np.zeros(np.shape(st.mean), dtype=bool))
    st.corrected, st.corrected_ci = {}, {}
    values, cis, given = cred.fallback(runs, verdict.where)
    unresolved = cred.not_resolved(name, runs, values)
    st.fallback.update(values)
    st.fallback_ci.update(cis)
    keep(verdict)
    keep(given)
    keep(unresolved)


def _region_runs(surrogate: Surrogate, fit: ModelOutput | None, fit_u: np.ndarray | None,
                 validation: ModelOutput | None, design: ValidationDesign | None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The germ points and failure mask of the fit and validation runs, and the validation
    runs' rows among them; None where either set's points are missing (quadrature nodes, no
    validation runs)."""
    if (fit is None or fit_u is None or validation is None or design is None
            or fit_u.shape[0] != fit.n or design.n != validation.n):
        return None
    u = np.vstack([np.asarray(fit_u, dtype=float), np.asarray(design.u, dtype=float)])
    failed = np.concatenate([fit.failed, validation.failed]).astype(bool)
    return surrogate.germ.from_unit(u), failed, np.arange(fit.n, fit.n + validation.n)


def _failed_share(failed: np.ndarray, design: ValidationDesign) -> tuple[float, float, float]:
    """The chance that a run fails and its 95% interval from the fit runs (the rows before
    the validation runs, a sample of the input distribution) and the validation runs at their
    weights, each set counted by its size (:func:`uqguide.pce.success_region.failed_share`)."""
    n_all = failed.size
    return failed_share(failed, np.concatenate([np.full(n_all - design.n, 1.0 / n_all),
                                                design.weight * design.n / n_all]))


def _success_region(surrogate: Surrogate, fit: ModelOutput | None, fit_u: np.ndarray | None,
                    validation: ModelOutput | None, design: ValidationDesign | None
                    ) -> RegionCheck | None:
    """The success region's leave-one-out check on the validation runs (None: no region can
    be learnt, :func:`_region_runs`)."""
    runs = _region_runs(surrogate, fit, fit_u, validation, design)
    if runs is None:
        return None
    xi, failed, held = runs
    return check_region(xi, failed, held)


def _conditional_on_success(estimate: Estimate, surrogate: Surrogate, space: InputSpace,
                            fit: ModelOutput | None, fit_u: np.ndarray | None,
                            validation: ModelOutput | None, design: ValidationDesign,
                            seed: int, label: str, n_draws: int
                            ) -> dict[str, dict[str, np.ndarray]]:
    """Replace, in place, every output's own moments by those of surrogate draws inside the
    success region fitted on all the runs (:mod:`uqguide.pce.success_region`), with their
    sampling error (its other statistics withheld); returns per output how far each
    statistic moves with the region (:func:`uqguide.pce.success_region.region_spread`), which
    widens its ``+cv`` intervals."""
    runs = _region_runs(surrogate, fit, fit_u, validation, design)
    assert runs is not None
    xi, failed, _ = runs
    region = fit_region(xi, failed)
    share = _failed_share(failed, design)
    spreads: dict[str, dict[str, np.ndarray]] = {}
    if region is None:
        return spreads
    for name, st in estimate.stats.items():
        shape = np.shape(st.mean)
        cols = int(np.prod(shape))
        # 2e5 values: their sampling error (in the intervals) is a tenth of the +cv
        # correction's from 50 validation runs, at a fifth of 1e6 draws' cost
        m = min(n_draws, max(BOOTSTRAP_DRAWS, 200_000 // max(cols, 1)))
        u = validation_unit_rows(seed, f"{label}/success", m, space.dim)
        xi_draws = surrogate.germ.from_unit(u)
        inside = region.succeeds(xi_draws)
        if not inside.any():
            continue
        values = surrogate.at_unit(u, [name])[name].reshape((m,) + shape)
        moments = conditional_moments(values, inside)
        # the covariance, Sobol' indices and quantiles stay the polynomial's over the whole
        # input space: withheld with everything, then the moments given back
        withhold_all(st, np.zeros(shape, dtype=bool))
        for k, v in moments.items():
            setattr(st, k, np.asarray(v, dtype=float).reshape(shape))
        st.moments_method = "surrogate-sampling"
        st.n_used = int(inside.sum())
        st.sampling_se = sampling_se(values[inside][:SE_DRAWS], int(inside.sum()), seed=seed)
        b = BOOTSTRAP_DRAWS
        spreads[name] = region_spread(xi, failed, xi_draws[:b], values[:b], share[1:], seed)
    return spreads


def _fit_loo(name: str, loo: Mapping[str, float], surrogate: Surrogate) -> float | None:
    """The fit's LOO error of ``name``; a derived output has none of its own: its carriers'
    worst judges it."""
    fit_loo = loo.get(name)
    if fit_loo is None and name in surrogate.derived:
        carriers = [loo[c] for c in surrogate.derived[name].carriers if c in loo]
        fit_loo = max(carriers) if carriers else None
    return fit_loo


def _far_draws(name: str, st: Any, surrogate: Surrogate, space: InputSpace, seed: int,
               label: str, box: tuple[np.ndarray, np.ndarray] | None
               ) -> tuple[np.ndarray, np.ndarray | None]:
    """Random surrogate draws of ``name`` (:func:`uqguide.pce.far_tails.far_draws` of them)
    and the same clipped to the runs' range ``box`` (None without it)."""
    shape = np.shape(st.mean)
    m = far_draws(int(np.prod(shape)))
    u = validation_unit_rows(seed, f"{label}/far", m, space.dim)
    draws = surrogate.at_unit(u, [name])[name].reshape((m,) + shape)
    clipped = None
    if box is not None:
        clipped = surrogate.at_unit(np.clip(u, *box), [name])[name].reshape((m,) + shape)
    return draws, clipped


def _correct(name: str, st: Any, y: np.ndarray, surrogate: Surrogate, space: InputSpace,
             used: ValidationDesign, seed: int, label: str, n_draws: int,
             fit_runs: FitRuns | None) -> Corrected:
    """The control-variate moments of ``name`` from its successful validation runs ``y``
    (:func:`uqguide.pce.validation.corrected_moments`), with the sampling error of sampled
    PCE moments."""
    s = surrogate.at_unit(used.u, [name])[name].reshape(y.shape)
    pce_se = None
    if st.sampling_se:
        pce_se = st.sampling_se
    elif st.moments_method == "surrogate-sampling":
        cols = int(np.prod(y.shape[1:]))
        m = min(SE_DRAWS, n_draws, max(1000, 2_000_000 // max(cols, 1)))
        u = validation_unit_rows(seed, f"{label}/se", m, space.dim)
        draws = surrogate.at_unit(u, [name])[name].reshape((m,) + y.shape[1:])
        pce_se = sampling_se(draws, n_draws, seed=seed)
    return corrected_moments(st, y, s, weight=used.weight, stratum=used.stratum,
                             share=used.share, pool=used.pool, pce_se=pce_se,
                             fit_runs=fit_runs)


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
    y = output_values(fit, name)
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


def _runs_estimate(name: str, fit: ModelOutput | None, validation: ModelOutput | None,
                   ok: np.ndarray | None, used: ValidationDesign | None) -> Corrected | None:
    """The Monte Carlo estimate of the output's fit and validation runs (None: no runs of
    it, e.g. a derived output, or fewer than three)."""
    yf = output_values(fit, name) if fit is not None else None
    if yf is not None and fit is not None:
        yf = yf[~fit.failed]
    yv = output_values(validation, name) if validation is not None else None
    if yv is not None and ok is not None and used is not None:
        yv = yv[ok]
    else:
        yv, used = None, None
    if yf is None and yv is None:
        return None
    return runs_estimate(yf, yv, used)


def split_validation(design_data: Mapping[str, Any], outputs: ModelOutput
                     ) -> tuple[ModelOutput, ModelOutput | None]:
    """The fit's runs and the validation runs (after ``n_fit`` rows), when the design has them."""
    if "n_fit" not in design_data:
        return outputs, None
    n_fit = int(design_data["n_fit"])
    return (outputs.subset(np.arange(n_fit)),
            outputs.subset(np.arange(n_fit, outputs.n)))
