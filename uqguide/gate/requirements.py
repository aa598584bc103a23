"""The requirements gate: a result's verdicts as an exit status (``uqguide check RESULT
--requirements``, ``uqguide run --check-requirements``): 1 on any ``fail``, 0 when every
verdict passes, ``undecided`` as the caller says; docs/requirements.md#the-gate.
"""

from __future__ import annotations

from typing import Literal

from ..errors import ResultError
from ..results.result import Result
from ..stats.verdicts import Verdict

#: What an ``undecided`` verdict counts as, by default: not shown to hold.
UNDECIDED_DEFAULT = "fail"


def blocking_verdicts(result: Result, undecided: Literal["pass", "fail"] = "fail"
                      ) -> list[Verdict]:
    """The verdicts that fail the gate, in method and requirement order; ResultError when the
    result holds none (its config has no requirements, or a file from before them)."""
    verdicts = [v for r in result.runs for v in r.verdicts.values()]
    if not verdicts:
        raise ResultError("the result holds no requirement verdicts (its config lists no "
                          "requirements)")
    bad = ("fail",) if undecided == "pass" else ("fail", "undecided")
    return [v for v in verdicts if v.verdict in bad]


def gate_lines(blocking: list[Verdict], n_verdicts: int) -> list[str]:
    """One line per blocking verdict, then the summary line."""
    lines = [f"{v.label}: {v.requirement} {v.verdict.upper()} (estimate {v.estimate:.6g}, "
             f"bounds [{v.lower:.6g}, {v.upper:.6g}], {v.runs:,} runs; {v.basis})"
             for v in blocking]
    lines.append(f"requirements: {n_verdicts - len(blocking)} of {n_verdicts} verdicts pass "
                 f"the gate" + ("" if blocking else " - OK"))
    return lines
