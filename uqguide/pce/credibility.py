"""Whether a PCE statistic may be shown: one pipeline of named steps per output.

Each step (:data:`STEPS`, in order, run by :func:`uqguide.methods.pce_validated.finish`) returns
its :class:`Verdict`: the value it judged, the :class:`State` it leaves where, why, and the
diagnostics that keep it in the result file (:func:`record`). The rules each step applies:
docs/pce.md#what-a-pce-may-print.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from enum import Enum
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..core.types import STAT_NAMES, OutputStats
from .far_tails import beyond_the_runs, can_swing, replace_far_tails
from .point_choice import better_points
from .runs_estimate import LOWEST, unresolved
from .success_region import RegionCheck
from .support import (disagrees_with_runs, either, less_precise, near_the_runs, unsupported,
                      with_the_kurtosis)
from .validation import Corrected, disagreeing, nan_at, sustained, usable_mask

log = logging.getLogger("uqguide.methods.pce_validated")

#: The steps of :func:`uqguide.methods.pce_validated.finish`, in the order they run.
STEPS = ("runs_failed", "success_region", "far_tails", "correct", "check_correction", "usable",
         "refused_correction", "check_own", "check_own_by_runs", "bound_own", "fallback",
         "not_resolved", "choose_points", "no_usable_surrogate")


class State(str, Enum):
    """What the report shows for a statistic at a point (the four states, named here once)."""

    OWN = "own"              # the PCE's own value
    CORRECTED = "corrected"  # the control-variate value (+cv)
    FALLBACK = "fallback"    # the Monte Carlo estimate of the method's own runs (+mc)
    WITHHELD = "withheld"    # nothing: the value judged is not shown


@dataclass(frozen=True)
class Verdict:
    """One step's decision about one output.

    ``step``: its name (:data:`STEPS`); ``of``: the value judged (``"own"``, ``"+cv"``, ``"+mc"``);
    ``state``: what stands where the step decided; ``where``: per statistic, the points decided
    (empty: the output as a whole); ``reason``: one line, logged as a warning when ``warn``;
    ``record``: the diagnostics entries that keep the verdict in the result file.
    """

    step: str
    of: str
    state: State
    where: Mapping[str, np.ndarray] = field(default_factory=dict)
    reason: str = ""
    record: Mapping[str, Any] = field(default_factory=dict)
    warn: bool = True


def record(diag: dict[str, Any], label: str, name: str, verdict: Verdict | None) -> None:
    """Keep ``verdict`` in the diagnostics ``diag`` and log its reason."""
    if verdict is None:
        return
    diag.update(verdict.record)
    if verdict.warn and verdict.reason:
        log.warning("%s: %s: %s", label, name, verdict.reason)


def blank(st: OutputStats, where: Mapping[str, np.ndarray]) -> None:
    """NaN, in place, the PCE's own statistics at ``where`` (per statistic)."""
    for k, m in where.items():
        if m.any():
            setattr(st, k, nan_at(getattr(st, k), m))


def runs_failed(name: str, st: OutputStats, n_failed: int, n_runs: int,
                runs: Corrected | None, region: RegionCheck | None = None) -> Verdict | None:
    """Where some of the method's runs failed and no success region passed its check
    (:func:`success_region`), withhold the PCE's own and ``+cv`` values of every statistic:
    its polynomial, fitted on the runs that succeeded, is integrated over the failure region
    too, so they are not the statistics conditional on success that every method reports;
    ``runs`` (their Monte Carlo estimate, None: none) stands instead. ``region``: the success
    region's check (None: none could be learnt)."""
    if not n_failed:
        return None
    where = {k: np.ones(np.shape(st.stat(k)), dtype=bool) for k in STAT_NAMES}
    instead = ("the Monte Carlo estimate of its successful runs (+mc) is given" if runs is not None
               else "no estimate of its own runs is at hand")
    why = ("no classifier of the success region could be checked on validation runs"
           if region is None else
           f"the classifier of the success region {region.line()}, no better than "
           f"predicting success everywhere" if not region.passed else
           "the success region holds none of the surrogate's draws")
    return Verdict(
        "runs_failed", "own", State.WITHHELD, where,
        f"{n_failed} of its {n_runs} runs failed and {why}: its polynomial, fitted on the "
        f"others, would be integrated over the failure region too, so its own and corrected "
        f"(+cv) statistics are withheld; {instead}",
        {f"runs_failed.{name}": f"{n_failed} of {n_runs} runs failed"})


def success_region(name: str, n_failed: int, n_runs: int, region: RegionCheck | None
                   ) -> Verdict | None:
    """Where some runs failed and a classifier of the success region passed its check on the
    validation runs: the PCE's statistics are those of its surrogate's draws inside that
    region, conditional on success as every method's are, with the region's bootstrap spread
    in their ``+cv`` intervals (:mod:`uqguide.pce.success_region`)."""
    if not n_failed or region is None:
        return None
    return Verdict(
        "success_region", "own", State.OWN, {},
        f"{n_failed} of its {n_runs} runs failed: its statistics are those of its surrogate "
        f"inside a classifier of the success region ({region.line()}), conditional on "
        f"success; their +cv intervals include the region's bootstrap spread",
        {f"success_region.{name}": region.line()}, warn=False)


def far_tails(name: str, st: OutputStats, draws: np.ndarray, clipped: np.ndarray | None
              ) -> tuple[dict[str, np.ndarray] | None, Verdict | None]:
    """Where the exact moments come from inputs too rare for any run, take the surrogate
    draws' instead (in place). Returns the part of each statistic the surrogate takes from
    beyond its runs (None without ``clipped``, the draws clipped to the runs' range)."""
    beyond = beyond_the_runs(draws, clipped) if clipped is not None else None
    cols = replace_far_tails(st, draws)
    if not cols.any():
        return beyond, None
    m = draws.shape[0]
    return beyond, Verdict(
        "far_tails", "own", State.OWN, {k: cols for k in STAT_NAMES},
        f"the PCE's exact moments at {int(cols.sum())} of {cols.size} points come from inputs "
        f"rarer than 1 in {m}, beyond every run (its polynomial swings there); its statistics "
        f"there are those of {m} surrogate draws, with their sampling error",
        {f"far_tails.{name}": int(cols.sum())})


def swings(st: OutputStats, expansion: Any) -> bool:
    """Whether :func:`far_tails` applies: a fitted output with exact (not sampled) moments
    whose polynomial can swing beyond its runs."""
    return expansion is not None and not st.sampling_se and can_swing(expansion)


def widen(cv: Corrected, beyond: Mapping[str, np.ndarray]) -> None:
    """Widen the control-variate intervals, in place, by the part of each statistic the
    surrogate takes from beyond its runs, on either side (``correction_half`` is kept: the
    extrapolation moves the PCE's value and the corrected one alike)."""
    for k, extra in beyond.items():
        sides = np.array([-1.0, 1.0]).reshape((2,) + (1,) * extra.ndim) * extra
        cv.ci[k] = cv.ci[k] + sides
        if cv.shown_ci is not None and k in cv.shown_ci:
            cv.shown_ci[k] = cv.shown_ci[k] + sides


def printed(cv: Corrected) -> dict[str, np.ndarray]:
    """The intervals the report prints: ``shown_ci`` (else ``ci``) with the std's lower end at
    least 0 and the kurtosis' at least 1, as for Monte Carlo."""
    ci = dict(cv.ci if cv.shown_ci is None else cv.shown_ci)
    for k, floor in LOWEST.items():
        if k in ci:
            v = np.array(ci[k], dtype=float)
            v[0] = np.maximum(v[0], floor)  # NaN stays NaN
            ci[k] = v
    return ci


def corrected(name: str, cv: Corrected) -> Verdict:
    """The ``+cv`` values the validation runs give (their error is the output's
    ``validation_error``)."""
    err = cv.error
    return Verdict("correct", "+cv", State.CORRECTED,
                   {k: np.isfinite(v) for k, v in cv.values.items()},
                   record={f"validation_error.{name}":
                           float(np.max(err)) if err.size else 0.0}, warn=False)


def check_correction(name: str, cv: Corrected, runs: Corrected | None
                     ) -> tuple[dict[str, np.ndarray] | None, Verdict | None]:
    """Withhold, in ``cv`` (in place), the ``+cv`` values the runs' own Monte Carlo estimate
    disagrees with or is more precise than. Returns where the runs disagreed with them (None
    without runs) and the verdict."""
    if runs is None:
        return None, None
    disagreed = disagrees_with_runs(cv, runs, runs.values["std"])
    bad = either(disagreed, less_precise(cv, runs))
    names = [k for k, m in bad.items() if m.any()]
    if not names:
        return disagreed, None
    for k in names:
        cv.values[k], cv.ci[k] = nan_at(cv.values[k], bad[k]), nan_at(cv.ci[k], bad[k], lead=1)
        if cv.shown_ci is not None:
            cv.shown_ci[k] = nan_at(cv.shown_ci[k], bad[k], lead=1)
    n_bad = int(np.sum(np.any([bad[k] for k in names], axis=0)))
    what = ", ".join(names)
    return disagreed, Verdict(
        "check_correction", "+cv", State.WITHHELD, {k: bad[k] for k in names},
        f"the corrected (+cv) {what} disagree with, or are less precise than, the Monte Carlo "
        f"estimate of the method's own runs at {n_bad} point(s) (the surrogate's tails beyond "
        f"its validation runs carry them); they are not reported there",
        {f"withheld_cv.{name}": what})


def usable(name: str, st: OutputStats, err: np.ndarray | None, fit_loo: float | None,
           threshold: float) -> tuple[np.ndarray, bool]:
    """Where the surrogate is usable (:func:`uqguide.pce.validation.usable_mask`), and whether
    the output is a constant: a scalar every fit run gave the same value (say, a collision flag
    that never fired) is no result, since a PCE cannot tell a constant from a rare event."""
    ok = usable_mask(err, fit_loo, threshold, np.shape(st.mean))
    constant = np.ndim(st.mean) == 1 and bool(np.any(np.asarray(st.std) == 0.0))
    if constant:
        ok = ok & (np.asarray(st.std) != 0.0)
    return ok, constant


def refused_correction(name: str, st: OutputStats, cv: Corrected, threshold: float
                       ) -> Verdict | None:
    """Withhold, in ``cv`` (in place), the ``+cv`` values where the validation error is above
    ``threshold`` and the surrogate varies: the residuals of a polynomial its validation
    refuses are heavy-tailed (it swings beyond the runs), so the spread of a few dozen of them
    understates the correction's error, and a ``+cv`` value chosen over the runs' for its
    narrower interval is chosen for that understatement. The runs' estimate (``+mc``) answers
    there. A constant surrogate's ``+cv`` values (the validation runs' own moments) stay.
    Measured: docs/pce.md#where-the-surrogate-is-refused."""
    with np.errstate(invalid="ignore"):
        bad = (np.asarray(cv.error) > threshold) & (np.asarray(st.std, dtype=float) > 0)
    where = {k: bad & np.isfinite(cv.values[k]) for k in STAT_NAMES}
    names = [k for k, m in where.items() if m.any()]
    if not names:
        return None
    for k in names:
        cv.values[k] = nan_at(cv.values[k], where[k])
        cv.ci[k] = nan_at(cv.ci[k], where[k], lead=1)
        if cv.shown_ci is not None:
            cv.shown_ci[k] = nan_at(cv.shown_ci[k], where[k], lead=1)
    n_bad = int(np.sum(np.any([where[k] for k in names], axis=0)))
    return Verdict(
        "refused_correction", "+cv", State.WITHHELD, {k: where[k] for k in names},
        f"the corrected (+cv) {', '.join(names)} are not reported at {n_bad} point(s) where "
        f"the validation error is above {threshold:g}: the residuals of a surrogate its "
        f"validation refuses do not measure the correction's error",
        {f"refused_correction.{name}": n_bad}, warn=False)


def check_own(name: str, st: OutputStats, cv: Corrected, time: np.ndarray | None,
              ok: np.ndarray, cv_withheld: str = "") -> tuple[dict[str, np.ndarray],
                                                               Verdict | None]:
    """Where the PCE's own statistics disagree with its validation runs (a series' steps only
    within a sustained run), among the usable points ``ok``: withheld. ``cv_withheld`` names
    the ``+cv`` statistics :func:`check_correction` withheld."""
    own = {k: np.asarray(st.stat(k), dtype=float) for k in STAT_NAMES}
    series = own["mean"].ndim == 2 and time is not None and time.size == own["mean"].shape[0]
    masks = {k: m & ok for k, m in disagreeing(own, cv, series).items()}
    if series:
        masks = {k: sustained(m) for k, m in masks.items()}
    names = [k for k, m in masks.items() if m.any()]
    if not names:
        return {}, None
    instead = ("the corrected values (+cv) are consistent with the runs there"
               if not cv_withheld else
               f"the corrected values (+cv) stand where the method's own runs do not refute "
               f"them (they refute its {cv_withheld} in places: the runs' Monte Carlo "
               f"estimate, +mc, is given there)")
    if series and time is not None:
        steps = np.flatnonzero(np.any([masks[k].any(axis=1) for k in names], axis=0))
        t0 = float(time[steps[0]])
        return masks, Verdict(
            "check_own", "own", State.WITHHELD, masks,
            f"the PCE's {' and '.join(names)} disagree with its validation runs at "
            f"{steps.size} steps from t = {t0:g} s (outside the correction's 95% interval) "
            f"and are withheld there; {instead}", {f"disagrees_from.{name}": t0})
    return masks, Verdict(
        "check_own", "own", State.WITHHELD, masks,
        f"the PCE's {', '.join(names)} disagree with its validation runs (more than two 95% "
        f"half-widths from the corrected value) and are withheld; {instead}",
        {f"disagrees.{name}": ", ".join(names)})


def check_own_by_runs(name: str, st: OutputStats, cv: Corrected | None,
                      runs: Corrected | None, ok: np.ndarray, time: np.ndarray | None,
                      loo: float | None = None,
                      disagreed: Mapping[str, np.ndarray] | None = None,
                      cv_disagreed: Mapping[str, np.ndarray] | None = None
                      ) -> tuple[dict[str, np.ndarray], list[Verdict]]:
    """Where the PCE's own moments are not supported by its runs (a skewness goes with its
    withheld kurtosis), among the usable points ``ok``. ``disagreed``: where :func:`check_own`
    withheld them; ``cv_disagreed``: where the runs disagreed with the ``+cv`` twin. Returns
    the masks to withhold and the verdicts."""
    own = {k: np.asarray(st.stat(k), dtype=float) for k in STAT_NAMES}
    bad = unsupported(own, cv, runs, loo, st.sampling_se or None,
                      None if cv_disagreed is None else dict(cv_disagreed))
    bad = {k: m & ok for k, m in bad.items()}  # elsewhere all four go anyway
    none = np.zeros_like(ok)
    tails = with_the_kurtosis(bad["kurtosis"] | (disagreed or {}).get("kurtosis", none),
                              own["skewness"]) & ok & ~bad["skewness"]
    bad["skewness"] = bad["skewness"] | tails
    verdicts = []
    if tails.any():
        verdicts.append(Verdict(
            "check_own_by_runs", "own", State.WITHHELD, {"skewness": tails},
            f"the PCE's skewness is withheld with its kurtosis at {int(tails.sum())} "
            f"point(s): both rest on the surrogate's tails, which its runs refute",
            {f"skewness_with_kurtosis.{name}": int(tails.sum())}))
    rest = {k: m & ~tails if k == "skewness" else m for k, m in bad.items()}
    names = [k for k, m in rest.items() if m.any()]
    if not names:
        return bad, verdicts
    any_bad = np.any([rest[k] for k in names], axis=0)
    what = " and ".join(names)
    instead = ("the Monte Carlo estimate of its own runs (+mc) is given" if runs is not None
               else "no estimate of its own runs is at hand")
    if any_bad.ndim == 2 and time is not None and time.size == any_bad.shape[0]:
        steps = np.flatnonzero(any_bad.any(axis=1))
        verdicts.append(Verdict(
            "check_own_by_runs", "own", State.WITHHELD, {k: rest[k] for k in names},
            f"the PCE's {what} disagree with its own runs at {steps.size} of "
            f"{any_bad.shape[0]} steps (from t = {time[steps[0]]:g} s) and are withheld "
            f"there; {instead}",
            {f"withheld_steps.{name}": int(steps.size),
             f"withheld_from.{name}": float(time[steps[0]])}))
    else:
        verdicts.append(Verdict(
            "check_own_by_runs", "own", State.WITHHELD, {k: rest[k] for k in names},
            f"the PCE's {what} disagree with its own runs and are withheld; {instead}",
            {f"withheld.{name}": what}))
    return bad, verdicts


def bound_own(name: str, st: OutputStats, cv: Corrected | None, runs: Corrected | None,
              ok: np.ndarray) -> tuple[dict[str, np.ndarray], Verdict | None]:
    """Give each of the PCE's own values shown its 95% interval (``st.ci``, in place): the
    smallest holding the value and the printed ``+cv`` interval, whose validation runs measure
    the surrogate's error; where there is no ``+cv`` value, the smallest holding the value and
    the runs' printed interval, if the value lies near the runs' estimate
    (:func:`uqguide.pce.support.near_the_runs`), their interval says something
    (:func:`uqguide.pce.runs_estimate.unresolved`) and it is not narrower than the
    correction's. Elsewhere, among the usable points ``ok``, nothing bounds the value: the
    masks returned, to withhold (with validation runs only: without, the runs' check decides
    alone and a value it keeps may stay without interval)."""
    if cv is None and runs is None:
        return {}, None
    shown = printed(cv) if cv is not None else None
    std = np.asarray(st.std, dtype=float)
    out: dict[str, np.ndarray] = {}
    for k in STAT_NAMES:
        own = np.asarray(st.stat(k), dtype=float)
        lo = hi = np.full(own.shape, np.nan)
        by_cv = np.zeros(own.shape, dtype=bool)
        if cv is not None and shown is not None:
            lo_cv, hi_cv = shown[k]
            by_cv = np.isfinite(cv.values[k]) & np.isfinite(lo_cv) & np.isfinite(hi_cv)
            lo, hi = np.fmin(own, lo_cv), np.fmax(own, hi_cv)
        by_runs = np.zeros(own.shape, dtype=bool)
        if runs is not None:
            r_lo, r_hi = runs.ci[k] if runs.shown_ci is None else runs.shown_ci[k]
            by_runs = ~by_cv & ~unresolved(runs, k) & near_the_runs(own, runs, k, std)
            if cv is not None:
                # the own value's error is at least the correction's half-width: where that
                # is wider than the runs' own interval, their estimate (+mc) is the better one
                with np.errstate(invalid="ignore"):
                    by_runs &= ~(cv.correction_half[k] > 0.5 * (runs.ci[k][1] - runs.ci[k][0]))
            lo = np.where(by_runs, np.fmin(own, r_lo), lo)
            hi = np.where(by_runs, np.fmax(own, r_hi), hi)
        bounded = by_cv | by_runs
        st.ci[k] = np.stack([np.where(bounded, lo, np.nan), np.where(bounded, hi, np.nan)])
        # without validation runs the runs' check alone decides (check_own_by_runs)
        out[k] = np.isfinite(own) & ~bounded & ok & (cv is not None)
    names = [k for k, m in out.items() if m.any()]
    if not names:
        return out, None
    n_bad = int(np.sum(np.any([out[k] for k in names], axis=0)))
    what = " and ".join(names)
    instead = ("the Monte Carlo estimate of its own runs (+mc) is given" if runs is not None
               else "no estimate of its own runs is at hand")
    return out, Verdict(
        "bound_own", "own", State.WITHHELD, {k: out[k] for k in names},
        f"the PCE's {what} are withheld at {n_bad} point(s): nothing bounds their error there "
        f"(no corrected +cv value, and the method's own runs disagree with them, say nothing "
        f"or are more precise than the correction); {instead}",
        {f"withheld.{name}": f"{what} (unbounded)"})


def not_resolved(name: str, runs: Corrected | None, values: Mapping[str, np.ndarray]
                 ) -> Verdict | None:
    """Where a ``+mc`` value given (``values``) has an interval that says nothing (a kurtosis
    ``>= 1``, :func:`uqguide.pce.runs_estimate.unresolved`): not resolved by the runs, not an
    estimate; the diagnostics say so (``not_resolved.<output>``)."""
    if runs is None or not values:
        return None
    where = {k: unresolved(runs, k) & np.isfinite(v) for k, v in values.items()}
    names = [k for k, m in where.items() if m.any()]
    if not names:
        return None
    what = " and ".join(names)
    return Verdict(
        "not_resolved", "+mc", State.FALLBACK, {k: where[k] for k in names},
        f"its {what} not resolved by {runs.n} runs (their 95% interval has one end infinite "
        f"and says no more than any distribution's bound)",
        {f"not_resolved.{name}": f"{what} by {runs.n} runs"}, warn=False)


def fallback(runs: Corrected | None, withheld: Mapping[str, np.ndarray]
             ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], Verdict | None]:
    """The runs' Monte Carlo estimate (``+mc``) and its printed interval wherever an own
    statistic is withheld (empty where none is)."""
    if runs is None or not any(m.any() for m in withheld.values()):
        return {}, {}, None
    shown = runs.ci if runs.shown_ci is None else runs.shown_ci
    values = {k: np.where(m, runs.values[k], np.nan) for k, m in withheld.items()}
    ci = {k: np.where(m, shown[k], np.nan) for k, m in withheld.items()}
    return values, ci, Verdict("fallback", "+mc", State.FALLBACK, dict(withheld), warn=False)


def choose_points(name: str, st: OutputStats, cv: Corrected, ok: np.ndarray
                  ) -> tuple[dict[str, np.ndarray] | None, Verdict | None]:
    """The ``+cv`` row's point values (:func:`uqguide.pce.point_choice.better_points`); None
    without the correction's standard errors."""
    if cv.se is None:
        return None, None
    chosen, took, taken, total = {}, {}, 0, 0
    for k in STAT_NAMES:
        own = np.where(ok, np.asarray(st.stat(k), dtype=float), np.nan)
        value, mask = better_points(own, st.corrected[k], cv.se[k])
        chosen[k], took[k] = value, mask
        taken += int(mask.sum())
        total += int(np.isfinite(value).sum())
    return chosen, Verdict("choose_points", "+cv", State.OWN, took,
                           record={f"cv_point.{name}": f"PCE value at {taken} of {total}"},
                           warn=False)


def no_usable_surrogate(name: str, st: OutputStats, ok: np.ndarray, constant: bool,
             err: np.ndarray | None, fit_loo: float | None, threshold: float,
             time: np.ndarray | None) -> Verdict | None:
    """The verdict where the surrogate is not usable; None where it is usable everywhere."""
    if ok.all():
        return None
    where = {k: ~ok for k in STAT_NAMES}
    why = (f"validation error {float(np.max(err)):.3g}" if err is not None
           else f"LOO error {fit_loo:.3g}" if fit_loo is not None
           else "error not estimated")  # (a single run: one-node quadrature)
    if constant:
        return Verdict(
            "no_usable_surrogate", "own", State.WITHHELD, where,
            f"no usable surrogate (constant on all {st.n_used} fit runs); its moments are not "
            f"reported",
            {f"no_usable_surrogate.{name}": f"constant on all {st.n_used} fit runs: a PCE "
                                            f"cannot tell a constant from a rare event"})
    if ok.ndim == 2 and time is not None and time.size == ok.shape[0]:
        bad_t = np.flatnonzero(~ok.all(axis=1))
        return Verdict(
            "no_usable_surrogate", "own", State.WITHHELD, where,
            f"no usable surrogate from t = {time[bad_t[0]]:g} s ({bad_t.size} of "
            f"{ok.shape[0]} steps; {why} > {threshold:g})",
            {f"no_usable_surrogate_from.{name}": float(time[bad_t[0]]),
             f"no_usable_surrogate_steps.{name}": int(bad_t.size)})
    return Verdict("no_usable_surrogate", "own", State.WITHHELD, where,
                   f"no usable surrogate ({why} > {threshold:g}); its moments are not reported",
                   {f"no_usable_surrogate.{name}": f"{why} > {threshold:g}"})
