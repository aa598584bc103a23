"""Statistics as a regression gate: the comparison of a result with a baseline.

``uqguide check RESULT --baseline B.json`` compares every statistic of the result with the
baseline's (:mod:`uqguide.gate.baseline`) at the same points: a Monte Carlo (sample) estimate
fails beyond ``sigmas`` (default 4) combined standard errors ``sqrt(se_a^2 + se_b^2)``; a PCE's
(a deterministic function of its design) beyond ``pce_rtol`` (default 2%, stored in the
baseline) of the statistic's scale; every tolerance has a floor of :data:`ROUNDOFF_RTOL` of the
component's peak magnitude. Quantiles, event probabilities and, with ``--sensitivity``, Sobol'
indices are judged the same two ways (:func:`check_result`). A baseline that cannot be read or
does not match the result (another model, a label or output missing, other kind, unit or
components) raises :class:`~uqguide.errors.ResultError` (exit 2); a config that differs is
listed in the notes and the statistics decide. The standard errors used, and why each
tolerance is what it is: ``docs/regression-gate.md#how-much-a-statistic-may-move``.
"""


from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .baseline import (
    SAMPLE_EVENTS, Baseline, BaselineEvent, BaselineOutput, BaselinePoint, delta_std_se,
    index_values, seal_note, to_jsonable, read_baseline, write_baseline,
)
from ..core.events import EventEstimate
from .tolerances import DEFAULT_PCE_RTOL, DEFAULT_SIGMAS, check_tolerance
from ..errors import ResultError
from ..models.base import OutputInfo
from ..results.dataset import misshapen
from ..results.result import Result
from ..results.statistics import SAMPLE, Z95, OutputStatistics, result_statistics

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["DEFAULT_PCE_RTOL", "DEFAULT_SIGMAS", "Baseline", "CheckReport", "CheckRow",
           "check_compatible", "check_result", "config_differences", "read_baseline",
           "write_baseline"]

#: Differences below this fraction of an output component's peak magnitude are numerical noise.
ROUNDOFF_RTOL = 1e-6
#: A std below this fraction of the component's peak std makes skewness and kurtosis meaningless.
STD_ZERO_RTOL = 1e-8
#: How far apart the run counts (``n_used``) of a sample output's baseline and result may be
#: (:func:`_runs_ratio`).
RUNS_RATIO = 10.0


class _Absent:
    def __repr__(self) -> str:
        return "<absent>"


#: Marks a config key one of two compared configs does not have.
ABSENT: Any = _Absent()


# ---------------------------------------------------------------------------- comparison
@dataclass
class CheckRow:
    """One statistic of one output at one point, compared with the baseline.

    ``tolerance`` is the largest allowed ``|value - baseline|`` (same unit as the statistic);
    ``basis`` says where it comes from; ``note`` why a row passed or failed other than by value.
    """

    label: str
    output: str
    component: str
    time: float | None
    stat: str
    unit: str
    value: float
    baseline: float
    tolerance: float
    basis: str
    passed: bool
    note: str = ""

    @property
    def quantity(self) -> str:
        comp = f"[{self.component}]" if self.component else ""
        where = f" at t={self.time:g} s" if self.time is not None else ""
        return f"{self.label}: {self.stat} of {self.output}{comp}{where}"

    @property
    def difference(self) -> float:
        return self.value - self.baseline

    @property
    def skipped(self) -> bool:
        return self.note.startswith("skipped")


@dataclass
class CheckReport:
    """The outcome of :func:`check_result`: one row per compared statistic, plus notes."""

    name: str
    baseline_source: str
    sigmas: float
    pce_rtol: float
    rows: list[CheckRow] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def failures(self) -> list[CheckRow]:
        return [r for r in self.rows if not r.passed]

    @property
    def passed(self) -> bool:
        return not self.failures

    def to_frame(self) -> pd.DataFrame:
        """Every compared statistic, one row each: columns ``quantity``, ``label``, ``output``,
        ``component``, ``time`` [s], ``stat``, ``unit``, ``value``, ``baseline``, ``difference``,
        ``tolerance`` (in the statistic's unit), ``basis``, ``passed``, ``note``."""
        import pandas as pd  # here: `uqguide check` starts without it

        return pd.DataFrame([{
            "quantity": r.quantity, "label": r.label, "output": r.output,
            "component": r.component, "time": r.time, "stat": r.stat, "unit": r.unit,
            "value": r.value, "baseline": r.baseline, "difference": r.difference,
            "tolerance": r.tolerance, "basis": r.basis, "passed": r.passed, "note": r.note,
        } for r in self.rows])

    def summary(self) -> str:
        """One line: PASS or REGRESSION, the counts and the tolerances used."""
        n_skip = sum(r.skipped for r in self.rows)
        n = len(self.rows) - n_skip
        labels = ", ".join(dict.fromkeys(r.label for r in self.rows))
        how = (f"Monte Carlo: {self.sigmas:g} combined standard errors; "
               f"PCE: {100 * self.pce_rtol:g}% relative")
        n_chaos = sum(r.note.startswith("skipped: chaotic") for r in self.rows)
        parts = [f"{n_skip - n_chaos} skipped (std ~ 0)"] if n_skip > n_chaos else []
        parts += [f"{n_chaos} not checked (chaotic under round-off)"] if n_chaos else []
        skipped = "; " + ", ".join(parts) if parts else ""
        if self.passed:
            return (f"PASS: {n} statistics of '{self.name}' ({labels}) within tolerance of "
                    f"baseline {self.baseline_source} ({how}){skipped}")
        return (f"REGRESSION: {len(self.failures)} of {n} statistics of '{self.name}' differ "
                f"from baseline {self.baseline_source} beyond tolerance ({how}){skipped}")

    def render(self, all_rows: bool = False) -> str:
        """The console form: the summary line, the failing (or with ``all_rows`` every) row, the
        notes."""
        parts = [self.summary()]
        rows = self.rows if all_rows else self.failures
        if rows:
            noted = any(r.note for r in rows)
            table = [{
                "quantity": r.quantity, "unit": r.unit if r.stat in ("mean", "std") else "1",
                "value": _fmt(r.value), "baseline": _fmt(r.baseline),
                "difference": _fmt(r.difference), "tolerance": _fmt(r.tolerance),
                "basis": r.basis, **({"ok": "yes" if r.passed else "NO"} if all_rows else {}),
                **({"note": r.note} if noted else {}),
            } for r in rows]
            parts += ["", _text_table(table, left=("quantity", "basis", "note"))]
        if self.notes:
            parts += ["", "Notes:"] + [f"- {n}" for n in self.notes]
        return "\n".join(parts)


def _text_table(table: list[dict[str, str]], left: tuple[str, ...]) -> str:
    """Fixed-width text table of rows of the same columns: the ``left`` columns left-aligned,
    the others right-aligned."""
    cols = list(table[0])
    cells = [list(row.values()) for row in table]
    widths = [max([len(c)] + [len(r[j]) for r in cells]) for j, c in enumerate(cols)]

    def line(values: list[str]) -> str:
        return "  ".join(v.ljust(w) if c in left else v.rjust(w)
                         for v, w, c in zip(values, widths, cols)).rstrip()

    return "\n".join([line(cols)] + [line(r) for r in cells])


def _fmt(v: float) -> str:
    if not math.isfinite(v):
        return "nan"
    a = abs(v)
    return f"{v:.5g}" if (a == 0 or 1e-3 <= a < 1e5) else f"{v:.4e}"


def _flatten(d: Any, prefix: str = "") -> dict[str, Any]:
    """The leaves of nested dicts and lists by dotted path (an empty list is a leaf)."""
    if isinstance(d, dict):
        children = [(f"{prefix}.{k}" if prefix else str(k), v) for k, v in d.items()]
    elif isinstance(d, list) and d:
        children = [(f"{prefix}[{i}]", v) for i, v in enumerate(d)]
    else:
        return {prefix: d}
    return {path: leaf for at, v in children for path, leaf in _flatten(v, at).items()}


def config_differences(baseline_config: dict[str, Any],
                       config: dict[str, Any]) -> list[tuple[str, Any, Any]]:
    """``(dotted path, baseline value, value)`` for every leaf of two resolved configs that
    differs (empty when they agree); ``ABSENT`` stands for a key one of them does not have (a
    setting added to uqguide since)."""
    a, b = _flatten(to_jsonable(baseline_config)), _flatten(to_jsonable(config))
    diffs = []
    for key in dict.fromkeys([*a, *b]):
        va, vb = a.get(key, ABSENT), b.get(key, ABSENT)
        if va != vb:
            diffs.append((key, va, vb))
    return diffs


def format_differences(diffs: list[tuple[str, Any, Any]]) -> str:
    """The differences of :func:`config_differences` on one line, ``"path: old -> new; ..."``."""
    return "; ".join(f"{k}: {va!r} -> {vb!r}" for k, va, vb in diffs)


def check_compatible(baseline: Baseline, model: str, labels: dict[str, str],
                     outputs: dict[str, OutputInfo], source: str = "baseline") -> None:
    """ResultError unless the baseline's model, method labels and outputs are all there;
    ``labels``: method label -> registered method name of the result (or config) to check."""
    if baseline.model != model:
        raise ResultError(f"{source}: baseline is for model '{baseline.model}', the result is "
                          f"model '{model}'")
    for label, bm in baseline.methods.items():
        if label not in labels:
            raise ResultError(f"{source}: the result has no method labelled '{label}' (it has: "
                              f"{', '.join(labels) or 'none'})")
        if labels[label] != bm.method:
            raise ResultError(f"{source}: method '{label}' is {bm.method} in the baseline and "
                              f"{labels[label]} in the result")
        for name, bo in bm.outputs.items():
            o = outputs.get(name)
            if o is None:
                raise ResultError(f"{source}: the result has no output '{name}' (baseline method "
                                  f"'{label}'; result outputs: {', '.join(outputs)})")
            if (o.kind, o.unit, list(o.components)) != (bo.kind, bo.unit, bo.components):
                raise ResultError(
                    f"{source}: output '{name}' is {bo.kind} [{bo.unit}] with components "
                    f"{bo.components} in the baseline, {o.kind} [{o.unit}] with components "
                    f"{list(o.components)} in the result")


def _grid_index(time: np.ndarray, p: BaselinePoint) -> tuple[int | None, str]:
    """Step of the result that matches baseline point ``p``, and a note."""
    if time.size == 0:
        return None, "the result has no time grid"
    assert p.time is not None
    if p.at == "end":
        note = "" if np.isclose(time[-1], p.time, rtol=0, atol=1e-9) else \
            f"last step at t={time[-1]:g} s, baseline's at t={p.time:g} s"
        return time.size - 1, note
    i = int(np.argmin(np.abs(time - p.time)))
    half_step = 0.5 * float(np.min(np.diff(time))) if time.size > 1 else 0.0
    if abs(time[i] - p.time) > half_step + 1e-9:
        return None, f"no step of the result's grid ({time[0]:g}..{time[-1]:g} s) at this time"
    return i, ""


def _compare_output(label: str, name: str, unit: str, bo: BaselineOutput, s: OutputStatistics,
                    time: np.ndarray, sigmas: float, pce_rtol: float,
                    inputs: tuple[str, ...] | None = None) -> list[CheckRow]:
    """Rows of one output: moments and quantiles, and with ``inputs`` (the result's input
    names: ``--sensitivity``) the Sobol' indices."""
    rows: list[CheckRow] = []
    sample = bo.uncertainty == SAMPLE
    # Magnitude and spread per component over the baseline's points: the floors' scales.
    mag: dict[str, float] = {}
    peak_std: dict[str, float] = {}
    for p in bo.points:
        m, sd = abs(p.mean or 0.0), abs(p.std or 0.0)
        mag[p.component] = max(mag.get(p.component, 0.0), m + sd)
        peak_std[p.component] = max(peak_std.get(p.component, 0.0), sd)
    comps = list(bo.components)
    for p in bo.points:
        c = comps.index(p.component)
        if bo.kind == "series":
            i, where_note = _grid_index(time, p)
            where: tuple[int, ...] | None = None if i is None else (i, c)
        else:
            where, where_note = (c,), ""
        std_a = float(s.moment("std").value[where]) if where is not None else math.nan
        std_b = math.nan if p.std is None else p.std
        floor = ROUNDOFF_RTOL * mag[p.component]
        zero_std = STD_ZERO_RTOL * peak_std[p.component]
        for moment in s.moments:
            stat = moment.name
            b = getattr(p, stat)
            b = math.nan if b is None else float(b)
            row = CheckRow(label, name, p.component, p.time, stat, unit,
                           math.nan, b, math.nan, "", False, where_note)
            rows.append(row)
            if where is None:
                continue
            a = float(moment.value[where])
            row.value = a
            if stat in p.roundoff:
                lo, hi = (math.nan if v is None else v for v in p.roundoff[stat])
                row.passed = True
                row.note = (f"skipped: chaotic under round-off (took {_fmt(lo)} .. {_fmt(hi)} "
                            "when the baseline's inputs moved by 1e-12)")
                continue
            if stat in ("skewness", "kurtosis") and not (std_a > zero_std and std_b > zero_std):
                row.passed, row.note = True, "skipped: std ~ 0 (ratio of round-off)"
                if math.isinf(std_a) or (math.isnan(std_b) and p.mean is not None):
                    row.note = "skipped: std not finite (its sums overflowed)"
                continue
            if sample:
                se_a = s.standard_error(stat, where)
                se_b = _baseline_moment_se(p, stat, bo.n_used, bo.moments_method)
                spread = math.hypot(se_a, se_b)  # no overflow of the squares
            else:
                spread = {"mean": max(abs(b), abs(std_b)), "std": abs(b),
                          "skewness": max(abs(b), 1.0), "kurtosis": abs(b)}[stat]
            _judge(row, a, b, spread, sample, sigmas, pce_rtol, floor)
        if where is not None:
            rows += _compare_quantiles(label, name, unit, p, s, where, sample, sigmas,
                                       pce_rtol, floor, bo.n_used)
        if inputs is not None and p.indices:
            got = {} if where is None else \
                {n: (v, b) for n, v, b in index_values(s, where, inputs)}
            rows += _compare_indices(label, name, p, got, bo.sobol_estimator != "pce", sigmas,
                                     pce_rtol)
    return rows


def _compare_indices(label: str, name: str, p: BaselinePoint,
                     got: dict[str, tuple[float | None, tuple[float | None, float | None]]],
                     sample: bool, sigmas: float, pce_rtol: float) -> list[CheckRow]:
    """The baseline point's Sobol' indices against the result's at the same place."""
    rows = []
    for key, (b, lo_b, hi_b) in p.indices.items():
        assert b is not None  # (validated)
        kind, _, of = key.partition(":")
        stat = {"first": "S1", "total": "ST", "group_first": "S1 group",
                "group_total": "ST group"}[kind] + f"[{of}]"
        row = CheckRow(label, name, p.component, p.time, stat, "1", math.nan, b, math.nan,
                       "", False)
        rows.append(row)
        value, (lo_a, hi_a) = got.get(key, (None, (None, None)))
        if value is None:
            row.note = "the result has no such index here"
            continue
        row.value = a = value
        if sample:
            comb = math.hypot(_half_width_se(lo_a, hi_a), _half_width_se(lo_b, hi_b))
            if not math.isfinite(comb):
                row.tolerance, row.passed = math.inf, True
                row.basis, row.note = "not checked", "no two-sided interval to judge it by"
                continue
            row.tolerance = sigmas * comb
            row.basis = f"{sigmas:g} x combined SE {_fmt(comb)}"
        else:
            row.tolerance = pce_rtol
            row.basis = f"{pce_rtol:g} absolute (a PCE's index)"
        _verdict(row, a, b)
    return rows


def _judge(row: CheckRow, a: float, b: float, spread: float, sample: bool, sigmas: float,
           pce_rtol: float, floor: float) -> None:
    """The verdict on ``a`` against the baseline's ``b`` within ``sigmas`` combined standard
    errors ``spread`` (``sample``), else ``pce_rtol`` of the scale ``spread``: at least the
    round-off ``floor``, and the floor alone where ``spread`` is not finite."""
    k = sigmas if sample else pce_rtol
    row.tolerance = max(k * spread, floor) if math.isfinite(spread) else floor
    basis = f"{sigmas:g} x combined SE {_fmt(spread)}" if sample \
        else f"{100 * pce_rtol:g}% of {_fmt(spread)}"
    row.basis = basis if row.tolerance > floor else "round-off floor (no spread)"
    _verdict(row, a, b)


def _verdict(row: CheckRow, a: float, b: float) -> None:
    # not finite: NaN (no spread), or a moment whose sums overflowed (an output near 1e300:
    # inf in the result, null in the baseline)
    if not math.isfinite(a) and not math.isfinite(b):
        row.passed, row.note = True, "NaN in both" if math.isnan(a) else "not finite in both"
    elif not math.isfinite(a) or not math.isfinite(b):
        row.passed = False
        row.note = "NaN in the " + ("result" if not math.isfinite(a) else "baseline")
    else:
        row.passed = abs(a - b) <= row.tolerance


def _baseline_moment_se(p: BaselinePoint, stat: str, n_used: int, moments_method: str
                        ) -> float:
    """The baseline's standard error of a sample moment.

    A plain std's is recomputed from the point's std, kurtosis and ``n_used``
    (:func:`delta_std_se`), so a ``std_se`` loosened by hand loosens nothing; a multi-fidelity
    std's and the skewness and kurtosis ones are the stored ones (they need moments of order
    8-16 a baseline does not hold, and another run's is no substitute: a lognormal kurtosis's
    varies 17x between reseeded runs of 2000); only the keyed seal protects those.
    """
    stored = getattr(p, f"{stat}_se")
    stored = math.nan if stored is None else float(stored)
    if stat == "std" and moments_method == "sample" and p.std is not None \
            and p.kurtosis is not None:
        return delta_std_se(p.std, p.kurtosis, n_used)
    return stored


def _baseline_se(se_a: float, n_a: int, n_b: int, stored: float) -> float:
    """The baseline's standard error of a quantile: the result's ``se_a`` scaled from its
    ``n_a`` runs to the baseline's ``n_b`` (a standard error goes as ``1 / sqrt(n)``), the
    ``stored`` one only where the result has none (an order-statistic interval is
    distribution-free, so the result's is as good a witness as the baseline's)."""
    if not math.isfinite(se_a):
        return stored
    return se_a * math.sqrt(max(n_a, 1) / max(n_b, 1))


def _half_width_se(lo: float | None, hi: float | None) -> float:
    """A standard error from a 95% interval (NaN when it has no two finite ends)."""
    if lo is None or hi is None or not (math.isfinite(lo) and math.isfinite(hi)):
        return math.nan
    return (hi - lo) / (2.0 * Z95)


def _compare_quantiles(label: str, name: str, unit: str, p: BaselinePoint, s: OutputStatistics,
                       where: tuple[int, ...], sample: bool, sigmas: float, pce_rtol: float,
                       floor: float, n_used_b: int) -> list[CheckRow]:
    """The baseline point's quantiles against the result's at the same place."""
    rows = []
    std_b = math.nan if p.std is None else p.std
    for qname, (b, lo_b, hi_b) in p.quantiles.items():
        assert b is not None  # (validated)
        row = CheckRow(label, name, p.component, p.time, qname, unit, math.nan, b, math.nan,
                       "", False)
        rows.append(row)
        q = s.own(qname)
        if q is None or q.kind != "quantile" or not q.defined_at(where):
            row.note = "the result has no such quantile here"
            continue
        row.value = a = float(q.value[where])
        if sample:
            # The baseline's standard error is the result's scaled to its run count, not the
            # half-width of its stored interval: an interval widened by hand within what the
            # baseline's own numbers allow would still loosen the check. Its own only where the
            # result has no interval here (an extreme level of few runs).
            se_a = _half_width_se(*q.interval(where))
            se_b = _baseline_se(se_a, s.n_used, n_used_b, _half_width_se(lo_b, hi_b))
            spread = math.hypot(se_a, se_b)
            if not math.isfinite(spread):
                # An extreme level of few runs (q0.00135 of 1000) has no two-sided
                # order-statistic interval in either run: nothing the runs know bounds its
                # sampling spread (it is about the sample's minimum), so it cannot be gated.
                row.tolerance, row.passed = math.inf, True
                row.basis = "not checked"
                row.note = "no two-sided interval at these run counts (an extreme level)"
                continue
        else:
            spread = max(abs(b), abs(std_b)) if math.isfinite(std_b) else abs(b)
        _judge(row, a, b, spread, sample, sigmas, pce_rtol, floor)
    return rows


def _compare_events(label: str, events: dict[str, BaselineEvent],
                    got: dict[str, EventEstimate], sigmas: float, pce_rtol: float
                    ) -> list[CheckRow]:
    """The baseline's event probabilities of one method against the result's."""
    rows = []
    for ev_name, bev in events.items():
        b = bev.probability
        row = CheckRow(label, ev_name, "", None, "probability", "1", math.nan, b, math.nan,
                       "", False)
        rows.append(row)
        e = got.get(ev_name)
        if e is None or not math.isfinite(e.probability):
            row.note = "the result has no probability of this event"
            continue
        row.value = a = float(e.probability)
        if bev.estimator in SAMPLE_EVENTS:
            comb = math.hypot(_half_width_se(*e.ci), _half_width_se(*bev.ci))
            row.tolerance = sigmas * comb if math.isfinite(comb) else 0.0
            row.basis = f"{sigmas:g} x combined SE {_fmt(comb)}"
        else:
            row.tolerance = max(pce_rtol * b, 1.0 / bev.n_used)
            row.basis = f"{100 * pce_rtol:g}% of {_fmt(b)}, at least one draw"
        _verdict(row, a, b)
    return rows


def _runs_ratio(label: str, name: str, bo: BaselineOutput, s: OutputStatistics,
                source: str) -> str:
    """A note when the result has far fewer runs than the baseline; a ResultError (the gate
    cannot judge) when the baseline has far fewer than the result, beyond :data:`RUNS_RATIO`:
    its errors (as ``1 / sqrt(n_used)``) would alone set the tolerance, so a baseline re-sealed
    with a few runs would loosen every check."""
    if bo.uncertainty != SAMPLE:
        return ""
    n_b, n_a = bo.n_used, s.n_used
    if n_a > RUNS_RATIO * n_b:
        raise ResultError(
            f"{source}: methods.{label}.outputs.{name}.n_used: the baseline has {n_b} runs, "
            f"the result {n_a}, more than {RUNS_RATIO:g}x as many; the baseline's standard "
            f"errors ({math.sqrt(n_a / n_b):.3g}x the result's) would set the tolerance; write "
            f"the baseline from a run of about the result's size (`uqguide baseline RESULT -o "
            f"FILE --force`)")
    if n_b > RUNS_RATIO * n_a:
        return (f"{label}: {name} has {n_a} runs against the baseline's {n_b} (fewer by more "
                f"than {RUNS_RATIO:g}x): the check is only as tight as the result's own runs")
    return ""


def baseline_indices(baseline: Baseline) -> int:
    """How many Sobol' indices ``baseline`` holds (0 before format 4)."""
    return sum(len(p.indices) for m in baseline.methods.values()
               for o in m.outputs.values() for p in o.points)


def check_sensitivity_possible(baseline: Baseline, source: str) -> int:
    """The count of the baseline's Sobol' indices; a :class:`ResultError` (exit 2) when it
    holds none, so that ``run --check ... --check-sensitivity`` refuses before it runs."""
    n_indices = baseline_indices(baseline)
    if not n_indices:
        why = (f"a format {baseline.format_version} baseline (indices from format 4 on)"
               if baseline.format_version < 4 else "its result had no Sobol' indices")
        raise ResultError(f"{source}: --sensitivity: the baseline holds no Sobol' index to "
                          f"check ({why}); write it again from a result with indices "
                          f"(`uqguide baseline RESULT -o FILE --force`)")
    return n_indices


def check_result(result: Result, baseline: Baseline, sigmas: float = DEFAULT_SIGMAS,
                 pce_rtol: float | None = None, source: str = "baseline",
                 sensitivity: bool = False) -> CheckReport:
    """Compare every statistic of ``result`` with ``baseline`` at the baseline's points: one
    row per statistic, with its tolerance and verdict.

    ``sigmas``: Monte Carlo tolerance in combined standard errors;
    ``pce_rtol``: default the baseline's; ``source``: the baseline's name in messages (its
    path); ``sensitivity``: also compare the Sobol' indices (ResultError when the baseline holds
    none). ResultError when the result cannot be compared (:func:`check_compatible`).
    """
    check_tolerance("--sigmas", sigmas)
    rtol = baseline.tolerances.pce_rtol if pce_rtol is None else pce_rtol
    check_tolerance("--pce-rtol", rtol)
    if not baseline.methods:
        raise ResultError(f"{source}: the baseline names no method: it would check nothing")
    check_compatible(baseline, result.model, {r.label: r.estimate.method for r in result.runs},
                     {o.name: o for o in result.outputs}, source)
    report = CheckReport(result.name, source, sigmas, rtol)
    described = result_statistics(result)
    n_indices = check_sensitivity_possible(baseline, source) if sensitivity \
        else baseline_indices(baseline)
    inputs = tuple(result.input_names) if sensitivity else None
    for label, bm in baseline.methods.items():
        run = result.run(label)
        if not bm.outputs:
            raise ResultError(f"{source}: baseline method '{label}' names no output: it would "
                              f"check nothing")
        for name, bo in bm.outputs.items():
            s = described[label].get(name)
            if s is None:
                raise ResultError(f"{source}: method '{label}' of the result has no statistics "
                                  f"of output '{name}'")
            problem = misshapen(run.estimate.stats[name], s.output, result.time.size,
                                f"{label}/{name}")
            if problem:
                raise ResultError(f"result {problem}")
            note = _runs_ratio(label, name, bo, s, source)
            if note and note not in report.notes:
                report.notes.append(note)
            rows = _compare_output(label, name, bo.unit, bo, s, result.time, sigmas, rtol,
                                   inputs)
            if not any(not r.skipped for r in rows):
                raise ResultError(f"{source}: baseline method '{label}', output '{name}' has no "
                                  f"statistic to check")
            report.rows += rows
        report.rows += _compare_events(label, bm.events, run.estimate.events, sigmas, rtol)
        extra = [n for n in described[label] if n not in bm.outputs]
        if extra:
            report.notes.append(f"{label}: output(s) {', '.join(extra)} not in the baseline, "
                                f"not checked")
        if run.n_runs != bm.n_runs:
            report.notes.append(f"{label}: {run.n_runs} runs, baseline {bm.n_runs}")
    if seal_note(baseline):
        report.notes.append(seal_note(baseline))
    if baseline.format_version < 3:
        report.notes.append(f"{source} is a format {baseline.format_version} baseline: its "
                            f"quantiles and event probabilities are not checked; write it "
                            f"again (`uqguide baseline RESULT -o FILE --force`) to check them")
    if n_indices and not sensitivity:
        report.notes.append(f"the baseline's {n_indices} Sobol' indices are not checked "
                            f"(check them with --sensitivity)")
    extra_labels = [r.label for r in result.runs if r.label not in baseline.methods]
    if extra_labels:
        report.notes.append(f"method(s) {', '.join(extra_labels)} not in the baseline, "
                            f"not checked")
    diffs = config_differences(baseline.config, result.config)
    changed = [d for d in diffs if d[1] is not ABSENT]
    added = [d for d in diffs if d[1] is ABSENT]
    if changed:
        report.notes.append("config differs from the baseline's: " + format_differences(changed))
    if added:
        report.notes.append("settings the baseline does not have (defaults since added): "
                            + format_differences(added))
    vdiff = [f"{k} {baseline.versions.get(k, '?')} -> {v}"
             for k, v in result.provenance.get("versions", {}).items()
             if baseline.versions.get(k) != str(v)]
    if vdiff:
        report.notes.append("versions differ from the baseline's: " + "; ".join(vdiff))
    return report
