"""The failed runs of a result, tallied by method and reason (printed by ``uqguide run``)."""

from __future__ import annotations

from collections import Counter
from typing import TYPE_CHECKING

import pandas as pd

if TYPE_CHECKING:
    from .result import Result

#: Reasons listed per method; the rest are summed into one "other reasons" row.
MAX_REASONS = 5


def failure_table(result: Result) -> pd.DataFrame:
    """One row per method and failure reason: label, runs, failed, share, reason, count.

    Empty when no run failed.
    """
    rows = []
    for r in result.runs:
        if not r.n_failed:
            continue
        tally = Counter(str(v) or "unknown" for v in r.reasons[r.failed]).most_common()
        shown, rest = tally[:MAX_REASONS], tally[MAX_REASONS:]
        if rest:
            shown.append((f"{len(rest)} other reasons", sum(c for _, c in rest)))
        for i, (reason, count) in enumerate(shown):
            first = i == 0
            rows.append({"label": r.label if first else "",
                         "runs": str(r.n_runs) if first else "",
                         "failed": str(r.n_failed) if first else "",
                         "share": f"{100 * r.n_failed / max(r.n_runs, 1):.3g}%" if first else "",
                         "reason": reason, "count": count})
    return pd.DataFrame(rows, columns=["label", "runs", "failed", "share", "reason", "count"])
