"""The failed runs, tallied by reason: the rows of the table ``uqguide run`` prints under its
statistics (:func:`uqguide.report.tables.failure_table`), and the table it prints when every run of
a method failed (no statistics at all)."""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Iterable, Mapping
from typing import Any

#: Reasons listed per method; the rest are summed into one "other reasons" row.
MAX_REASONS = 5
COLUMNS = ["label", "runs", "failed", "share", "reason", "count"]


#: A detail of one run inside its reason (a ``command`` model's kept work folder): the runs are
#: tallied with it masked, or 20 samples failing alike would fill the table with 20 reasons of
#: count 1. The per-run reason keeps it (``RunResult.reasons``), where the user looks it up.
KEPT_FOLDER = re.compile(r"(work folder kept: )(\S+?)(?=[;)]|$)")
MASK = "one per run"


def reason_kind(reason: str) -> str:
    """``reason`` with its per-run details masked: the key failures are tallied by."""
    return KEPT_FOLDER.sub(lambda m: m.group(1) + MASK, reason)


def _tally(reasons: Iterable[object]) -> list[tuple[str, int]]:
    kinds: Counter[str] = Counter()
    first: dict[str, str] = {}
    for v in reasons:
        text = str(v) or "unknown"
        kind = reason_kind(text)
        kinds[kind] += 1
        first.setdefault(kind, text)
    rows = []
    for kind, count in kinds.most_common():
        detail = KEPT_FOLDER.search(first[kind])
        # a reason met once is shown as it is; one met often, masked, with its first run's
        rows.append((first[kind] if count == 1 or detail is None
                     else f"{kind} (first: {detail.group(2)})", count))
    return rows


def reason_rows(label: str, n_runs: int, reasons: Iterable[object]) -> list[dict[str, object]]:
    """Rows of one method's failures: ``reasons`` has one entry per failed run, tallied by
    :func:`reason_kind`."""
    tally = _tally(reasons)
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


def reason_summary(reasons: Iterable[object], limit: int = MAX_REASONS) -> str:
    """The failed runs' reasons on one line, tallied as the table tallies them (a ``command``
    model's 67 aborts in 67 kept work folders are one reason of count 67): ``"reason (count);
    ..."``, the ``limit`` most frequent, then ``"N other reasons (count)"``."""
    tally = _tally(reasons)
    shown = [f"{reason} ({count:,})" for reason, count in tally[:limit]]
    rest = tally[limit:]
    if rest:
        shown.append(f"{len(rest)} other reasons ({sum(c for _, c in rest):,})")
    return "; ".join(shown)


def render_reasons(label: str, n_runs: int, reasons: Iterable[object]) -> str:
    """The table of :func:`reason_rows` as text (for a method whose every run failed)."""
    import pandas as pd

    return pd.DataFrame(reason_rows(label, n_runs, reasons), columns=COLUMNS).to_string(
        index=False)


#: A method's diagnostics that hold the chance that a run fails and its 95% interval where
#: its runs are not a plain sample of the inputs (a PCE's stratified validation runs).
FAILED_SHARE = ("failed_share", "failed_share_low", "failed_share_high")


def failed_runs_line(label: str, method: str, n_runs: int, n_failed: int,
                     diagnostics: Mapping[str, Any] | None = None) -> str:
    """The one line that says a method's failed runs: their count, their share with its 95%
    Clopper-Pearson interval (the chance that a run of this model fails; from the
    ``diagnostics``' :data:`FAILED_SHARE` where they hold it, the runs weighted to the input
    distribution), and what the method's statistics then are. ``method``: its registered
    name (subset simulation counts a failed run outside its event; every other method's
    statistics are those of the runs that succeeded)."""
    from .events import clopper_pearson

    if diagnostics is not None and all(k in diagnostics for k in FAILED_SHARE):
        p, lo, hi = (float(diagnostics[k]) for k in FAILED_SHARE)
        # a handful of weighted runs puts the lower end at any small number: below 0.001%
        # its digits say nothing
        low = f"{100 * lo:.3g}" if 100 * lo >= 1e-3 else "<0.001"
        share = (f"{100 * p:.3g}% weighted to the input distribution, 95% interval "
                 f"{low}-{100 * hi:.3g}%")
    else:
        lo, hi = clopper_pearson(n_failed, n_runs)
        share = f"{100 * n_failed / n_runs:.3g}%, 95% interval {100 * lo:.3g}-{100 * hi:.3g}%"
    meaning = ("its probability counts them outside the event (not conditional on success)"
               if method == "subset_simulation" else
               "its statistics are conditional on success (the runs that failed are left out)")
    return f"{label}: {n_failed:,} of {n_runs:,} runs failed ({share}); {meaning}"
