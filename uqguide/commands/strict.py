"""``--strict`` (or the config's ``strict: true``): a withheld statistic is a failed run.

A PCE withholds a moment where its surrogate is not usable or its own runs do not support the
value; the report then gives the Monte Carlo estimate of those runs (``+mc``), not the answer
the config asked for. With ``--strict`` that is exit 1 (the result and the tables are still
written). Only the points a report shows count (report times, a series' last step, scalars).
"""

from __future__ import annotations

from ..errors import UqguideError
from ..results.result import Result
from ..results.statistics import points, result_statistics

#: Withheld points named in the message before it says "and N more".
SHOWN = 4


def check_withheld(result: Result) -> None:
    """Raise UqguideError (exit 1) when any method withholds a moment at a reported point,
    naming the first :data:`SHOWN` and their count."""
    found = []
    for label, by_output in result_statistics(result).items():
        for v in by_output.values():
            for p in points(v.output, result.time, result.report_times):
                names = v.withheld_at(p.where)
                if not names:
                    continue
                where = "" if p.time is None else f" at t = {p.time:g} s"
                comp = f"[{p.name}]" if p.name else ""
                found.append((len(names), f"{label}: {v.output.name}{comp}{where} "
                                          f"({', '.join(names)})"))
    if not found:
        return
    total = sum(n for n, _ in found)
    shown = "; ".join(text for _, text in found[:SHOWN])
    more = f"; and {len(found) - SHOWN} more points" if len(found) > SHOWN else ""
    raise UqguideError(f"strict: {total} statistic(s) withheld, the Monte Carlo estimate of the "
                       f"method's own runs (+mc) given instead: {shown}{more}")
