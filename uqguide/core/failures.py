"""The failed runs, tallied by reason: the rows of the table ``uqguide run`` prints under its
statistics (:func:`uqguide.report.tables.failure_table`), and the table it prints when every run of
a method failed (no statistics at all)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable

#: Reasons listed per method; the rest are summed into one "other reasons" row.
MAX_REASONS = 5
COLUMNS = ["label", "runs", "failed", "share", "reason", "count"]


def reason_rows(label: str, n_runs: int, reasons: Iterable[object]) -> list[dict[str, object]]:
    """Rows of one method's failures: ``reasons`` has one entry per failed run."""
    tally = Counter(str(v) or "unknown" for v in reasons).most_common()
    n_failed = sum(c for _, c in tally)
    shown, rest = tally[:MAX_REASONS], tally[MAX_REASONS:]
    if rest:
        shown.append((f"{len(rest)} other reasons", sum(c for _, c in rest)))
    rows = []
    for i, (reason, count) in enumerate(shown):
        first = i == 0
        rows.append({"label": label if first else "", "runs": str(n_runs) if first else "",
                     "failed": str(n_failed) if first else "",
                     "share": f"{100 * n_failed / max(n_runs, 1):.3g}%" if first else "",
                     "reason": reason, "count": count})
    return rows


def render_reasons(label: str, n_runs: int, reasons: Iterable[object]) -> str:
    """The table of :func:`reason_rows` as text (for a method whose every run failed)."""
    import pandas as pd

    return pd.DataFrame(reason_rows(label, n_runs, reasons), columns=COLUMNS).to_string(
        index=False)
