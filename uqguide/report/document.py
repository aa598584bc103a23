"""The Markdown report of a result: tables of :mod:`uqguide.report.tables` and the figures of
:mod:`uqguide.report.plots`, in one document an engineer reads after a run.

Sections: the uncertain inputs; the methods' cost (table and figure); per output its figure and
its statistics at the report times beside the reference method's, with the reference's 95%
interval; the agreement of each series with the reference over the whole grid; the error
budget (Sobol' indices of every method that gives them, tables and figures over time);
optionally the regression check against a baseline; and the provenance
(versions and the resolved config).
"""

from __future__ import annotations

import logging
import os
import re
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import pandas as pd
import yaml

from ..core import atomic
from ..core.failures import failed_runs_line
from .budget import budget_markdown, budget_tables
from .plots import FigureFile, write_figures
from .tables import (
    cost_table, cost_units, events_table, events_text, requirements_table, requirements_text,
    series_agreement, statistics_table, to_markdown, wide_table,
)
from ..results.result import Result

log = logging.getLogger(__name__)


class CheckReport(Protocol):
    """What the report shows of a regression check (:class:`uqguide.gate.check.CheckReport`); a
    protocol, so that the report, which the gate's verdict is shown in, does not import it."""

    notes: list[str]

    @property
    def failures(self) -> list[Any]: ...
    def summary(self) -> str: ...
    def to_frame(self) -> pd.DataFrame: ...

_DIST_PARAMS = ("mean", "std", "low", "high", "mu", "sigma")


def _inputs_table(result: Result) -> pd.DataFrame:
    rows = []
    for spec in result.config.get("inputs", []) or []:
        params = ", ".join(f"{k} {spec[k]:g}" for k in _DIST_PARAMS
                           if isinstance(spec.get(k), (int, float)))
        rows.append({"input": spec.get("name", ""), "distribution": spec.get("dist", ""),
                     "parameters (SI)": params})
    return pd.DataFrame(rows)


def _img(path: Path, base: Path, alt: str) -> str:
    rel = Path(os.path.relpath(path, base)).as_posix()
    return f"![{alt}]({rel})"


def render_report(result: Result, figures: list[FigureFile], base: Path,
                  check: CheckReport | None = None) -> str:
    """The Markdown text; figure links are relative to the folder ``base`` of the report."""
    created = result.provenance.get("created_utc", "")
    versions = result.provenance.get("versions", {})
    with_ref = result.reference is not None and len(result.runs) > 1
    parts = [
        f"# {result.name}: uncertainty propagation report", "",
        f"Model `{result.model}`; {len(result.input_names)} uncertain inputs; methods "
        + ", ".join(f"`{r.label}` ({r.estimate.method}, {r.n_runs} runs)" for r in result.runs)
        + f"; seed {result.config.get('seed', '?')}; run {created} with uqguide "
        f"{versions.get('uqguide', '?')}."
        + (f" Reference method: `{result.reference}`." if result.reference else ""),
    ]
    if result.config.get("description"):
        parts += ["", str(result.config["description"]).strip()]
    inputs = _inputs_table(result)
    if not inputs.empty:
        parts += ["", "## Uncertain inputs", "", to_markdown(inputs)]
    cost = cost_table(result)
    parts += ["", "## Methods and cost", "", cost_units(cost) + ".", "", to_markdown(cost)]
    for f in figures:
        if f.kind == "cost":
            parts += ["", _img(f.path, base, "cost of each method")]
    for r in result.runs:
        if r.success and r.n_failed:
            why = r.estimate.diagnostics.get("failure_reasons")
            parts += ["", failed_runs_line(r.label, r.estimate.method, r.n_runs, r.n_failed,
                                           r.estimate.diagnostics)
                      + (f" ({why})." if why else ".")]
    stats = statistics_table(result)
    parts += ["", "## Outputs", "",
              "Statistics are the population (1/n) moments; kurtosis is non-excess (a Gaussian "
              "has 3). Table cells: estimate [95% interval]"
              + (" (difference from the reference; in: within the 95% interval of the "
                 "difference, both estimates' errors combined; OUT: beyond it)." if with_ref
                 else ".")]
    for o in result.outputs:
        sub = stats[stats["output"] == o.name] if not stats.empty else stats
        if sub.empty:
            continue
        kind = "time series" if o.kind == "series" else "scalar"
        parts += ["", f"### {o.name} [{o.unit}] ({kind})", "", o.description]
        for f in figures:
            if f.output == o.name and f.kind != "budget":  # (in the budget section)
                alt = f"{o.name} {f.component}".strip()
                parts += ["", _img(f.path, base, alt)]
        head = "Statistics at the report times and the last step:" if o.kind == "series" \
            else "Statistics:"
        parts += ["", head, "", to_markdown(wide_table(sub, with_ref))]
    events = events_table(result)
    if not events.empty:
        parts += ["", "## Events", "", "Probability of each event with its 95% interval "
                  "(Clopper-Pearson over model runs; for a PCE over its surrogate draws only: "
                  "the surrogate's own error is not in it; subset simulation: lognormal from "
                  "its CoV upper bound, in / used = its final level).", "",
                  to_markdown(events_text(events))]
    verdicts = requirements_table(result)
    if not verdicts.empty:
        parts += ["", "## Requirements", "", "Each requirement's verdict by each method: pass "
                  "when the one-sided lower bound of the success probability at its confidence "
                  "reaches the requirement, fail when the upper bound is below it "
                  "(docs/requirements.md).",
                  "", to_markdown(requirements_text(verdicts, result))]
    agree = series_agreement(result)
    if not agree.empty:
        parts += ["", f"## Series over the whole grid against `{result.reference}`", "",
                  "Largest relative difference of the mean and the std over time (steps where "
                  "the reference is below 1e-3 of its peak are left out), and when it occurs.",
                  "", to_markdown(agree)]
    budgets = budget_tables(result, series_at_end=True)
    if budgets:
        parts += ["", "## Error budget (Sobol' indices)", "",
                  "First-order index of each input: the fraction of the output's variance its "
                  "uncertainty alone explains, with its 95% interval where the method gives "
                  "one; share: that fraction in percent, for each input outside a correlated "
                  "group and each correlated group (whose inputs' indices overlap); total "
                  "(PCE, Saltelli): with all its interactions."]
        for f in figures:
            if f.kind == "budget":
                alt = f"error budget of {f.output} {f.component}".strip()
                parts += ["", _img(f.path, base, alt)]
        for b in budgets:
            parts += ["", f"{b.title}:", "", to_markdown(budget_markdown(b)), ""]
            parts += [f"{n[0].upper()}{n[1:]}." for n in b.notes]
    if check is not None:
        parts += ["", "## Regression check", "", check.summary()]
        rows = check.failures
        if rows:
            df = check.to_frame()
            df = df[~df["passed"]][["quantity", "unit", "value", "baseline", "difference",
                                    "tolerance", "basis", "note"]]
            parts += ["", to_markdown(df)]
        if check.notes:
            parts += [""] + [f"- {n}" for n in check.notes]
    parts += ["", "## Provenance", "",
              to_markdown(pd.DataFrame([{"package": k, "version": v}
                                        for k, v in versions.items()])),
              "", f"The whole run took "
              f"{float(result.provenance.get('wall_seconds', np.nan)):.3g} s wall.",
              "", "Resolved config (every default filled in):", "", "```yaml",
              yaml.safe_dump(result.config, sort_keys=False).rstrip(), "```"]
    return "\n".join(parts) + "\n"


def write_report(result: Result, out_dir: str | Path, check: CheckReport | None = None,
                 figure_dir: str | Path | None = None) -> tuple[Path, list[FigureFile]]:
    """Write the figures (into ``figure_dir``, default ``out_dir/figures``) and
    ``<name>_report.md`` into ``out_dir``, with the regression ``check`` when given; return the
    report and the figures it embeds."""
    out = Path(out_dir)
    atomic.make_folder(out)
    figures = write_figures(result, Path(figure_dir) if figure_dir else out / "figures")
    name = re.sub(r"[^A-Za-z0-9_.-]+", "_", result.name).strip("_.") or "result"
    path = atomic.write_text(out / f"{name}_report.md", render_report(result, figures, out, check))
    log.info("wrote %s", path)
    return path, figures
