"""Tables of a result: the cost table and the statistics table
(docs/guide.md#running-a-shipped-study).

``statistics_table`` is the long form (one row per output, component, time, method and
statistic) written to CSV; the printed and Markdown forms are pivots of it. Beside every value it
gives the reference method's value, the relative difference and whether the value lies inside
the reference's 95% interval (bootstrap for std, skewness, kurtosis; ``mean +- 1.96 sem`` for the
mean), so a reader sees whether a difference is larger than the reference's own noise.
"""

from __future__ import annotations

import math

from pathlib import Path
import re
import textwrap
import warnings
from typing import Any

import numpy as np
import pandas as pd

from ..core import atomic
from ..core.failures import COLUMNS as FAILURE_COLUMNS, failed_runs_line, reason_rows
from ..models.base import OutputInfo
from ..pce.runs_estimate import says_nothing
from ..results.result import Result
from .budget import budget_tables, budget_text
from ..results.dataset import SOURCES
from ..results.statistics import (
    FROM_RUNS, OutputStatistics, Point, Statistic, points, result_statistics,
)

#: Relative differences of a series over time ignore steps where the reference's magnitude is
#: below this fraction of its peak: a ratio to a value that crosses zero means nothing.
REL_FLOOR = 1e-3


def cost_table(result: Result) -> pd.DataFrame:
    """One row per method: runs, failures, wall times and method diagnostics.

    Columns ``label``, ``method``, ``runs``, ``failed``, ``model_s``, ``compile_s`` (only when a
    method's runs compiled the model's kernel: the first run of a fresh install, never counted
    in ``model_s``), ``fit_s`` [s], the diagnostics a method has (``degree``, ``n_terms``,
    ``loo_error``...), each rare event's ``P(name)`` and ``cov(name)``, ``reference``, and
    ``status`` when a method failed.
    """
    rows = []
    # a rare-event method's event is shown for every method that estimates it: the cost of
    # its probability and coefficient of variation side by side
    rare = list(dict.fromkeys(r.estimate.diagnostics["event"] for r in result.runs
                              if "event" in r.estimate.diagnostics))
    compiled = any(r.compile_seconds > 0 for r in result.runs)
    for r in result.runs:
        d = r.estimate.diagnostics
        extra: dict[str, Any] = {k: d[k] for k in ("degree", "n_terms", "loo_error",
                                                    "n_components", "levels") if k in d}
        if "n_validation" in d:
            extra["validation"] = d["n_validation"]
            errs = [v for k, v in d.items() if k.startswith("validation_error.")]
            extra["val_error"] = max(errs) if errs else float("nan")
        extra.update(multifidelity_columns(d))
        for column, listed in (("no usable surrogate", no_surrogate_outputs(d)),
                               ("validation disagrees", disagreeing_outputs(d)),
                               ("withheld (+mc given)", withheld_outputs(d))):
            if listed:
                extra[column] = "; ".join(listed)
        for name in rare:
            ev = r.estimate.events.get(name)
            extra[f"P({name})"] = ev.probability if ev else float("nan")
            extra[f"cov({name})"] = ev.cov if ev else float("nan")
        rows.append({
            "label": r.label, "method": r.estimate.method, "runs": r.n_runs,
            "failed": r.n_failed, "model_s": round(r.model_seconds, 3),
            **({"compile_s": round(r.compile_seconds, 3)} if compiled else {}),
            "fit_s": round(r.fit_seconds, 3), **extra,
            "reference": "yes" if r.label == result.reference else "",
        })
        if not r.success:
            rows[-1]["status"] = "FAILED: no statistics"
    df = pd.DataFrame(rows)
    if "status" in df:
        df["status"] = df["status"].fillna("ok")
    return df


def cost_units(df: pd.DataFrame) -> str:
    """The units of the time columns of :func:`cost_table`'s ``df``, as a line under it: the
    column names are API, so their ``_s`` says seconds and this says which clock."""
    wall = [c for c in ("model_s", "compile_s", "fit_s") if c in df]
    summed = [c for c in ("model_s", "compile_s") if c in df]
    parts = [f"{', '.join(wall)}: s wall, {' and '.join(summed)} summed over the workers"]
    if "CPU s per level" in df:
        parts.append("CPU s per level: CPU-s")
    return "; ".join(parts)


def multifidelity_columns(diagnostics: dict) -> dict[str, Any]:
    """A multi-fidelity method's cost (:mod:`uqguide.methods.mfmc`): runs and model CPU
    seconds per level (``/``-separated, highest fidelity first; a level left out after the
    pilot shows its pilot runs), the variance reduction the pilot predicted for the allocation,
    and the plain Monte Carlo runs of the highest level that would give the standard error of
    the mean it reached (the worst of the outputs it was optimised for), and of the variance.
    Empty for the other methods."""
    if "runs_per_level" not in diagnostics:
        return {}
    runs = np.atleast_1d(diagnostics["runs_per_level"])
    cpu = np.atleast_1d(diagnostics.get("cpu_per_level", np.full(runs.size, np.nan)))
    return {
        "runs per level": " / ".join(str(int(v)) for v in runs),
        "CPU s per level": " / ".join(f"{float(v):.3g}" for v in cpu),
        "variance reduction": round(float(diagnostics.get("estimated_variance_reduction",
                                                          np.nan)), 3),
        "equivalent MC runs": round(float(diagnostics.get("equivalent_mc_runs", np.nan))),
        "equivalent MC runs (std)": _rounded(diagnostics.get("equivalent_mc_runs_std")),
    }


def _rounded(value: object) -> float | int:
    """A count rounded, or NaN (a result written before the figure existed has none)."""
    v = float(value) if isinstance(value, (int, float, np.floating)) else float("nan")
    return round(v) if np.isfinite(v) else float("nan")


def no_surrogate_outputs(diagnostics: dict) -> list[str]:
    """``"output (why)"`` or ``"output from t = 58 s"`` for every output (span) where a PCE
    has no usable surrogate, its moments withheld
    (:func:`uqguide.pce.credibility.no_usable_surrogate`; ``unusable.`` in an older
    result file)."""
    out = [f"{name} ({v})" for name, v in _by_output(diagnostics, "no_usable_surrogate.",
                                                     "unusable.")]
    out += [f"{name} from t = {v:g} s"
            for name, v in _by_output(diagnostics, "no_usable_surrogate_from.",
                                      "unusable_from.")]
    return out


def unusable_outputs(diagnostics: dict) -> list[str]:
    """Deprecated name of :func:`no_surrogate_outputs`."""
    warnings.warn("uqguide.report.tables.unusable_outputs is deprecated: use "
                  "no_surrogate_outputs", DeprecationWarning, stacklevel=2)
    return no_surrogate_outputs(diagnostics)


def _by_output(diagnostics: dict, *prefixes: str) -> list[tuple[str, Any]]:
    """``(output, value)`` of the diagnostics ``prefix + output`` (the first of ``prefixes``
    that names the output: the others are its older names), by output name: the order of a
    dict read back from a result file is not the order the method wrote it in, and the same
    result must print the same text."""
    found: dict[str, Any] = {}
    for prefix in reversed(prefixes):
        found.update((k[len(prefix):], v) for k, v in diagnostics.items()
                     if k.startswith(prefix))
    return sorted(found.items())


def withheld_outputs(diagnostics: dict) -> list[str]:
    """``"zem (kurtosis)"`` or ``"x at 19 steps from t = 5.3 s"`` for every output whose PCE
    skewness or kurtosis its runs do not support (:mod:`uqguide.pce.support`)."""
    out = [f"{name} ({v})" for name, v in _by_output(diagnostics, "withheld.")]
    out += [f"{name} (every moment: {v})" for name, v in _by_output(diagnostics, "runs_failed.")]
    out += [f"{name} at {v} steps from t = "
            f"{diagnostics.get('withheld_from.' + name, float('nan')):g} s"
            for name, v in _by_output(diagnostics, "withheld_steps.")]
    return out


def disagreeing_outputs(diagnostics: dict) -> list[str]:
    """``"zem (skewness)"`` or ``"omega_s from t = 57 s"`` for every output (span) whose PCE
    statistics its validation runs refute (:func:`uqguide.pce.validation.disagreeing`)."""
    out = [f"{name} ({v})" for name, v in _by_output(diagnostics, "disagrees.")]
    out += [f"{name} from t = {v:g} s" for name, v in _by_output(diagnostics, "disagrees_from.")]
    return out


def validation_table(result: Result) -> pd.DataFrame:
    """A validated PCE's own value beside its control-variate value and interval, per output,
    component, statistic (and report time for a series), with the model runs it cost (fit plus
    validation)."""
    described = result_statistics(result)
    rows = []
    for r in result.runs:
        d = r.estimate.diagnostics
        runs = f"{r.n_runs - int(d.get('n_validation', 0))}+{int(d.get('n_validation', 0))}"
        for v in described[r.label].values():
            if not v.corrected:
                continue
            for p in points(v.output, result.time, result.report_times):
                w = p.where
                err = float(v.validation_error[w]) if v.validation_error is not None \
                    else float("nan")
                for cv in v.corrected:
                    lo, hi = cv.interval(w)
                    rows.append({"label": r.label, "output": v.output.name, "component": p.name,
                                 "time": _time(p), "stat": cv.name,
                                 "pce": float(v.moment(cv.name).value[w]),
                                 "corrected": float(cv.value[w]), "ci_low": lo, "ci_high": hi,
                                 "val_error": err, "usable": v.usable_at(w), "runs": runs})
    return pd.DataFrame(rows)


def _time(p: Point) -> float:
    """A point's time in a table: NaN for a scalar."""
    return float("nan") if p.time is None else p.time


def validation_text(df: pd.DataFrame) -> pd.DataFrame:
    out = df[["label", "output", "component", "time", "stat"]].copy()
    # a usable PCE's NaN is a value its runs refuted or do not support (withheld, with a
    # reason in the warnings and the cost table), not a number
    out["PCE"] = [("no usable surrogate" if not u else _fmt(v) if np.isfinite(v)
                   else "withheld") for v, u in zip(df["pce"], df["usable"])]
    out["+cv [95%]"] = [f"{_fmt(v)} [{_fmt(a)}, {_fmt(b)}]" if np.isfinite(v) or
                              np.isfinite(a) else NOT_REPORTED for v, a, b in
                              zip(df["corrected"], df["ci_low"], df["ci_high"])]
    out["val_error"] = df["val_error"].map(_fmt)
    out["runs (fit+validation)"] = df["runs"]
    return _without_constant_columns(out)


def _without_constant_columns(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` without its ``time`` column where every time is NaN (scalars) and without its
    ``component`` column where no point names one."""
    if df["time"].isna().all():
        df = df.drop(columns="time")
    if (df["component"] == "").all():
        df = df.drop(columns="component")
    return df


def agrees(v: float, lo: float, hi: float, rv: float, rlo: float, rhi: float) -> bool | None:
    """Whether two estimates agree: their difference lies within the 95% interval of the
    difference, both estimates' errors combined (None when neither has an interval).

    Each 95% half-width is taken on the side facing the other estimate (``1.96 se`` for a
    symmetric interval), so the difference's half-width is ``sqrt(u_a^2 + u_b^2)``. An estimate
    without an interval (a PCE's moment) counts as exact: it then has to lie in the other's
    interval. Judging a candidate against the reference's interval alone would call a
    consistent 1000-run Monte Carlo "out" of a 1e5-run reference whenever its own error is the
    larger one.

    ``v, lo, hi``: one estimate and its 95% interval (NaN: none); ``rv, rlo, rhi``: the other
    (the reference) and its interval, in the same unit. None when neither estimate has an
    interval or either value is not finite.
    """
    def half(x: float, a: float, b: float, towards: float) -> float:
        w = (b - x) if towards > x else (x - a)
        # NaN: no interval (counts as exact); inf: a stated floor or ceiling, whose runs do not
        # bound it on that side, so any value there agrees with it
        return 0.0 if np.isnan(w) else float(w)

    if not (np.isfinite(lo) or np.isfinite(rlo)):
        return None
    if not (np.isfinite(v) and np.isfinite(rv)):
        return None
    width = float(np.hypot(half(v, lo, hi, rv), half(rv, rlo, rhi, v)))
    return bool(abs(v - rv) <= width)


def failure_table(result: Result) -> pd.DataFrame:
    """One row per method and failure reason: the columns of
    :data:`uqguide.core.failures.COLUMNS` (label, runs, failed, share, reason, count); no rows
    when no run failed."""
    rows = [row for r in result.runs if r.n_failed
            for row in reason_rows(r.label, r.n_runs, r.reasons[r.failed])]
    return pd.DataFrame(rows, columns=FAILURE_COLUMNS)


def statistics_table(result: Result) -> pd.DataFrame:
    """Long-form statistics at the report times (series) and for every scalar output.

    One row per output, component, time [s] (NaN for scalars), method and statistic
    (:mod:`uqguide.results.statistics`: the method's moments, a validated PCE's control-variate
    moments as ``<label>+cv``, the quantiles): ``value``, ``ci_low``, ``ci_high`` in the
    output's ``unit``, ``usable`` (moments); against the reference also ``ref_value``,
    ``abs_diff``, ``rel_diff`` and ``agrees`` (see :func:`agrees`); where an output's moments
    overflowed double precision, ``overflow`` (``"value"``: the moment, ``"interval"``: its
    interval; :func:`uqguide.stats.moments.overflowed`). ``attrs["reference"]``: the
    reference's label (None without one).
    """
    described = result_statistics(result)
    # result.run: a ResultError naming the labels when the reference is none of them
    ref = described[result.run(result.reference).label] if result.reference else None
    rows = []
    for o in result.outputs:
        for r in result.runs:
            v = described[r.label].get(o.name)
            if v is None:
                continue
            rv = ref.get(o.name) if ref is not None else None
            for p in points(o, result.time, result.report_times):
                withheld = v.withheld_at(p.where) if v.usable_at(p.where) else []
                over = v.overflowed_at(p.where)
                for st in v.statistics:
                    row = _row(o, st, p, None if rv is None else rv.own(st.name),
                               st.kind == "moment" and st.name in withheld,
                               v.needs_runs(st.name) if st.kind == "moment" else None)
                    if row and st.kind == "moment" and over:
                        row[0]["overflow"] = _overflow_kind(st, p.where, over)
                    rows += row
    table = pd.DataFrame(rows)
    table.attrs["reference"] = result.reference
    # the PCEs that withhold their moments because runs failed (the text says why)
    table.attrs["runs_failed"] = sorted(
        r.label for r in result.runs
        if any(k.startswith("runs_failed.") for k in r.estimate.diagnostics))
    table.attrs["runs_behind"] = {
        (label, o.name): n for r in result.runs for o in result.outputs
        for label, n in _runs_behind(r.label, r.estimate.diagnostics,
                                     described[r.label].get(o.name)).items()}
    return table


#: The run count in a ``not_resolved.<output>`` diagnostic ("kurtosis by 60 runs", written by
#: :func:`uqguide.pce.credibility.not_resolved`).
_BY_RUNS = re.compile(r"by (\d+) runs$")


def _runs_behind(label: str, diagnostics: dict, v: OutputStatistics | None) -> dict[str, int]:
    """The runs behind each sample estimate of one output, by its label: a sampling method's
    own moments (its runs), a PCE's ``+mc`` (its fit and validation runs that succeeded, as
    its diagnostics say where they found a value not resolved by them)."""
    if v is None:
        return {}
    out = {label: v.n_used} if v.moments_method in FROM_RUNS else {}
    m = _BY_RUNS.search(str(diagnostics.get(f"not_resolved.{v.output.name}", "")))
    if m and v.fallback:
        out[v.fallback[0].label] = int(m.group(1))
    return out


def _overflow_kind(st: Statistic, where: tuple[int, ...], over: list[str]) -> str:
    """At a point where moments overflowed: ``"value"`` for those, ``"interval"`` for a
    moment whose own value is finite but whose interval (read from the higher power sums)
    is not, ``""`` otherwise."""
    if st.name in over:
        return "value"
    if st.ci is None:  # (a PCE's moments carry no interval to lose)
        return ""
    lo, hi = st.interval(where)
    return "interval" if np.isnan(lo) or np.isnan(hi) or (np.isinf(lo) and np.isinf(hi)) \
        else ""


def _row(o: OutputInfo, st: Statistic, p: Point, ref: Statistic | None,
         withheld: bool = False, needs_runs: int | None = None) -> list[dict]:
    """The row of statistic ``st`` at point ``p`` (none where it does not exist there),
    compared with the reference's own statistic of the same name where that exists;
    ``withheld``: a PCE's moment its runs do not support (:mod:`uqguide.pce.support`);
    ``needs_runs``: the runs a sample moment needs, more than the method had (NaN value)."""
    w = p.where
    if not st.defined_at(w):
        return []
    lo, hi = st.interval(w)
    row: dict[str, object] = {"output": o.name, "component": p.name, "unit": o.unit,
                              "time": _time(p), "label": st.label, "stat": st.name,
                              "value": float(st.value[w]), "ci_low": lo, "ci_high": hi}
    usable = st.usable_at(w)
    if usable is not None:
        row["usable"] = usable
    if withheld:
        row["withheld"] = True
    if needs_runs is not None and np.isnan(st.value[w]):
        row["needs_runs"] = needs_runs
    if ref is not None and ref.defined_at(w):
        row.update(_against(float(st.value[w]), lo, hi, float(ref.value[w]), *ref.interval(w)))
    return [row]


def _against(v: float, lo: float, hi: float, rv: float, rlo: float, rhi: float
             ) -> dict[str, object]:
    """The reference's value, the difference from it and whether the two agree."""
    # A relative difference to a reference that is within its own noise of zero (a skewness
    # of a near-Gaussian output, a median near 0) means nothing: NaN there, and the absolute
    # difference says the rest.
    noisy = bool(np.isfinite(rhi - rlo)) and abs(rv) <= 0.5 * (rhi - rlo)
    return {"ref_value": rv, "abs_diff": v - rv,
            "rel_diff": (v - rv) / abs(rv) if rv and not noisy else float("nan"),
            "agrees": agrees(v, lo, hi, rv, rlo, rhi)}


def events_table(result: Result) -> pd.DataFrame:
    """One row per method and event: columns ``event``, ``definition``, ``label``,
    ``probability``, ``ci_low``, ``ci_high`` (95% interval), ``n_in``, ``n_used``, ``cov``,
    ``estimator``."""
    rows = []
    for r in result.runs:
        for name, ev in r.estimate.events.items():
            rows.append({"event": name, "definition": ev.definition, "label": r.label,
                         "probability": ev.probability, "ci_low": ev.ci[0],
                         "ci_high": ev.ci[1], "n_in": ev.n_in, "n_used": ev.n_used,
                         "cov": ev.cov, "estimator": ev.estimator})
    return pd.DataFrame(rows)


def events_text(df: pd.DataFrame) -> pd.DataFrame:
    """The events table ``df`` (:func:`events_table`) for reading, as text: columns ``event``,
    ``definition``, ``label``, ``probability [95% interval]``, ``in / used``, ``cov``,
    ``estimator``."""
    out = df[["event", "definition", "label"]].copy()
    out["probability [95% interval]"] = [
        f"{_fmt(p)} [{_fmt(lo)}, {_fmt(hi)}]"
        for p, lo, hi in zip(df["probability"], df["ci_low"], df["ci_high"])]
    out["in / used"] = [f"{a} / {b}" for a, b in zip(df["n_in"], df["n_used"])]
    out["cov"] = df["cov"].map(_fmt)
    out["estimator"] = df["estimator"]
    return out


#: Columns of ``<name>_requirements.csv`` (:func:`requirements_table`).
REQUIREMENT_COLUMNS = ["requirement", "label", "verdict", "estimate", "lower", "upper", "runs",
                       "runs_to_decide"]


def requirements_table(result: Result) -> pd.DataFrame:
    """One row per requirement and method: :data:`REQUIREMENT_COLUMNS` (the success probability,
    its one-sided bounds at the requirement's confidence, the runs behind them, the further
    runs that would decide an undecided one) and ``basis`` (how the bounds were made, or why
    there are none)."""
    order = [str(q.get("name")) for q in result.config.get("requirements") or []]
    rows = [{"requirement": v.requirement, "label": r.label, "verdict": v.verdict,
             "estimate": v.estimate, "lower": v.lower, "upper": v.upper, "runs": v.runs,
             "runs_to_decide": v.runs_to_decide, "basis": v.basis}
            for r in result.runs
            for v in sorted(r.verdicts.values(), key=lambda v: (
                order.index(v.requirement) if v.requirement in order else len(order),
                v.requirement))]
    return pd.DataFrame(rows, columns=[*REQUIREMENT_COLUMNS, "basis"])


def requirements_text(df: pd.DataFrame, result: Result) -> pd.DataFrame:
    """The requirements table ``df`` (:func:`requirements_table`) for reading: columns
    ``requirement``, ``definition``, ``label``, ``verdict``, ``estimate [lower, upper]``,
    ``runs``, ``to decide``, ``basis``."""
    from ..core.requirements import RequirementSpec

    defs = {r["name"]: RequirementSpec.model_validate(r).describe()
            for r in result.config.get("requirements") or []}
    out = df[["requirement"]].copy()
    out["definition"] = [defs.get(n, "") for n in df["requirement"]]
    out["label"], out["verdict"] = df["label"], df["verdict"]
    out["estimate [lower, upper]"] = [
        f"{_fmt(p)} [{_fmt(lo)}, {_fmt(hi)}]"
        for p, lo, hi in zip(df["estimate"], df["lower"], df["upper"])]
    out["runs"] = df["runs"]
    out["to decide"] = ["" if v == 0 else "never" if v == np.inf else "n/a" if np.isnan(v)
                        else f"{int(v):,}" for v in df["runs_to_decide"]]
    out["basis"] = df["basis"]
    return out


def series_agreement(result: Result) -> pd.DataFrame:
    """Per series output and method: the largest relative difference of mean and std over time.

    The relative difference at a step is ``|value - ref| / |ref|``, over the steps where
    ``|ref|`` is at least ``REL_FLOOR`` of its peak over time. Columns ``output``, ``label``,
    ``max_rel_mean``, ``at_t_mean`` [s], ``max_rel_std``, ``at_t_std`` [s]; empty without a
    reference.
    """
    if not result.reference:
        return pd.DataFrame()
    described = result_statistics(result)
    ref = described[result.run(result.reference).label]
    rows = []
    for o in result.outputs:
        if o.kind != "series":
            continue
        rs = ref.get(o.name)
        for r in result.runs:
            s = described[r.label].get(o.name)
            if r.label == result.reference or s is None or rs is None:
                continue
            row: dict[str, object] = {"output": o.name, "label": r.label}
            for stat in ("mean", "std"):
                a, b = s.moment(stat).value, rs.moment(stat).value
                mag = np.abs(b)
                keep = mag >= REL_FLOOR * np.nanmax(mag, axis=0, keepdims=True)
                with np.errstate(invalid="ignore", divide="ignore"):
                    rel = np.where(keep, np.abs(a - b) / np.where(keep, mag, 1.0), np.nan)
                finite = np.where(np.isfinite(rel), rel, -np.inf)
                t_idx, _ = np.unravel_index(int(np.argmax(finite)), finite.shape)
                has = bool(np.isfinite(rel).any())
                row[f"max_rel_{stat}"] = float(finite[t_idx].max()) if has else float("nan")
                row[f"at_t_{stat}"] = float(result.time[t_idx]) if has else float("nan")
            rows.append(row)
    return pd.DataFrame(rows)


# ---------------------------------------------------------------------------- text forms
#: A control-variate value the runs disagree with, or less precise than the runs' own estimate
#: (:func:`uqguide.pce.support.corrections_to_withhold`), or undefined (no variance): the
#: legend says which.
NOT_REPORTED = "not reported"
#: A sample std or kurtosis whose interval bounds it no more than its definition does
#: (:func:`uqguide.pce.runs_estimate.says_nothing`): no estimate; its value stays in the
#: result file.
NOT_RESOLVED = "not resolved by {runs}"


def _fmt(v: float) -> str:
    if v is None or (isinstance(v, float) and np.isnan(v)):
        return "nan"
    if isinstance(v, float) and np.isinf(v):
        return "inf" if v > 0 else "-inf"
    a = abs(v)
    return f"{v:.4g}" if (a == 0 or 1e-3 <= a < 1e5) else f"{v:.3e}"


def _decimals(half: float) -> int | None:
    """Decimal places that show two significant digits of an interval's half-width ``half``
    (the digits the interval supports); None where it gives none (zero, NaN, inf)."""
    if not (np.isfinite(half) and half > 0):
        return None
    return 1 - math.floor(math.log10(half))


def _supported(v: float, places: int | None) -> str:
    """``v`` to ``places`` decimal places where that shows fewer digits than :func:`_fmt`'s four
    significant ones (never more), else :func:`_fmt`'s form."""
    a = abs(v) if np.isfinite(v) else 0.0
    if places is None or not np.isfinite(v) or not (a == 0 or 1e-3 <= a < 1e5):
        return _fmt(v)
    digits = (math.floor(math.log10(a)) + 1 if a else 1) + places
    if digits >= 4:
        return _fmt(v)
    return f"{round(v, places):.{max(places, 0)}f}"


def _end(v: float, places: int | None, up: bool) -> str:
    """An interval's end at ``places`` decimals (None: :func:`_fmt`'s form), rounded outward so
    the printed interval holds the computed one."""
    if places is None or not np.isfinite(v) or _supported(v, places) == _fmt(v):
        return _fmt(v)
    step = 10.0 ** -places
    return _supported((math.ceil(v / step) if up else math.floor(v / step)) * step, places)


def wide_table(stats: pd.DataFrame, with_ref: bool) -> pd.DataFrame:
    """One row per (time, component, label); a column per statistic with its interval, as
    text; the ``time`` and ``component`` columns only where they vary.

    ``stats``: rows of :func:`statistics_table` (one output), ``stats.attrs["reference"]``
    naming the reference method; ``with_ref``: add the difference from the reference and its
    verdict to each cell.
    """
    rows = []
    keys = ["time", "component", "label"]
    for key, g in stats.groupby(keys, sort=False, dropna=False):
        row = dict(zip(keys, key))
        constant = _constant(g)
        for _, s in g.iterrows():
            row[s["stat"]] = (_constant_cell(s) if constant and not np.isnan(s["value"])
                              else "-" if constant else _cell_text(s, stats.attrs, with_ref))
        rows.append(row)
    df = _without_constant_columns(pd.DataFrame(rows))
    if "time" in df:
        df["time"] = df["time"].map(lambda t: f"{t:g}")
    return df


#: A std this small against the mean is round-off: every run gave the same value.
CONSTANT_RTOL = 1e-12


def _constant(g: pd.DataFrame) -> bool:
    """Whether one method's statistics ``g`` at one point are those of a constant output (its
    skewness and kurtosis are then undefined, its intervals round-off)."""
    by = dict(zip(g["stat"], g["value"]))
    mean, std = by.get("mean", np.nan), by.get("std", np.nan)
    return bool(np.isfinite(mean) and np.isfinite(std)
                and std <= CONSTANT_RTOL * max(abs(mean), np.finfo(float).tiny))


def _constant_cell(s: pd.Series) -> str:
    """The cell of a constant output's statistic: its value, no interval."""
    return "0 (constant)" if s["stat"] == "std" else f"{_fmt(s['value'])} (constant)"


def _cell_text(s: pd.Series, attrs: dict, with_ref: bool) -> str:
    """One statistic's cell of :func:`wide_table`: its value and interval (and difference from
    the reference ``attrs["reference"]``), or why it has none."""
    u = s.get("usable")
    if isinstance(u, (bool, np.bool_)) and not u:
        return "no usable surrogate"
    if s.get("withheld") is True:
        return ("withheld: runs failed" if s["label"] in attrs.get("runs_failed", ())
                else "withheld: its runs disagree (see +mc)")
    if s.get("overflow") == "value":
        return "overflow"
    need = s.get("needs_runs")
    if need is not None and need == need:  # pandas fills a missing one with NaN
        return f"needs {int(need)} runs"
    if s.get("overflow") == "interval":
        return f"{_fmt(s['value'])} [no interval: overflow]"
    if str(s["label"]).endswith(SOURCES["cv"]) and np.isnan(s["value"]) \
            and np.isnan(s["ci_low"]):
        return NOT_REPORTED
    if bool(says_nothing(str(s["stat"]), s["ci_low"], s["ci_high"])):
        n = attrs.get("runs_behind", {}).get((s["label"], s["output"]))
        return NOT_RESOLVED.format(runs=f"{n} runs" if n is not None else "its runs")
    # the value and its interval to the digits the interval supports (two significant digits
    # of its half-width, or of the distance to a stated floor), the ends rounded outward
    v, lo, hi = (float(s[k]) for k in ("value", "ci_low", "ci_high"))
    if np.isinf(hi) and np.isfinite(lo):
        # a stated floor (uqguide.stats.tail_intervals): no upper bound from the runs
        places = _decimals(abs(v - lo))
        cell = f"{_supported(v, places)} [>= {_end(lo, places, up=False)}]"
    elif np.isinf(lo) and np.isfinite(hi):
        places = _decimals(abs(hi - v))
        cell = f"{_supported(v, places)} [<= {_end(hi, places, up=True)}]"
    elif not np.isnan(lo):
        places = _decimals(0.5 * (hi - lo))
        if _supported(v, places) == _fmt(v):
            places = None  # the value keeps four digits: so do its ends
        cell = (f"{_supported(v, places)} [{_end(lo, places, up=False)}, "
                f"{_end(hi, places, up=True)}]")
    else:
        cell = _fmt(v)
    if with_ref and s["label"] != attrs.get("reference"):
        rd, ad = s.get("rel_diff"), s.get("abs_diff")
        inside = s.get("agrees")
        # pandas stores a missing verdict (no reference interval) as None or NaN
        flag = "?" if inside is None or inside != inside else ("in" if inside else "OUT")
        if rd is not None and np.isfinite(rd):
            cell += f" ({100 * rd:+.1f}%, {flag})"
        elif ad is not None and np.isfinite(ad):
            cell += f" ({ad:+.2g}, {flag})"
    return cell


def render_text(result: Result) -> str:
    """The console form, plain text no wider than :data:`CONSOLE_WIDTH` where it can be: cost,
    each output's statistics at the report times, events, series agreement, the error budget
    of each scalar output (:mod:`uqguide.report.budget`), the key and failures."""
    cost = cost_table(result)
    parts = [f"Cost ({cost_units(cost)})", fit_columns(cost, ["label"], na_rep="")]
    val = validation_table(result)
    if not val.empty:
        parts += ["", _prose("PCE validation (PCE value; the +cv row: the PCE's own value where "
                             "it lies within sqrt(2) standard errors of the control-variate "
                             "value, else that value, with the control variate's 95% interval "
                             "from the validation runs, delta method; val_error: out-of-sample "
                             "error / variance)"),
                  fit_columns(validation_text(val), ["label", "output", "stat"])]
    stats = statistics_table(result)
    with_ref = result.reference is not None and len(result.runs) > 1
    shown = []
    for o in result.outputs:
        sub = stats[stats["output"] == o.name] if not stats.empty else stats
        if sub.empty:
            continue
        kind = "at report times" if o.kind == "series" else "(scalar)"
        shown.append(wide_table(sub, with_ref))
        parts += ["", _prose(f"{o.name} [{o.unit}] {kind}: {o.description}"),
                  fit_columns(shown[-1], ["time", "component", "label"])]
    events = events_table(result)
    if not events.empty:
        parts += ["", _prose("Events (95% intervals: Clopper-Pearson over model runs; "
                             "surrogate: over its draws only; subset: lognormal from its CoV "
                             "upper bound, in = final level)"),
                  fit_columns(events_text(events), ["event", "label"])]
    verdicts = requirements_table(result)
    if not verdicts.empty:
        parts += ["", _prose("Requirements (one-sided bounds of the success probability at "
                             "each requirement's confidence; to decide: further runs at the "
                             "current estimate)"),
                  fit_columns(requirements_text(verdicts, result), ["requirement", "label"])]
    agree = series_agreement(result)
    if not agree.empty:
        parts += ["", f"Series over the whole time grid vs reference '{result.reference}' "
                  f"(max relative difference)",
                  fit_columns(agree, ["output", "label"], float_format=_fmt)]
    for b in budget_tables(result):
        parts += ["", budget_text(b)]
    if shown:
        parts += ["", interval_legend(result, shown, with_ref)]
    parts += _without_statistics(result)
    failures = failure_table(result)
    if not failures.empty:
        # the whole reason of each run is in the result file (RunResult.reasons)
        failures["reason"] = failures["reason"].map(
            lambda r: r if len(r) <= _PROSE_WIDTH else r[:_PROSE_WIDTH - 3] + "...")
        parts += ["", "Failed runs (excluded from the statistics)",
                  *[console_line(failed_runs_line(r.label, r.estimate.method, r.n_runs,
                                                  r.n_failed, r.estimate.diagnostics))
                    for r in result.runs if r.success and r.n_failed],
                  fit_columns(failures, ["label"])]
    return "\n".join(parts)


def _without_statistics(result: Result) -> list[str]:
    """The lines naming each method that produced no statistics, and why."""
    broken = [r for r in result.runs if not r.success]
    if not broken:
        return []
    others = "the others completed" if len(broken) < len(result.runs) else \
        "their runs are kept"
    return ["", f"Methods without statistics ({others}):",
            *[f"  {r.label}: {r.message}" for r in broken]]


#: The console's widest line: wider tables are split into blocks of columns, prose is wrapped.
CONSOLE_WIDTH = 160
_PROSE_WIDTH = 100


def interval_legend(result: Result, tables: list[pd.DataFrame], with_reference: bool) -> str:
    """The key of the symbols the statistics ``tables`` (of :func:`wide_table`) print, one
    line each, with a pointer to the page that explains them all."""
    cells = " | ".join(str(v) for df in tables for v in df.to_numpy().ravel())
    labels = {str(v) for df in tables if "label" in df for v in df["label"]}
    pce = {r.label for r in result.runs if r.estimate.method.startswith("pce_")}
    entries = [
        ("[a, b]", "95% interval; Monte Carlo's are skew-corrected (Hall) influence-function "
                   "intervals by default (a method's intervals: setting names the others)", True),
        ("[>= L], [<= U]", "a floor (ceiling): a few runs carry the statistic's variance and "
                           "cannot bound it on the other side", "[>= " in cells or "[<= " in cells),
        ("PCE value [a, b]", "the hull of the value and its +cv interval, else of its runs' "
                             "interval; none without validation runs (see loo_error)",
         bool(pce & labels)),
        ("label+cv", "a validated PCE's control-variate estimate, its interval from the "
                     "validation runs", any(x.endswith(SOURCES["cv"]) for x in labels)),
        ("label+mc", "where a PCE moment is withheld: the Monte Carlo estimate of the PCE's own "
                     "runs", any(x.endswith(SOURCES["mc"]) for x in labels)),
        ("withheld", "a PCE value its validation or Monte Carlo runs refute, or one nothing "
                     "bounds", "withheld" in cells),
        ("no usable surrogate", "the PCE's LOO or validation error is above its usable_error",
         "no usable surrogate" in cells),
        ("needs n runs", "fewer runs than the statistic takes to say anything (one run's std "
                         "is 0, two runs' kurtosis 1)", "needs " in cells),
        ("not resolved by N runs", "a std or kurtosis whose interval bounds it no more than its "
                                   "definition (>= 0, >= 1); kept in the result file",
         "not resolved by" in cells),
        ("overflow", "the sums of the output's powers overflow double precision",
         "overflow" in cells),
        ("(constant)", "every run gave the same value (a std below 1e-12 of the mean); "
                       "'-': undefined", "(constant)" in cells),
        ("(+1.2%, in | OUT)", "difference from the reference; in: within the 95% interval of "
                              "the difference", with_reference),
    ]
    shown = [(k, v) for k, v, used in entries if used]
    pad = max(len(k) for k, _ in shown) + 2
    lines = ["Key (all of it: docs/statistics.md):"]
    for key, text in shown:
        lines += textwrap.wrap(text, _PROSE_WIDTH, initial_indent=f"  {key:<{pad}}",
                               subsequent_indent=" " * (pad + 2))
    return "\n".join(lines)


def fit_columns(df: pd.DataFrame, keys: list[str], width: int = CONSOLE_WIDTH,
                **kwargs: Any) -> str:
    """``df`` as text no wider than ``width`` where it can be: whole when it fits, else in
    blocks of its other columns, each with the ``keys`` columns (``time``, ``label``...) on
    the left; ``kwargs`` go to :meth:`pandas.DataFrame.to_string`."""
    def text(cols: list[str]) -> str:
        return df[cols].to_string(index=False, **kwargs)

    def wide(s: str) -> int:
        return max((len(x) for x in s.splitlines()), default=0)

    keys = [k for k in keys if k in df.columns]
    whole = text(list(df.columns))
    if wide(whole) <= width:
        return whole
    blocks: list[list[str]] = [[]]
    for c in (c for c in df.columns if c not in keys):
        if blocks[-1] and wide(text(keys + blocks[-1] + [c])) > width:
            blocks.append([])
        blocks[-1].append(c)
    return "\n\n".join(text(keys + b) for b in blocks)


def console_line(text: str) -> str:
    """A line of the console output wrapped to :data:`CONSOLE_WIDTH`, its continuation lines
    indented (a footnote, a failure summary)."""
    return textwrap.fill(text, CONSOLE_WIDTH, subsequent_indent="  ")


def _prose(text: str) -> str:
    """A sentence over the tables, wrapped to the console."""
    return textwrap.fill(text, _PROSE_WIDTH)


def to_markdown(df: pd.DataFrame) -> str:
    """``df`` as a GitHub-flavoured Markdown table (no extra dependency): header, separator
    and one line per row; floats to 4 significant digits."""
    cols = [str(c) for c in df.columns]
    lines = ["| " + " | ".join(cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for _, row in df.iterrows():
        cells = [_fmt(v) if isinstance(v, float) else str(v) for v in row.tolist()]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def render_markdown(result: Result) -> str:
    """The Markdown summary (``<name>_summary.md``): cost, statistics, events and series
    agreement tables."""
    stats = statistics_table(result)
    with_ref = result.reference is not None and len(result.runs) > 1
    cost = cost_table(result)
    parts = [f"# {result.name}: model `{result.model}`", "", "## Cost", "", cost_units(cost) + ".",
             "", to_markdown(cost)]
    val = validation_table(result)
    if not val.empty:
        parts += ["", "## PCE validation", "", to_markdown(validation_text(val))]
    shown = []
    for o in result.outputs:
        sub = stats[stats["output"] == o.name] if not stats.empty else stats
        if not sub.empty:
            shown.append(wide_table(sub, with_ref))
            parts += ["", f"## {o.name} [{o.unit}]", "", o.description, "",
                      to_markdown(shown[-1])]
    for b in budget_tables(result):
        parts += ["", budget_text(b)]
    if shown:
        parts += ["", "```text", interval_legend(result, shown, with_ref), "```"]
    events = events_table(result)
    if not events.empty:
        parts += ["", "## Events", "", to_markdown(events_text(events))]
    verdicts = requirements_table(result)
    if not verdicts.empty:
        parts += ["", "## Requirements", "",
                  to_markdown(requirements_text(verdicts, result))]
    parts += _without_statistics(result)
    agree = series_agreement(result)
    if not agree.empty:
        parts += ["", "## Series agreement with the reference", "", to_markdown(agree)]
    return "\n".join(parts) + "\n"


def write_tables(result: Result, out_dir: Path, stem: str) -> list[Path]:
    """Write ``<stem>_stats.csv``, ``<stem>_cost.csv`` and ``<stem>_summary.md`` (and
    ``<stem>_events.csv`` when the config has events, ``<stem>_requirements.csv`` when it has
    requirements), each whole or absent; ``out_dir`` is
    made when missing, ``stem`` is the run's name. Returns the files written.
    """
    atomic.make_folder(out_dir)
    paths = [out_dir / f"{stem}_stats.csv", out_dir / f"{stem}_cost.csv",
             out_dir / f"{stem}_summary.md"]
    # Each file whole or absent (temporary file, then rename): never a 0-byte table.
    atomic.write_with(paths[0], lambda p: statistics_table(result).to_csv(p, index=False))
    events = events_table(result)
    if not events.empty:
        paths.append(out_dir / f"{stem}_events.csv")
        atomic.write_with(paths[-1], lambda p: events.to_csv(p, index=False))
    verdicts = requirements_table(result)
    if not verdicts.empty:
        paths.append(out_dir / f"{stem}_requirements.csv")
        atomic.write_with(paths[-1], lambda p: verdicts[REQUIREMENT_COLUMNS].to_csv(
            p, index=False))
    atomic.write_with(paths[1], lambda p: cost_table(result).to_csv(p, index=False))
    atomic.write_text(paths[2], render_markdown(result))
    return paths

