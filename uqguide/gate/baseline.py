"""Baselines of the regression gate: what a result's statistics were, as a JSON file.

A baseline is written from a result on purpose (``uqguide baseline RESULT -o B.json``). Per
method label, output, point (:func:`uqguide.results.statistics.points`) and component it holds
the moments (with their standard errors for sample estimates), the quantiles and Sobol' indices
with their 95% intervals (``[value, low, high]``) and each method's event probabilities, plus
the PCE tolerance, the resolved config, the library versions and the creation date; ``null``
stands for NaN. It reads the result through :mod:`uqguide.results.statistics`, as the report
and the result file do, and refuses on reading what a hand edit could loosen (:class:`Baseline`'s
checks). One line per point, numbers in the shortest repr that reads back to the same double:
the file's format and rules are ``docs/regression-gate.md``.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import hmac
import json
import math
import os
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from ..core import atomic
from ..core.events import EventEstimate, clopper_pearson
from .._version import __version__
from ..errors import ResultError
from ..results import statistics
from ..results.result import Result
from .tolerances import DEFAULT_PCE_RTOL, check_tolerance, tolerance_problem
from ..results.statistics import (
    FROM_RUNS, SAMPLE, OutputStatistics, Point, result_statistics,
)
from ..core.types import STAT_NAMES

BASELINE_FORMAT = "uqguide-baseline"
#: 4: Sobol' indices too (``check --sensitivity``); 3: quantiles and event probabilities too;
#: 2: a ``digest`` of the rest of the file, so an edit by hand is refused (1: none). Versions 2
#: and 3 are still read (what they hold is checked; a note says what they lack).
BASELINE_VERSION = 4
READ_VERSIONS = (2, 3, 4)

#: The kinds of index a baseline point holds, ``<kind>:<input or group>``.
INDEX_KINDS = ("first", "total", "group_first", "group_total")


# ---------------------------------------------------------------------------- file schema
class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class BaselinePoint(_Strict):
    """One time point (or the scalar value) of one component; ``None`` stands for NaN."""

    at: Literal["report", "end", "scalar"]
    time: float | None
    component: str
    mean: float | None
    std: float | None
    skewness: float | None
    kurtosis: float | None
    mean_se: float | None = None
    std_se: float | None = None
    skewness_se: float | None = None
    kurtosis_se: float | None = None
    #: Statistics that are chaotic under round-off, with the range [low, high] they took over
    #: the round-off ensemble the baseline was written with (``scripts/update_golden.py``);
    #: the gate reports them and does not check them.
    roundoff: dict[str, list[float | None]] = {}
    #: Quantiles by level name (``q0.99``): ``[value, low, high]``, the 95% interval's bounds
    #: (null where the method gives none).
    quantiles: dict[str, list[float | None]] = {}
    #: Sobol' indices by ``<kind>:<name>`` (:data:`INDEX_KINDS`): ``[value, low, high]``, the
    #: 95% interval's bounds (null where the method gives none).
    indices: dict[str, list[float | None]] = {}

    @field_validator("indices")
    @classmethod
    def _indices(cls, v: dict[str, list[float | None]]) -> dict[str, list[float | None]]:
        for name, q in v.items():
            kind, _, of = name.partition(":")
            if kind not in INDEX_KINDS or not of:
                raise ValueError(f"index {name!r}: a name is a kind ({', '.join(INDEX_KINDS)}), "
                                 f"':' and an input or group, e.g. first:x1")
            if len(q) != 3 or q[0] is None or any(
                    x is not None and (isinstance(x, bool) or not math.isfinite(x)) for x in q):
                raise ValueError(f"index {name}: must be [value, low, high], finite numbers "
                                 f"(low and high may be null) (got {q!r})")
            if q[1] is not None and q[2] is not None and q[1] > q[2]:
                raise ValueError(f"index {name}: the interval's low end {q[1]} is above its "
                                 f"high end {q[2]}")
        return v

    @field_validator("quantiles")
    @classmethod
    def _quantiles(cls, v: dict[str, list[float | None]]) -> dict[str, list[float | None]]:
        for name, q in v.items():
            level = quantile_level(name)
            if level is None:
                raise ValueError(f"quantile {name!r}: a name is 'q' and a level in (0, 1), "
                                 f"e.g. q0.99")
            if len(q) != 3 or q[0] is None or any(
                    x is not None and (isinstance(x, bool) or not math.isfinite(x)) for x in q):
                raise ValueError(f"quantile {name}: must be [value, low, high], finite numbers "
                                 f"(low and high may be null) (got {q!r})")
            value, lo, hi = float(q[0]), q[1], q[2]
            if (lo is not None and lo > value) or (hi is not None and hi < value):
                raise ValueError(f"quantile {name}: the interval [{lo}, {hi}] does not hold "
                                 f"the value {value}")
        return v

    @field_validator("time", "mean", "std", "skewness", "kurtosis", "mean_se", "std_se",
                     "skewness_se", "kurtosis_se", mode="before")
    @classmethod
    def _number(cls, v: Any) -> Any:
        if isinstance(v, bool):
            raise ValueError(f"must be a number or null, not a boolean (got {v!r})")
        return v

    @field_validator("time", "mean", "std", "skewness", "kurtosis")
    @classmethod
    def _finite(cls, v: float | None) -> float | None:
        if v is not None and not math.isfinite(v):
            raise ValueError(f"must be a finite number or null (got {v!r})")
        return v

    @field_validator("std", "mean_se", "std_se", "skewness_se", "kurtosis_se")
    @classmethod
    def _error(cls, v: float | None) -> float | None:
        if v is not None and not (math.isfinite(v) and v >= 0):
            raise ValueError(f"must be a finite number >= 0 or null (got {v!r})")
        return v


class BaselineOutput(_Strict):
    kind: Literal["series", "scalar"]
    unit: str
    components: list[str]
    uncertainty: Literal["standard_error", "relative_tolerance"]
    moments_method: str
    n_used: int = Field(ge=0)
    #: How the Sobol' indices were estimated (``pce``, ``given-data``, ``saltelli``; "" none).
    sobol_estimator: str = ""
    points: list[BaselinePoint] = Field(min_length=1)

    @model_validator(mode="after")
    def _consistent(self) -> BaselineOutput:
        """A baseline that cannot be compared is refused here, not at check time."""
        if not self.components or len(set(self.components)) != len(self.components):
            raise ValueError(f"components must be a non-empty list of distinct names "
                             f"(got {self.components})")
        sample = self.uncertainty == SAMPLE
        if sample != (self.moments_method in FROM_RUNS):
            raise ValueError(f"uncertainty {self.uncertainty!r} does not fit moments_method "
                             f"{self.moments_method!r}")
        if sample and self.n_used < 1:
            raise ValueError(f"n_used must be >= 1 for sample statistics (got {self.n_used})")
        for i, p in enumerate(self.points):
            where = f"points[{i}]"
            if p.component not in self.components:
                raise ValueError(f"{where}.component {p.component!r} is not one of "
                                 f"{self.components}")
            if self.kind == "scalar" and (p.at != "scalar" or p.time is not None):
                raise ValueError(f"{where}: a scalar output's point has at 'scalar' and time "
                                 f"null (got at {p.at!r}, time {p.time!r})")
            if self.kind == "series" and (p.at == "scalar" or p.time is None or p.time < 0):
                raise ValueError(f"{where}: a series output's point has at 'report' or 'end' "
                                 f"and a time >= 0 (got at {p.at!r}, time {p.time!r})")
            if p.mean is None and p.std is None:
                raise ValueError(f"{where}: mean and std are both null: nothing to check")
            if self.moments_method == "mfmc" and p.std is not None:
                _check_multifidelity_se(p, self.n_used, where)
            elif sample and p.std is not None:
                _check_mean_se(p, self.n_used, where)
                for stat in ("std", "skewness", "kurtosis"):
                    if getattr(p, stat) is not None and getattr(p, f"{stat}_se") is None:
                        raise ValueError(f"{where}.{stat}_se: missing for a sample statistic")
                _check_std_se(p, self.n_used, where)
            if sample:
                _check_quantile_intervals(p, self.n_used, where)
        return self


#: How far a stored ``mean_se`` may lie from ``std / sqrt(n_used)`` recomputed here, in units
#: in the last place: room for a path that multiplies by ``1 / sqrt(n)`` (three roundings, not
#: two), none for an error bar a hand loosened (docs/regression-gate.md).
MEAN_SE_ULPS = 2.0


def _check_mean_se(p: BaselinePoint, n_used: int, where: str) -> None:
    """A sample point's ``mean_se``: the one its own std and run count give, to the round-off
    (a baseline whose error bars were loosened by hand no longer fits its own numbers)."""
    assert p.std is not None
    sem = p.std / math.sqrt(n_used)
    if p.mean_se is None or abs(p.mean_se - sem) > MEAN_SE_ULPS * math.ulp(sem):
        raise ValueError(f"{where}.mean_se must be std / sqrt(n_used) = {sem!r} to the "
                         f"round-off ({MEAN_SE_ULPS:g} ulps) (got {p.mean_se!r}); regenerate "
                         f"the baseline rather than edit it")


#: How much larger than plain MC's ``std / sqrt(n_used)`` over its highest level's runs a
#: multi-fidelity standard error of the mean may be. With the optimal weights estimated from
#: the runs the estimator's variance formula is at most plain MC's over those runs (PWG16
#: Lemma 3.3: ``g <= 1``); the margin covers the std being the MFMC estimate, not the highest
#: level's own sample std.
MFMC_SE_FACTOR = 1.5


def _check_multifidelity_se(p: BaselinePoint, n_used: int, where: str) -> None:
    """A multi-fidelity point's standard errors: present, and the mean's no larger than
    plain MC's over its highest-level runs (``n_used``) would be (a bar loosened by hand)."""
    assert p.std is not None
    if p.mean_se is None or not p.mean_se > 0:
        raise ValueError(f"{where}.mean_se must be a standard error > 0 for a multi-fidelity "
                         f"statistic (got {p.mean_se!r})")
    bound = MFMC_SE_FACTOR * p.std / math.sqrt(n_used)
    if p.mean_se > bound:
        raise ValueError(f"{where}.mean_se {p.mean_se:.6g} exceeds {MFMC_SE_FACTOR:g} std / "
                         f"sqrt(n_used) = {bound:.6g}, more than plain MC of the highest "
                         f"level's runs; regenerate the baseline rather than edit it")
    for stat in ("std", "skewness", "kurtosis"):
        if getattr(p, stat) is not None and getattr(p, f"{stat}_se") is None:
            raise ValueError(f"{where}.{stat}_se: missing for a sample statistic")


def quantile_level(name: str) -> float | None:
    """The probability of a quantile named ``q<level>`` (None if it is not such a name)."""
    if not name.startswith("q"):
        return None
    try:
        level = float(name[1:])
    except ValueError:
        return None
    return level if 0.0 < level < 1.0 else None


def _check_quantile_intervals(p: BaselinePoint, n_used: int, where: str) -> None:
    """A sample quantile's interval bounds are order statistics of the runs, so (Cantelli's
    inequality, which holds for the runs' own distribution) the one at level ``l`` lies within
    ``mean -+ std sqrt((1 - l) / l)`` resp. ``sqrt(l / (1 - l))``. An interval widened by hand
    to switch the quantile's check off goes beyond that and is refused. The levels are taken
    3 binomial standard deviations and one run beyond the 95% interval's: a margin that no
    interval a run computes reaches."""
    if p.mean is None or p.std is None:
        return
    for name, (_, lo, hi) in p.quantiles.items():
        level = quantile_level(name)
        assert level is not None  # (validated with the point)
        half = 3.0 * math.sqrt(level * (1.0 - level) / n_used) + 1.0 / n_used
        l_lo, l_hi = level - half, level + half
        if lo is not None and l_lo > 0:
            bound = p.mean - p.std * math.sqrt((1.0 - l_lo) / l_lo)
            if lo < bound - 1e-9 * (abs(bound) + p.std):
                raise ValueError(f"{where}.quantiles.{name}: the interval's low end {lo:.6g} "
                                 f"is below what {n_used} runs of mean {p.mean:.6g} and std "
                                 f"{p.std:.6g} allow ({bound:.6g}); regenerate the baseline "
                                 f"rather than edit it")
        if hi is not None and l_hi < 1:
            bound = p.mean + p.std * math.sqrt(l_hi / (1.0 - l_hi))
            if hi > bound + 1e-9 * (abs(bound) + p.std):
                raise ValueError(f"{where}.quantiles.{name}: the interval's high end {hi:.6g} "
                                 f"is above what {n_used} runs of mean {p.mean:.6g} and std "
                                 f"{p.std:.6g} allow ({bound:.6g}); regenerate the baseline "
                                 f"rather than edit it")


#: How far a sample std's standard error may lie from the delta method's
#: ``std sqrt((kurtosis - 1) / (4 n))`` on the baseline's own numbers, either way: room for small
#: samples and heavy tails, none for error bars loosened by hand (docs/regression-gate.md).
STD_SE_FACTOR = 3.0


def delta_std_se(std: float, kurtosis: float, n_used: int) -> float:
    """The delta method's standard error of a sample std, ``std sqrt((kurtosis - 1) / (4 n))``
    (kurtosis non-excess; the std's influence function is ``sigma (z^2 - 1) / 2``)."""
    return std * math.sqrt(max(kurtosis - 1.0, 0.0) / (4.0 * max(n_used, 1)))


def _check_std_se(p: BaselinePoint, n_used: int, where: str) -> None:
    if p.std is None or p.std <= 0 or p.kurtosis is None or p.std_se is None:
        return
    expected = delta_std_se(p.std, p.kurtosis, n_used)
    if expected > 0 and not expected / STD_SE_FACTOR <= p.std_se <= expected * STD_SE_FACTOR:
        raise ValueError(
            f"{where}.std_se {p.std_se:.6g} does not fit the point's own std, kurtosis and "
            f"n_used (std sqrt((kurtosis - 1) / (4 n_used)) = {expected:.6g}, allowed within a "
            f"factor {STD_SE_FACTOR:g}); regenerate the baseline rather than edit it")


#: Event estimators whose probability is a random estimate (checked against combined standard
#: errors); the others are functions of a fixed design and seed (PCE draws: relative tolerance).
SAMPLE_EVENTS = ("count", "subset")


class BaselineEvent(_Strict):
    """One event's probability by one method, its 95% interval and counts."""

    probability: float = Field(ge=0.0, le=1.0)
    ci: list[float] = Field(min_length=2, max_length=2)
    n_in: int = Field(ge=0)
    n_used: int = Field(ge=1)
    estimator: str

    @model_validator(mode="after")
    def _consistent(self) -> BaselineEvent:
        lo, hi = self.ci
        if not (0.0 <= lo <= self.probability <= hi <= 1.0):
            raise ValueError(f"the interval [{lo}, {hi}] must lie in [0, 1] and hold the "
                             f"probability {self.probability}")
        if self.n_in > self.n_used:
            raise ValueError(f"n_in ({self.n_in}) exceeds n_used ({self.n_used})")
        if self.estimator == "count":
            # a count of runs: the probability and its exact interval follow from the counts,
            # so an interval widened by hand no longer fits them
            p = self.n_in / self.n_used
            want = clopper_pearson(self.n_in, self.n_used)
            if abs(self.probability - p) > 1e-12 or \
                    any(abs(a - b) > 1e-9 for a, b in zip(self.ci, want)):
                raise ValueError(f"a count's probability and interval must be n_in / n_used "
                                 f"= {p:.6g} and its Clopper-Pearson interval [{want[0]:.6g}, "
                                 f"{want[1]:.6g}] (got {self.probability:.6g}, [{lo:.6g}, "
                                 f"{hi:.6g}]); regenerate the baseline rather than edit it")
        return self


class BaselineMethod(_Strict):
    method: str
    n_runs: int = Field(ge=0)
    n_failed: int = Field(ge=0)
    #: The runs that are a sample of the inputs, and how many of them failed, where they are
    #: not all the runs (a pick-freeze design's ``A`` and ``B`` rows); None: all of them.
    sample_runs: int | None = Field(default=None, ge=0)
    sample_failed: int | None = Field(default=None, ge=0)
    outputs: dict[str, BaselineOutput] = Field(min_length=1)
    events: dict[str, BaselineEvent] = {}

    @model_validator(mode="after")
    def _counts(self) -> BaselineMethod:
        if self.n_failed > self.n_runs:
            raise ValueError(f"n_failed ({self.n_failed}) exceeds n_runs ({self.n_runs})")
        if (self.sample_runs is None) != (self.sample_failed is None):
            raise ValueError("sample_runs and sample_failed are given together or not at all")
        # Sample statistics use every run of the sample that did not fail (a non-finite value
        # fails its run), so n_used is the method's count of successful sample runs; a smaller
        # one widens every standard error, a larger one claims runs that were not made.
        runs, failed, what = self.n_runs, self.n_failed, "n_runs - n_failed"
        if self.sample_runs is not None and self.sample_failed is not None:
            if not (self.sample_runs <= self.n_runs and self.sample_failed <= self.n_failed
                    and self.sample_failed <= self.sample_runs):
                raise ValueError(f"sample_runs ({self.sample_runs}) and sample_failed "
                                 f"({self.sample_failed}) must be within n_runs and n_failed")
            runs, failed, what = self.sample_runs, self.sample_failed, \
                "sample_runs - sample_failed"
        ok = runs - failed
        for name, o in self.outputs.items():
            if o.moments_method == "mfmc":
                # the highest level's runs: some of all the levels' runs
                if o.n_used > ok:
                    raise ValueError(f"outputs.{name}.n_used ({o.n_used}) exceeds the "
                                     f"method's successful runs ({ok} = n_runs - n_failed)")
                continue
            if o.uncertainty == SAMPLE and o.n_used != ok:
                raise ValueError(f"outputs.{name}.n_used ({o.n_used}) is not the method's "
                                 f"successful runs ({ok} = {what})")
        return self


class BaselineTolerances(_Strict):
    pce_rtol: float
    note: str = ""

    @field_validator("pce_rtol")
    @classmethod
    def _rtol(cls, v: float) -> float:
        problem = tolerance_problem("--pce-rtol", v)
        if problem:
            raise ValueError(problem.split(": ", 1)[1])
        return v


class Baseline(_Strict):
    """A baseline file, validated. Build one with :func:`make_baseline`."""

    format: Literal["uqguide-baseline"]
    format_version: Literal[2, 3, 4]
    #: checked by read_baseline against the file's content (an in-memory baseline has none)
    digest: str = ""
    #: keyed seal (:func:`baseline_seal`), where the baseline was written with a key
    seal: str = ""
    name: str
    model: str
    created_utc: str
    uqguide_version: str
    result_created_utc: str = ""
    versions: dict[str, str]
    tolerances: BaselineTolerances
    methods: dict[str, BaselineMethod] = Field(min_length=1)
    config: dict[str, Any]

    @model_validator(mode="after")
    def _complete(self) -> Baseline:
        """A version 3 baseline of a config with quantiles (events) holds them: removing them
        (and sealing the file again) would switch their check off."""
        if self.format_version < 3:
            return self
        if self.config.get("quantiles") is not None and not any(
                p.quantiles for m in self.methods.values() for o in m.outputs.values()
                for p in o.points):
            raise ValueError("its config asks for quantiles and it holds none")
        if self.config.get("events") and not any(m.events for m in self.methods.values()):
            raise ValueError("its config has events and it holds no event probability")
        if self.format_version >= 4:
            for label, m in self.methods.items():
                for name, o in m.outputs.items():
                    if o.sobol_estimator and not any(p.indices for p in o.points):
                        raise ValueError(f"methods.{label}.outputs.{name}: its estimator "
                                         f"{o.sobol_estimator!r} gave Sobol' indices and it "
                                         f"holds none")
        return self


# ---------------------------------------------------------------------------- extraction
def _num(v: float) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


#: Key of one statistic of a baseline: (label, output, at, time, component, statistic).
StatKey = tuple[str, str, str, "float | None", str, str]


def _points(v: OutputStatistics, places: list[Point],
            roundoff: dict[StatKey, list[float | None]] | None = None,
            inputs: tuple[str, ...] = ()) -> list[dict[str, Any]]:
    """The baseline's points of one method's output: its moments (and their standard errors,
    for sample estimates) where the method's own moments are usable."""
    sample = v.uncertainty == SAMPLE
    pts = []
    for place in places:
        where = place.where
        if not v.usable_at(where):
            continue  # a PCE with no usable surrogate here reports no moments to pin
        p: dict[str, Any] = {"at": place.at, "time": place.time, "component": place.name}
        for m in v.moments:
            p[m.name] = _num(m.value[where])
        if sample:
            for m in v.moments:
                p[f"{m.name}_se"] = _num(v.standard_error(m.name, where))
        quantiles = {q.name: [_num(q.value[where]), *(_num(b) for b in q.interval(where))]
                     for q in v.quantiles if q.defined_at(where)}
        if quantiles:
            p["quantiles"] = quantiles
        indices = {name: [value, *bounds]
                   for name, value, bounds in index_values(v, where, inputs) if value is not None}
        if indices:
            p["indices"] = indices
        chaotic = {m.name: rng for m in v.moments
                   if (rng := (roundoff or {}).get((v.label, v.output.name, place.at,
                                                    place.time, place.name, m.name)))}
        if chaotic:
            p["roundoff"] = chaotic
        pts.append(p)
    return pts


def index_values(v: OutputStatistics, where: tuple[int, ...], inputs: tuple[str, ...]
                  ) -> list[tuple[str, float | None, tuple[float | None, float | None]]]:
    """The Sobol' indices of one output at one point (``(step, component)`` of a series,
    ``(component,)`` of a scalar): ``(name, value, (low, high))`` with names
    ``<kind>:<input or group>`` (:data:`INDEX_KINDS`), None for NaN, in a fixed order."""
    out = []
    for kind, value, band, names in (
            ("first", v.sobol_first, v.sobol_first_ci, inputs),
            ("total", v.sobol_total, v.sobol_total_ci, inputs),
            ("group_first", v.sobol_group_first, v.sobol_group_first_ci, v.sobol_groups),
            ("group_total", v.sobol_group_total, v.sobol_group_total_ci, v.sobol_groups)):
        if value is None:
            continue
        at = np.asarray(value)[where]
        lo_hi = np.asarray(band)[(slice(None),) + where] if band is not None else None
        for j, name in enumerate(names[:at.shape[-1]]):
            bounds = (None, None) if lo_hi is None else (_num(lo_hi[0, j]), _num(lo_hi[1, j]))
            out.append((f"{kind}:{name}", _num(at[j]), bounds))
    return out


def make_baseline(result: Result, pce_rtol: float = DEFAULT_PCE_RTOL,
                  roundoff: dict[StatKey, list[float | None]] | None = None) -> dict[str, Any]:
    """The baseline of ``result`` as a JSON-ready mapping (see the module docstring): format,
    config, tolerances, and per method and output the values and standard errors at the report
    points.

    ``pce_rtol``: relative tolerance stored for PCE statistics, in ``(0, 1]``; ``roundoff``:
    statistics chaotic under round-off with their range over a round-off ensemble
    (``scripts/update_golden.py`` measures it), recorded, not checked.
    """
    check_tolerance("--pce-rtol", pce_rtol)
    methods: dict[str, Any] = {}
    left_out: list[str] = []
    described = result_statistics(result)
    for r in result.runs:
        outs: dict[str, Any] = {}
        for v in described[r.label].values():
            o = v.output
            points = _points(v, statistics.points(o, result.time, result.report_times),
                             roundoff, tuple(result.input_names))
            if not points:
                left_out.append(f"{r.label}/{o.name} (no usable surrogate: no moments)")
                continue
            if roundoff and all(set(STAT_NAMES) <= set(p.get("roundoff", {})) for p in points):
                left_out.append(f"{r.label}/{o.name} (nothing checkable: chaotic under "
                                "round-off, or the moments of a zero spread)")
                continue
            outs[o.name] = {
                "kind": o.kind, "unit": o.unit, "components": list(o.components),
                "uncertainty": v.uncertainty, "moments_method": v.moments_method,
                "n_used": v.n_used,
                **({"sobol_estimator": v.sobol_estimator}
                   if any("indices" in p for p in points) else {}),
                "points": points,
            }
        if not outs:  # a method without moments (subset simulation): nothing to gate
            left_out.append(f"{r.label} (no statistic to check)")
            continue
        methods[r.label] = {"method": r.estimate.method, "n_runs": int(r.n_runs),
                            "n_failed": int(r.n_failed), "outputs": outs}
        diag = r.estimate.diagnostics
        if "sample_runs" in diag:
            methods[r.label] |= {"sample_runs": int(diag["sample_runs"]),
                                 "sample_failed": int(diag["sample_failed"])}
        events = {name: _event(e) for name, e in r.estimate.events.items() if _event(e)}
        if events:
            methods[r.label]["events"] = events
    return {
        "format": BASELINE_FORMAT,
        "format_version": BASELINE_VERSION,
        "name": result.name,
        "model": result.model,
        "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "uqguide_version": __version__,
        "result_created_utc": str(result.provenance.get("created_utc", "")),
        "versions": {k: str(v) for k, v in result.provenance.get("versions", {}).items()},
        "tolerances": {
            "pce_rtol": float(pce_rtol),
            "note": "Monte Carlo statistics are checked against k combined standard errors "
                    "(the *_se values; k given to `uqguide check --sigmas`, default 4); PCE "
                    "statistics against pce_rtol of their scale. null means NaN."
                    + (" Left out: " + "; ".join(left_out) + "." if left_out else ""),
        },
        "methods": methods,
        "config": result.config,
    }


def _event(e: EventEstimate) -> dict[str, Any] | None:
    """An event's baseline entry (None where the method estimated no probability)."""
    lo, hi = e.ci
    if not (math.isfinite(e.probability) and math.isfinite(lo) and math.isfinite(hi)) \
            or e.n_used < 1:
        return None
    return {"probability": float(e.probability), "ci": [float(lo), float(hi)],
            "n_in": int(e.n_in), "n_used": int(e.n_used), "estimator": e.estimator}


# ---------------------------------------------------------------------------- JSON files
def _is_scalar(v: Any) -> bool:
    return v is None or isinstance(v, (str, int, float, bool))


def _json_text(obj: Any, level: int = 0) -> str:
    """JSON with containers of scalars on one line (one line per point: readable diffs)."""
    pad, inner = "  " * level, "  " * (level + 1)
    if isinstance(obj, dict):
        if not obj:
            return "{}"
        if all(_is_scalar(v) for v in obj.values()):
            return json.dumps(obj, allow_nan=False)
        body = ",\n".join(f"{inner}{json.dumps(str(k))}: {_json_text(v, level + 1)}"
                          for k, v in obj.items())
        return "{\n" + body + "\n" + pad + "}"
    if isinstance(obj, (list, tuple)):
        if all(_is_scalar(v) for v in obj):
            return json.dumps(list(obj), allow_nan=False)
        return "[\n" + ",\n".join(inner + _json_text(v, level + 1) for v in obj) + "\n" + pad + "]"
    return json.dumps(obj, allow_nan=False)


def to_jsonable(obj: Any) -> Any:
    """``obj`` (nested dicts, lists, tuples, arrays, scalars) with arrays and NumPy scalars as
    lists and numbers, non-finite floats as None: accepted by
    ``json.dumps(..., allow_nan=False)``."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item())
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    return obj


def baseline_digest(data: dict[str, Any]) -> str:
    """``"sha256:<hex>"`` of a baseline's JSON-ready content, everything but the ``digest``.

    The statistics, their standard errors, the tolerances and the config a baseline was made
    with are what the gate trusts; the digest makes an accidental change to them visible, so a
    baseline changes only by being written again from a result. Anyone can compute it again
    after an edit: against a deliberate one only the keyed seal (:func:`baseline_seal`) holds.
    """
    body = {k: v for k, v in data.items() if k != "digest"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return "sha256:" + hashlib.sha256(text.encode("utf-8")).hexdigest()


#: The environment variable holding the key of the baselines' keyed seal.
KEY_ENV = "UQGUIDE_BASELINE_KEY"
SEAL_PREFIX = "hmac-sha256:"


def baseline_key() -> bytes | None:
    """The seal key from :data:`KEY_ENV` (UTF-8 bytes), None where it is unset or empty."""
    key = os.environ.get(KEY_ENV, "")
    return key.encode("utf-8") if key else None


def baseline_seal(data: dict[str, Any], key: bytes) -> str:
    """``"hmac-sha256:<hex>"`` under ``key`` of a baseline's content, everything but ``digest``
    and ``seal``: only who holds the key can write a baseline that carries a valid one."""
    body = {k: v for k, v in data.items() if k not in ("digest", "seal")}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return SEAL_PREFIX + hmac.new(key, text.encode("utf-8"), hashlib.sha256).hexdigest()


def sealed(data: dict[str, Any], key: bytes | None = None) -> dict[str, Any]:
    """``data`` (JSON-ready) with its digest, placed after ``format_version``, and with a
    ``key`` its keyed seal after the digest (which covers the seal)."""
    out: dict[str, Any] = {}
    for k, v in data.items():
        if k not in ("digest", "seal"):
            out[k] = v
        if k == "format_version":
            out["digest"] = ""
            if key is not None:
                out["seal"] = ""
    if key is not None:
        out["seal"] = baseline_seal(out, key)
    out["digest"] = baseline_digest(out)
    return out


def check_seal(data: dict[str, Any], source: str, require_key: bool = False) -> None:
    """ResultError unless ``data``'s keyed seal fits: a seal present and a key set must agree;
    with ``require_key`` (``uqguide check --require-key``) a key must be set and the baseline
    carry a seal made with it."""
    key = baseline_key()
    seal = data.get("seal") or ""
    if require_key and key is None:
        raise ResultError(f"{source}: --require-key: {KEY_ENV} is not set (or empty), so "
                          f"no seal can be verified; set it to the key the baseline was "
                          f"written with")
    if require_key and not seal:
        raise ResultError(f"{source}: --require-key: the baseline has no keyed seal; write it "
                          f"again with {KEY_ENV} set (`uqguide baseline RESULT -o FILE --force`)")
    if seal and key is not None and not hmac.compare_digest(
            str(seal), baseline_seal(data, key)):
        raise ResultError(f"{source}: the baseline's keyed seal does not match its content "
                          f"under the key in {KEY_ENV}: it was changed after it was written, or "
                          f"sealed with another key; write it again with the key set")


def seal_note(baseline: Baseline) -> str:
    """What the check can say of a baseline's seal that :func:`check_seal` let through."""
    key = baseline_key()
    if baseline.seal and key is None:
        return f"the baseline's keyed seal is not verified ({KEY_ENV} is not set)"
    if not baseline.seal and key is not None:
        return ("the baseline has no keyed seal (its digest detects accidental edits only); "
                "`uqguide check --require-key` refuses such a baseline")
    return ""


def write_baseline(result: Result, path: str | Path, pce_rtol: float = DEFAULT_PCE_RTOL,
                   roundoff: dict[StatKey, list[float | None]] | None = None) -> Path:
    """Write the baseline of ``result`` to ``path`` (temporary file, then an atomic rename);
    arguments as :func:`make_baseline`."""
    path = Path(path)
    text = _json_text(sealed(to_jsonable(make_baseline(result, pce_rtol, roundoff)),
                             baseline_key())) + "\n"
    return atomic.write_text(path, text)


def parse_baseline(data: Any, source: str = "<baseline>") -> Baseline:
    """Validate a decoded baseline mapping; ResultError naming the first problem."""
    if not isinstance(data, dict) or data.get("format") != BASELINE_FORMAT:
        raise ResultError(f"{source}: not a uqguide baseline (expected a JSON object with "
                          f"\"format\": \"{BASELINE_FORMAT}\"; write one with "
                          f"`uqguide baseline RESULT -o FILE`)")
    version = data.get("format_version")
    if version not in READ_VERSIONS or isinstance(version, bool):
        raise ResultError(f"{source}: baseline format_version {version!r} is not supported "
                          f"(this uqguide reads {' and '.join(map(str, READ_VERSIONS))}, whose "
                          f"digest refuses edits by hand); regenerate it with `uqguide baseline "
                          f"RESULT -o FILE --force`")
    try:
        return Baseline.model_validate(data)
    except ValidationError as err:
        e = err.errors(include_url=False)[0]
        where = ".".join(str(p) for p in e["loc"])
        msg = e["msg"].replace("Value error, ", "")
        got = "" if isinstance(e.get("input"), (dict, list)) else f" (got {e.get('input')!r:.60})"
        raise ResultError(f"{source}: invalid baseline at {where or 'top level'}: "
                          f"{msg}{got}") from None
    except RecursionError:
        raise ResultError(f"{source}: baseline nested too deeply") from None


#: A baseline holds a few numbers per report point: 50 MB is far beyond any real one.
MAX_BASELINE_BYTES = 50_000_000


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number (a baseline writes NaN as null)")


def read_baseline(path: str | Path, require_key: bool = False) -> Baseline:
    """Read and validate a baseline file; ResultError if it is missing, corrupt, not one, or
    edited since it was written (its digest, :func:`baseline_digest`, and its keyed seal,
    :func:`check_seal`); ``require_key``: refuse one without a seal made with the key in
    :data:`KEY_ENV`."""
    path = Path(path)
    try:
        st = path.stat()
        if not path.is_file():  # a FIFO's read would block
            raise ResultError(f"{path}: baseline is not a regular file")
        size = st.st_size
        if size > MAX_BASELINE_BYTES:
            raise ResultError(f"{path}: baseline is {size} bytes; a baseline is at most "
                              f"{MAX_BASELINE_BYTES} (is this a baseline?)")
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ResultError(f"{path}: baseline file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ResultError(f"{path}: cannot read baseline file ({exc})") from None
    try:
        data = json.loads(text, parse_constant=_reject_constant)
    except RecursionError:
        raise ResultError(f"{path}: baseline is nested too deeply to be one") from None
    except ValueError as exc:
        if not isinstance(exc, json.JSONDecodeError):
            raise ResultError(f"{path}: baseline is not valid JSON ({exc})") from None
        raise ResultError(f"{path}: baseline is not valid JSON (line {exc.lineno}, column "
                          f"{exc.colno}: {exc.msg})") from None
    baseline = parse_baseline(data, str(path))
    if data.get("digest") != baseline_digest(data):
        raise ResultError(f"{path}: the baseline was changed after it was written (its digest "
                          f"does not match its content); a baseline changes only by being "
                          f"written again: `uqguide baseline RESULT -o FILE --force` (golden "
                          f"baselines: scripts/update_golden.py)")
    check_seal(data, str(path), require_key)
    return baseline
