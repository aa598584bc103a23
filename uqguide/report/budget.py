"""The error budget: which uncertain input drives each output, read from the Sobol' indices of
the statistics description (:mod:`uqguide.results.statistics`).

One table per method and scalar output component (a series at its last step in the Markdown
report; its course over time is a figure, :mod:`uqguide.report.budget_plot`): a row per input,
ordered by first-order index, with its 95% interval where the method gives one, the total index
and its interval where the method has them (PCE: :mod:`uqguide.pce.sobol_indices`; a Saltelli
pick-freeze design), the groups of inputs (the config's ``groups``, or each correlated group)
after the inputs, and the input's **share**: its first-order index over the sum of the positive
first-order indices, the part of the first-order budget it carries. The sum of the first-order
indices is stated under the table: ``1 - sum`` is the variance that only interactions explain
(for independent inputs).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..results.result import Result
from ..results.statistics import OutputStatistics, result_statistics

#: Inputs listed per table before the rest are summed into one row.
MAX_ROWS = 12

#: How each estimator is named in a budget's title (the rest: a PCE's coefficients).
ESTIMATORS = {"given-data": "from the Monte Carlo runs (given data)",
              "saltelli": "from a Saltelli pick-freeze design"}


@dataclass(frozen=True)
class BudgetTable:
    """One method's budget of one output component.

    Attributes
    ----------
    output : str
        The output's name, ``output[component]`` for one of several components.
    at : str
        ``""`` for a scalar, ``"at t = ... s"`` for a series' step.
    estimator : str
        ``"given-data"``, ``"saltelli"`` or ``"pce"`` (:data:`ESTIMATORS`).
    table : DataFrame
        Columns input, first_order, ci_low, ci_high, total, total_low, total_high (NaN where
        unknown), share_% (see the module docstring).
    """

    label: str
    output: str
    at: str
    estimator: str
    table: pd.DataFrame
    first_sum: float

    @property
    def title(self) -> str:
        how = ESTIMATORS.get(self.estimator, "from the PCE coefficients")
        at = f" {self.at}" if self.at else ""
        return f"Error budget of {self.output}{at}, {self.label}: Sobol' indices {how}"


def budget_table(s: OutputStatistics, inputs: list[str], component: int,
                 step: int | None = None) -> pd.DataFrame | None:
    """The budget of one component of one output (at ``step`` of a series), ordered.

    Returns None where the method gave no index there (a step between report times).
    """
    if s.sobol_first is None:
        return None
    pick = (component,) if step is None else (step, component)
    first = np.asarray(s.sobol_first)[pick]
    if not np.isfinite(first).any():
        return None
    nan = np.full(first.shape, np.nan)
    ci = np.asarray(s.sobol_first_ci)[(slice(None),) + pick] \
        if s.sobol_first_ci is not None else np.stack([nan, nan])
    total = np.asarray(s.sobol_total)[pick] if s.sobol_total is not None else nan
    tci = np.asarray(s.sobol_total_ci)[(slice(None),) + pick] \
        if s.sobol_total_ci is not None else np.stack([nan, nan])
    positive = np.clip(np.nan_to_num(first), 0.0, None)
    share = 100.0 * positive / positive.sum() if positive.sum() > 0 else nan
    df = pd.DataFrame({"input": inputs, "first_order": first, "ci_low": ci[0],
                       "ci_high": ci[1], "total": total, "total_low": tci[0],
                       "total_high": tci[1], "share_%": share})
    df = df.sort_values("first_order", ascending=False, kind="stable",
                        na_position="last").reset_index(drop=True)
    if s.sobol_group_first is not None and s.sobol_groups:
        gf = np.asarray(s.sobol_group_first)[pick]
        none = np.full((2, gf.size), np.nan)

        def at(a: np.ndarray | None, bounds: bool) -> np.ndarray:
            if a is None:
                return none if bounds else none[0]
            return np.asarray(a)[(slice(None),) + pick] if bounds else np.asarray(a)[pick]

        gci, gt, gtci = (at(s.sobol_group_first_ci, True), at(s.sobol_group_total, False),
                         at(s.sobol_group_total_ci, True))
        # a group overlaps its inputs' rows: listed after them, without a share
        groups = pd.DataFrame({"input": [f"group {g}" for g in s.sobol_groups],
                               "first_order": gf, "ci_low": gci[0], "ci_high": gci[1],
                               "total": gt, "total_low": gtci[0], "total_high": gtci[1],
                               "share_%": np.nan})
        df = pd.concat([df, groups], ignore_index=True)
    return df


def budget_tables(result: Result, series_at_end: bool = False) -> list[BudgetTable]:
    """Every method's budget of every scalar output component (and, with ``series_at_end``,
    of every series at its last step), in the result's method and output order."""
    tables = []
    described = result_statistics(result)
    inputs = list(result.input_names)
    for r in result.runs:
        for o in result.outputs:
            s = described[r.label].get(o.name)
            if s is None or s.sobol_first is None:
                continue
            if o.kind == "series" and not (series_at_end and result.time.size):
                continue
            step = result.time.size - 1 if o.kind == "series" else None
            at = f"at t = {result.time[-1]:g} s" if step is not None else ""
            for c, comp in enumerate(o.components):
                df = budget_table(s, inputs, c, step)
                if df is None:
                    continue
                name = f"{o.name}[{comp}]" if comp else o.name
                one = ~df["input"].str.startswith("group ")
                tables.append(BudgetTable(r.label, name, at, s.sobol_estimator or "pce", df,
                                          float(np.nansum(df["first_order"][one]))))
    return tables


def budget_text(b: BudgetTable, max_rows: int = MAX_ROWS) -> str:
    """The console form of one budget: the largest ``max_rows`` inputs and the sum."""
    df = b.table
    groups = df[df["input"].str.startswith("group ")]
    df = df[~df["input"].str.startswith("group ")]
    shown = pd.concat([df.head(max_rows), groups], ignore_index=True)
    cols = {"input": shown["input"],
            "first-order": shown["first_order"].map(_fmt),
            "95% interval": [_interval(lo, hi) for lo, hi in zip(shown["ci_low"],
                                                                 shown["ci_high"])],
            "share": shown["share_%"].map(lambda v: f"{v:.1f}%" if np.isfinite(v) else "")}
    if np.isfinite(df["total"]).any():
        cols["total"] = shown["total"].map(_fmt)
    if np.isfinite(df["total_low"]).any():
        cols["total 95% interval"] = [_interval(lo, hi) for lo, hi in
                                      zip(shown["total_low"], shown["total_high"])]
    if not np.isfinite(df["ci_low"]).any():
        del cols["95% interval"]
    lines = [b.title, pd.DataFrame(cols).to_string(index=False)]
    rest = len(df) - min(len(df), max_rows)
    if rest > 0:
        lines.append(f"  ... {rest} more inputs, first-order indices summing to "
                     f"{np.nansum(df['first_order'].iloc[max_rows:]):.3f}")
    lines.append(f"  sum of first-order indices {b.first_sum:.3f} (1 - sum: variance from "
                 f"interactions, for independent inputs)")
    return "\n".join(lines)


def budget_markdown(b: BudgetTable) -> pd.DataFrame:
    """The Markdown report's form of one budget (every input)."""
    df = b.table
    out = pd.DataFrame({"input": df["input"], "first-order": df["first_order"].map(_fmt4)})
    if np.isfinite(df["ci_low"]).any():
        out["95% interval"] = [_interval(lo, hi) for lo, hi in zip(df["ci_low"], df["ci_high"])]
    if np.isfinite(df["total"]).any():
        out["total"] = df["total"].map(_fmt4)
    if np.isfinite(df["total_low"]).any():
        out["total 95% interval"] = [_interval(lo, hi) for lo, hi in
                                     zip(df["total_low"], df["total_high"])]
    out["share"] = df["share_%"].map(lambda v: f"{v:.1f}%" if np.isfinite(v) else "")
    return out


def _fmt(v: float) -> str:
    return f"{v:.3f}" if np.isfinite(v) else ""


def _fmt4(v: float) -> str:
    return f"{v:.4f}" if np.isfinite(v) else ""


def _interval(lo: float, hi: float) -> str:
    return f"[{lo:.3f}, {hi:.3f}]" if np.isfinite(lo) and np.isfinite(hi) else ""
