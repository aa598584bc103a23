"""The error budget: which uncertain input drives each output, read from the Sobol' indices of
the statistics description (:mod:`uqguide.results.statistics`).

One table per method and scalar output component (a series at its last step in the Markdown
report; its course over time is a figure, :mod:`uqguide.report.budget_plot`): a row per input,
ordered by first-order index, with its 95% interval where the method gives one, the total index
and its interval where the method has them (PCE: :mod:`uqguide.pce.sobol_indices`; a Saltelli
pick-freeze design), the groups of inputs (the config's ``groups``, or each correlated group)
after the inputs, and the **share**: the percent of the output's variance an input alone
explains (its first-order index, 0 if negative), given to each input outside a correlated group
and to each correlated group's own row (its inputs' indices overlap: each carries what it
shares with the others). Under the table: what the shares leave (interactions, or what a
correlated group without an index explains) and which indices the estimator does not give.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from ..core.inputs import split_groups
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
    #: Lines under the table: what the shares leave, the indices not given and why.
    notes: tuple[str, ...] = ()

    @property
    def title(self) -> str:
        how = ESTIMATORS.get(self.estimator, "from the PCE coefficients")
        at = f" {self.at}" if self.at else ""
        return f"Error budget of {self.output}{at}, {self.label}: Sobol' indices {how}"


def correlated_groups(config: Mapping) -> tuple[list[tuple[str, ...]],
                                                dict[str, tuple[str, ...]]]:
    """A resolved config's correlated groups (input names, two or more) and its index groups
    (name -> input names: ``groups:``, else each correlated group named by its inputs)."""
    correlated = [tuple(c["inputs"]) for c in config.get("correlations") or []
                  if len(c["inputs"]) > 1]
    groups = config.get("groups")
    if groups is None:
        return correlated, {"+".join(c): c for c in correlated}
    return correlated, {name: tuple(m) for name, m in groups.items()}


def budget_table(s: OutputStatistics, inputs: list[str], component: int,
                 step: int | None = None, correlated: Sequence[Sequence[str]] = (),
                 members: Mapping[str, Sequence[str]] | None = None) -> pd.DataFrame | None:
    """The budget of one component of one output (at ``step`` of a series), ordered.

    ``correlated``: the correlated groups' input names; ``members``: each index group's (a
    group's row holds a share where it is a whole correlated group). Returns None where the
    method gave no index there (a step between report times).
    """
    if s.sobol_first is None:
        return None
    pick = (component,) if step is None else (step, component)
    first = np.asarray(s.sobol_first)[pick]
    if not np.isfinite(first).any():
        return None

    def at(a: np.ndarray | None, bounds: bool, size: int) -> np.ndarray:
        """``a`` at the component (and step), its bounds ``(2, size)`` with ``bounds``; NaN
        where the method has none."""
        if a is None:
            return np.full((2, size) if bounds else size, np.nan)
        return np.asarray(a)[(slice(None),) + pick] if bounds else np.asarray(a)[pick]

    ci, total, tci = (at(s.sobol_first_ci, True, first.size),
                      at(s.sobol_total, False, first.size), at(s.sobol_total_ci, True, first.size))
    grouped = {name for c in correlated for name in c}
    share = np.where([name in grouped for name in inputs], np.nan,
                     100.0 * np.clip(first, 0.0, None))
    df = pd.DataFrame({"input": inputs, "first_order": first, "ci_low": ci[0],
                       "ci_high": ci[1], "total": total, "total_low": tci[0],
                       "total_high": tci[1], "share_%": share})
    df = df.sort_values("first_order", ascending=False, kind="stable",
                        na_position="last").reset_index(drop=True)
    if s.sobol_group_first is not None and s.sobol_groups:
        gf = np.asarray(s.sobol_group_first)[pick]
        gci, gt, gtci = (at(s.sobol_group_first_ci, True, gf.size),
                         at(s.sobol_group_total, False, gf.size),
                         at(s.sobol_group_total_ci, True, gf.size))
        # a group overlaps its inputs' rows: listed after them, with a share only where its
        # inputs' rows have none (a whole correlated group)
        whole = {frozenset(c) for c in correlated}
        own = [frozenset((members or {}).get(g, ())) in whole for g in s.sobol_groups]
        groups = pd.DataFrame({"input": [f"group {g}" for g in s.sobol_groups],
                               "first_order": gf, "ci_low": gci[0], "ci_high": gci[1],
                               "total": gt, "total_low": gtci[0], "total_high": gtci[1],
                               "share_%": np.where(own, 100.0 * np.clip(gf, 0.0, None),
                                                   np.nan)})
        df = pd.concat([df, groups], ignore_index=True)
    return df


def budget_tables(result: Result, series_at_end: bool = False) -> list[BudgetTable]:
    """Every method's budget of every scalar output component (and, with ``series_at_end``,
    of every series at its last step), in the result's method and output order."""
    tables = []
    described = result_statistics(result)
    inputs = list(result.input_names)
    correlated, members = correlated_groups(result.config)
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
                df = budget_table(s, inputs, c, step, correlated, members)
                if df is None:
                    continue
                name = f"{o.name}[{comp}]" if comp else o.name
                one = ~df["input"].str.startswith("group ")
                estimator = s.sobol_estimator or "pce"
                tables.append(BudgetTable(
                    r.label, name, at, estimator, df, float(np.nansum(df["first_order"][one])),
                    budget_notes(df, name, estimator, correlated, members)))
    return tables


#: Why an estimator gives no index of one input of a correlated group.
NOT_ALONE = {
    "pce": "a PCE's terms in one input of a correlated group are an order-dependent part of it",
    "saltelli": "a pick-freeze design freezes a correlated group only whole",
}


def budget_notes(df: pd.DataFrame, output: str, estimator: str,
                 correlated: Sequence[Sequence[str]] = (),
                 members: Mapping[str, Sequence[str]] | None = None) -> tuple[str, ...]:
    """The lines under a budget: the shares' sum and what they leave, and the indices of a
    correlated group's inputs the estimator does not give (and why)."""
    share = df["share_%"].to_numpy(dtype=float)
    total = float(np.nansum(share))
    with_share = {frozenset((members or {}).get(row[len("group "):], ()))
                  for row, v in zip(df["input"], share)
                  if row.startswith("group ") and np.isfinite(v)}
    missing = ["+".join(c) for c in correlated if frozenset(c) not in with_share]
    rest = round(100.0 - total, 1) + 0.0  # no "-0.0"
    left = "interactions" if not missing else \
        (f"the joint part of correlated {', '.join(missing)} (no group index here) and "
         f"interactions")
    if rest < 0:
        left += " (below 0: the indices' estimation error)"
    notes = [f"shares sum to {total:.1f}% of the variance of {output}; the rest, {rest:.1f}%: "
             f"{left}"]
    first = dict(zip(df["input"], df["first_order"]))
    for c in correlated:
        none = [name for name in c if not np.isfinite(first.get(name, np.nan))]
        if none and estimator in NOT_ALONE:
            notes.append(f"{', '.join(none)}: no index alone ({NOT_ALONE[estimator]}); "
                         f"the group {'+'.join(c)}'s index holds them")
    if estimator == "pce":
        for name, cols in (members or {}).items():
            split = split_groups(correlated, cols)
            if split and f"group {name}" in first:
                notes.append(f"group {name}: no index (holds part of the correlated group "
                             f"{'+'.join(split[0])}; {NOT_ALONE['pce']})")
    return tuple(notes)


def budget_text(b: BudgetTable, max_rows: int = MAX_ROWS) -> str:
    """The console form of one budget: the largest ``max_rows`` inputs and the sum."""
    df = b.table
    groups = df[df["input"].str.startswith("group ")]
    df = df[~df["input"].str.startswith("group ")]
    shown = pd.concat([df.head(max_rows), groups], ignore_index=True)
    cols = _columns(shown, df, 3)
    for late in ("total", "total 95% interval"):  # (the console puts the totals last)
        if late in cols:
            cols[late] = cols.pop(late)
    lines = [b.title, pd.DataFrame(cols).to_string(index=False)]
    rest = len(df) - min(len(df), max_rows)
    if rest > 0:
        lines.append(f"  ... {rest} more inputs, first-order indices summing to "
                     f"{np.nansum(df['first_order'].iloc[max_rows:]):.3f}")
    lines += [f"  {n}" for n in b.notes]
    return "\n".join(lines)


def budget_markdown(b: BudgetTable) -> pd.DataFrame:
    """The Markdown report's form of one budget (every input)."""
    return pd.DataFrame(_columns(b.table, b.table, 4))


def _columns(shown: pd.DataFrame, df: pd.DataFrame, digits: int) -> dict[str, Any]:
    """The text columns of a budget's rows ``shown``: input, first-order index (``digits``
    decimals) and its interval, total index and its interval, share; an index's columns only
    where the rows ``df`` have it."""
    cols: dict[str, Any] = {"input": shown["input"],
                            "first-order": shown["first_order"].map(lambda v: _fmt(v, digits))}
    if np.isfinite(df["ci_low"]).any():
        cols["95% interval"] = [_interval(lo, hi)
                                for lo, hi in zip(shown["ci_low"], shown["ci_high"])]
    if np.isfinite(df["total"]).any():
        cols["total"] = shown["total"].map(lambda v: _fmt(v, digits))
    if np.isfinite(df["total_low"]).any():
        cols["total 95% interval"] = [_interval(lo, hi)
                                      for lo, hi in zip(shown["total_low"], shown["total_high"])]
    cols["share"] = shown["share_%"].map(lambda v: f"{v:.1f}%" if np.isfinite(v) else "")
    return cols


def _fmt(v: float, digits: int) -> str:
    return f"{v:.{digits}f}" if np.isfinite(v) else ""


def _interval(lo: float, hi: float) -> str:
    return f"[{lo:.3f}, {hi:.3f}]" if np.isfinite(lo) and np.isfinite(hi) else ""
