"""A run's statistics, described for their readers: which there are, how they are named and
labelled, where they are read, their intervals and standard errors.

The report tables, the regression gate and the run's checks read a method's statistics through
this description, which reads them from the method's Dataset (:mod:`uqguide.results.dataset`).
What one method estimated of one output is an :class:`OutputStatistics`, whose
:class:`Statistic` entries are the method's own moments, a validated PCE's ``+cv`` moments, the
``+mc`` estimate of its own runs where it withholds one, and the quantiles; each holds its
values, intervals and where it is usable. The places a statistic is reported at are
:func:`points`.

How the statistics are read: docs/architecture.md#a-results-statistics.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from ..core.types import RUNS_NEEDED, STAT_NAMES, OutputStats
from ..errors import ResultError
from ..stats.moments import overflowed
from ..stats.quantiles import level_name
from .dataset import SOURCES, layout, read_stats

if TYPE_CHECKING:
    from ..models.base import OutputInfo
    from .result import Result

#: Half-width of a 95% normal interval in standard errors.
Z95 = 1.959963984540054
#: How an output's statistics are judged: by standard errors (sample estimates) or by a relative
#: tolerance (a PCE's exact or surrogate-sampled moments).
SAMPLE, RELATIVE = "standard_error", "relative_tolerance"
#: ``moments_method`` of estimates made from model runs, judged by their standard errors:
#: plain sample moments, and multi-fidelity Monte Carlo's (:mod:`uqguide.methods.mfmc`).
FROM_RUNS = ("sample", "mfmc")

Kind = Literal["moment", "corrected", "fallback", "quantile"]


@dataclass(frozen=True)
class Point:
    """One place a statistic is reported at: a step of a series, or a scalar, and a component.

    ``at``: ``"report"`` (a report time's step), ``"end"`` (the grid's last step) or
    ``"scalar"``; ``time`` [s] and ``step`` None for a scalar; ``name``: the component's
    (``""`` for a single component).
    """

    at: Literal["report", "end", "scalar"]
    time: float | None
    step: int | None
    component: int
    name: str

    @property
    def where(self) -> tuple[int, ...]:
        """Index of this point in a statistic's values: ``(step, component)`` or
        ``(component,)``."""
        return (self.component,) if self.step is None else (self.step, self.component)


def report_indices(t: np.ndarray, report_times: Sequence[float] | None,
                   n_default: int = 5) -> np.ndarray:
    """Grid indices of the report times (nearest step) on the grid ``t (T,)`` plus the last
    step; ``n_default`` evenly spaced steps when there are no report times."""
    if t.size == 0:
        return np.zeros(0, dtype=int)
    if report_times:
        idx = [int(np.argmin(np.abs(t - rt))) for rt in report_times]
    else:
        idx = list(np.linspace(0, t.size - 1, n_default).round().astype(int))
    return np.unique(np.append(idx, t.size - 1))


def points(output: OutputInfo, time: np.ndarray,
           report_times: Sequence[float] | None) -> list[Point]:
    """The points an output's statistics are reported at, step by step, component by component:
    the nearest steps of the config's ``report_times`` [s] plus the last step
    (:func:`report_indices`)."""
    if output.kind == "scalar":
        return [Point("scalar", None, None, c, n) for c, n in enumerate(output.components)]
    last = time.size - 1
    return [Point("end" if i == last else "report", float(time[i]), int(i), c, n)
            for i in report_indices(time, report_times)
            for c, n in enumerate(output.components)]


@dataclass(frozen=True)
class Statistic:
    """One statistic of one output by one method, at every step and component.

    ``label``: the method's, ``<label>+cv`` for a control-variate estimate; ``name``: ``mean``,
    ``std``, ``skewness``, ``kurtosis`` or a quantile's level name (``q0.99``); ``kind``:
    ``"moment"`` (the method's own), ``"corrected"`` (a validated PCE's control-variate),
    ``"fallback"`` (the Monte Carlo estimate of a PCE's own runs where it withholds its moment)
    or ``"quantile"``; ``value (..., k)``: in the output's unit (a quantile NaN at steps where
    none was computed); ``ci (2, ..., k)``: None where the method gives none; ``sem``: of a
    sample mean (the mean's interval when it has no other); ``usable``: where the value is
    usable (True: everywhere; None: not judged, quantiles); ``level``: a quantile's probability.
    """

    label: str
    name: str
    kind: Kind
    value: np.ndarray
    ci: np.ndarray | None = None
    sem: np.ndarray | None = None
    usable: np.ndarray | bool | None = True
    level: float | None = None

    def defined_at(self, where: tuple[int, ...]) -> bool:
        """Whether the statistic exists at ``where``: a quantile is NaN at the steps it was
        not computed at, a PCE's fallback where the PCE gives its own value; a moment exists
        everywhere (a NaN moment is a value)."""
        return self.kind not in ("quantile", "fallback") or not np.isnan(self.value[where])

    def interval(self, where: tuple[int, ...]) -> tuple[float, float]:
        """The 95% interval at ``where``: the method's; for a sample mean without one,
        ``mean -+ 1.96 sem``; NaN where there is none."""
        if self.ci is not None:
            return float(self.ci[0][where]), float(self.ci[1][where])
        if self.sem is not None:
            m, e = self.value[where], self.sem[where]
            return float(m - 1.96 * e), float(m + 1.96 * e)
        return float("nan"), float("nan")

    def usable_at(self, where: tuple[int, ...]) -> bool | None:
        """Whether the value at ``where`` is usable; None for a statistic that is not judged."""
        if self.usable is None or isinstance(self.usable, bool):
            return self.usable
        return bool(self.usable[where])


@dataclass(frozen=True)
class OutputStatistics:
    """What one method estimated of one output: its statistics, and what they are judged by.

    ``moments``: its own mean, std, skewness, kurtosis in that order; ``corrected``: a
    validated PCE's control-variate moments (``<label>+cv``); ``quantiles``: by increasing
    level; ``fallback``: where a PCE withholds a moment, the Monte Carlo estimate of its own runs
    (``<label>+mc``; NaN where the PCE's own value is given); these three empty otherwise.
    ``n_used``: runs (or surrogate draws); ``moments_method``: ``"sample"``, ``"exact"`` or
    ``"surrogate-sampling"``; ``cov (..., k, k)``; ``sobol_first``, ``sobol_total``
    ``(..., k, d)`` and their ``_ci`` (a PCE's; Monte Carlo's first-order ones, NaN at steps
    where none was computed); ``validation_error``: a validated PCE's out-of-sample relative
    error; ``usable``: where a PCE's surrogate is usable (None: not judged);
    ``sobol_estimator``: ``"pce"``, ``"given-data"`` or ``""``; ``sobol_groups`` with
    ``sobol_group_first``, ``sobol_group_total`` ``(..., k, G)`` and their ``_ci`` (the total
    ones a PCE's or a pick-freeze design's), or None.
    """

    label: str
    output: OutputInfo
    moments: tuple[Statistic, ...]
    corrected: tuple[Statistic, ...]
    quantiles: tuple[Statistic, ...]
    n_used: int
    moments_method: str
    cov: np.ndarray
    sobol_first: np.ndarray | None = None
    sobol_total: np.ndarray | None = None
    validation_error: np.ndarray | None = None
    usable: np.ndarray | None = None
    fallback: tuple[Statistic, ...] = ()
    sobol_first_ci: np.ndarray | None = None
    sobol_total_ci: np.ndarray | None = None
    sobol_estimator: str = ""
    sobol_groups: tuple[str, ...] = ()
    sobol_group_first: np.ndarray | None = None
    sobol_group_first_ci: np.ndarray | None = None
    sobol_group_total: np.ndarray | None = None
    sobol_group_total_ci: np.ndarray | None = None

    @classmethod
    def of(cls, label: str, output: OutputInfo, s: OutputStats) -> OutputStatistics:
        """The description of one method's statistics ``s`` of ``output``, read from their
        variables (:func:`uqguide.results.dataset.layout`)."""
        try:
            coords, variables = layout({output.name: s}, [output], np.zeros(0), ())
        except ValueError as exc:  # moments or intervals of different shapes (a method's bug)
            raise ResultError(f"{label}/{output.name}: statistics of inconsistent shapes "
                              f"({exc})") from None
        return cls.read(label, output, coords | variables)

    @classmethod
    def read(cls, label: str, output: OutputInfo, ds: Mapping[str, Any]) -> OutputStatistics:
        """The description of the statistics of ``output`` in one method's Dataset ``ds`` (an
        ``xarray.Dataset`` or a mapping of :class:`~uqguide.results.dataset.Variable`)."""
        s = read_stats(ds, [output])[output.name]
        moments = tuple(Statistic(label, n, "moment", s.stat(n), s.ci.get(n),
                                  s.sem if n == "mean" else None,
                                  True if s.usable is None else s.usable)
                        for n in STAT_NAMES)
        other = {kind: tuple(Statistic(label + SOURCES[ds[f"{output.name}_{kind}"].attrs["source"]],
                                       n, kind, getattr(s, kind)[n], getattr(s, f"{kind}_ci")[n])
                             for n in STAT_NAMES) if getattr(s, kind) else ()
                 for kind in ("corrected", "fallback")}
        table = s.quantile_table()
        quantiles = () if table is None else tuple(
            Statistic(label, level_name(p), "quantile", table[1][j], table[2][:, j],
                      usable=None, level=p)
            for j, p in enumerate(table[0]))
        return cls(label, output, moments, other["corrected"], quantiles, s.n_used,
                   s.moments_method, s.cov, s.sobol_first, s.sobol_total, s.validation_error,
                   s.usable, other["fallback"], s.sobol_first_ci, s.sobol_total_ci,
                   s.sobol_estimator, s.sobol_groups, s.sobol_group_first,
                   s.sobol_group_first_ci, s.sobol_group_total, s.sobol_group_total_ci)

    @property
    def statistics(self) -> tuple[Statistic, ...]:
        """Every statistic in reading order: own moments, control-variate moments, the
        fallback where a moment is withheld, quantiles."""
        return self.moments + self.corrected + self.fallback + self.quantiles

    def withheld_at(self, where: tuple[int, ...]) -> list[str]:
        """The moments a PCE withholds at ``where`` (not usable there, or not supported by
        its runs: :mod:`uqguide.pce.support`); empty for sampling methods."""
        if not self.usable_at(where):
            return list(STAT_NAMES)
        return [f.name for f in self.fallback if np.isfinite(f.value[where])]

    def overflowed_at(self, where: tuple[int, ...]) -> list[str]:
        """The method's own moments at ``where`` that are not finite because their sums
        overflowed double precision (:func:`uqguide.stats.moments.overflowed`); none where a
        PCE's surrogate is not usable (its moments are NaN for that reason)."""
        if not self.usable_at(where):
            return []
        masks = self._overflow_masks(where)
        return [n for n in STAT_NAMES if bool(masks[n])]

    @property
    def overflows(self) -> bool:
        """Whether any of the method's own moments overflowed, anywhere (:meth:`overflowed_at`)."""
        usable = True if self.usable is None else self.usable
        return any(bool(np.any(m & usable)) for m in self._overflow_masks(...).values())

    def _overflow_masks(self, where: Any) -> dict[str, np.ndarray]:
        mean, std, skew, kurt = (m.value[where] for m in self.moments)
        return overflowed(mean, std, skew, kurt, sample=self.moments_method == "sample",
                          n_used=self.n_used)

    def needs_runs(self, name: str) -> int | None:
        """The runs the sample moment (or quantile) ``name`` needs when the method's were fewer
        (:data:`~uqguide.core.types.RUNS_NEEDED`; its value is NaN unless no input is uncertain,
        when one run is the whole distribution); None otherwise."""
        need = RUNS_NEEDED.get(name)
        if need is None or self.moments_method != "sample" or self.n_used >= need:
            return None
        return need

    @property
    def sem(self) -> np.ndarray | None:
        """The standard error of the mean (sample estimates only)."""
        return self.moments[0].sem

    @property
    def uncertainty(self) -> str:
        """How the statistics are judged: :data:`SAMPLE` or :data:`RELATIVE`."""
        return SAMPLE if self.moments_method in FROM_RUNS else RELATIVE

    @property
    def quantile_levels(self) -> tuple[float, ...]:
        """The quantiles' probabilities (empty when there are none)."""
        return tuple(float(q.level) for q in self.quantiles if q.level is not None)

    def moment(self, name: str) -> Statistic:
        """The method's own moment ``name`` (mean, std, skewness or kurtosis)."""
        return self.moments[STAT_NAMES.index(name)]

    def own(self, name: str) -> Statistic | None:
        """The method's own statistic of that name (a moment or a quantile's level name), if any."""
        return next((st for st in self.moments + self.quantiles if st.name == name), None)

    def usable_at(self, where: tuple[int, ...]) -> bool:
        """Whether the method's own moments are usable at ``where`` (always, unless judged)."""
        return True if self.usable is None else bool(self.usable[where])

    def standard_error(self, name: str, where: tuple[int, ...]) -> float:
        """Standard error of the sample moment ``name`` at ``where``, in the statistic's unit.

        The standard error of the mean where there is one; else the half-width of the
        method's 95% interval over :data:`Z95` (a bootstrap percentile interval of a
        near-normal estimator is ``-+1.96 se``), of its finite side for a one-sided interval
        (:mod:`uqguide.stats.tail_intervals`); else normal theory: ``std / sqrt(n)``,
        ``std / sqrt(2 n)``, ``sqrt(6 / n)``, ``sqrt(24 / n)``.
        """
        n = max(self.n_used, 1)
        st = self.moment(name)
        if name == "mean" and st.sem is not None:
            return float(st.sem[where])
        if st.ci is not None:
            lo, hi = float(st.ci[0][where]), float(st.ci[1][where])
            if math.isfinite(lo) and math.isfinite(hi):
                return (hi - lo) / (2.0 * Z95)
            # a one-sided interval (a floor the runs cannot bound above): its finite side
            v = float(st.value[where])
            for end in (lo, hi):
                if math.isfinite(end) and math.isfinite(v) and end != v:
                    return abs(v - end) / Z95
        std = float(self.moment("std").value[where])
        normal_theory = {"mean": std / math.sqrt(n), "std": std / math.sqrt(2 * n),
                         "skewness": math.sqrt(6.0 / n), "kurtosis": math.sqrt(24.0 / n)}
        return normal_theory[name]


def result_statistics(result: Result) -> dict[str, dict[str, OutputStatistics]]:
    """The description of every method's statistics of a result: by method label (the
    result's order), then by output name (the result's order; the outputs the method has
    statistics of)."""
    return {r.label: {o.name: OutputStatistics.of(r.label, o, r.estimate.stats[o.name])
                      for o in result.outputs if o.name in r.estimate.stats}
            for r in result.runs}
