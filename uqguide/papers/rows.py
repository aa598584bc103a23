"""A paper scenario's report: rows of the model's figures beside the paper's, and their text table
(``uqguide simulate``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["ReportRow", "format_report", "within"]


@dataclass(frozen=True)
class ReportRow:
    """One line of a nominal run's report: the model's figure ``value`` (a string for yes/no
    outcomes) beside the paper's (None where it gives none).

    ``quantity``: e.g. ``"time to 50 m"`` (``"GMM-NTSMC: ..."`` where a model reports several
    cases); ``tolerance``: the acceptance tolerance (``"1%"``, ``"not asserted"``); ``ok``:
    whether ``value`` is within it (None: not checked); ``note``: why a figure is not
    reproduced, or how it was computed. ``kind``: *reproducible* (moves by less than its
    tolerance when the inputs move by round-off), *chaotic* (it does not: ``value`` is the
    robust statistic ``statistic`` describes, :mod:`uqguide.models.roundoff`) or *timing* (wall
    time, never checked); docs/papers.md#reproducible-and-chaotic-figures.
    """

    quantity: str
    unit: str
    value: float | str
    paper: float | str | None = None
    tolerance: str = ""
    ok: bool | None = None
    note: str = ""
    kind: Literal["reproducible", "chaotic", "timing"] = "reproducible"
    statistic: str = ""


def within(value: float, paper: float, rel: float) -> bool:
    """Whether ``value`` is within the relative tolerance ``rel`` of the paper's figure."""
    return bool(abs(value - paper) <= rel * abs(paper))


def cell_text(v: object) -> str:
    """A report cell: 4 significant digits, scientific notation outside [1e-3, 1e5)."""
    if v is None:
        return "—"
    if isinstance(v, float):
        a = abs(v)
        return f"{v:.4g}" if (a == 0 or 1e-3 <= a < 1e5) else f"{v:.3e}"
    return str(v)


def format_report(model_name: str, rows: list[ReportRow]) -> str:
    """The nominal run's figures beside the paper's, as an aligned text table, then the robust
    statistics of chaotic rows and the rows' notes, wrapped to the console."""
    from ..report.tables import console_line  # pandas and the results: only when printing

    header = ("quantity", "unit", "model", "paper", "tolerance", "check", "kind")
    body = [(r.quantity, r.unit, cell_text(r.value), cell_text(r.paper), r.tolerance,
             {True: "ok", False: "MISS", None: "—"}[r.ok], r.kind) for r in rows]
    widths = [max(len(h), *(len(b[i]) for b in body)) if body else len(h)
              for i, h in enumerate(header)]
    fmt = "  ".join(f"{{:<{w}}}" for w in widths)
    lines = [f"Nominal run of model '{model_name}' beside the paper",
             *(fmt.format(*b).rstrip() for b in [header, ["-" * w for w in widths], *body])]
    chaotic = [(r.quantity, r.statistic) for r in rows if r.statistic]
    if chaotic:
        lines.append("")
        lines.append("chaotic rows (they move by more than their tolerance when the inputs move "
                     "by round-off) show a robust statistic:")
        lines += [console_line(f"robust — {q}: {s}") for q, s in chaotic]
    notes = [(r.quantity, r.note) for r in rows if r.note]
    if notes:
        lines.append("")
        lines += [console_line(f"note — {q}: {n}") for q, n in notes]
    return "\n".join(lines)
