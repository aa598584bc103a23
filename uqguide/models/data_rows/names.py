"""The column names of a file of runs (or of arrays given to ``uqguide.fit``), checked before
any value is read: each is printable text of at most :data:`MAX_NAME_CHARS` characters (a
series' step ``name[j]`` adding its index), none twice, and a series' steps ``name[0]``,
``name[1]``, ... without gaps or repeats. A refusal is one line naming the file, where the
column is, the name and the rule; a byte-order mark is no part of a name (CSV readers strip
it from the start of the file, and so does :mod:`.files`), anywhere else it is refused.
"""

from __future__ import annotations

import re
import unicodedata
from collections.abc import Callable, Sequence

from ...errors import ConfigError

#: A column of one time step of a series: ``name[j]``.
STEP = re.compile(r"^(.+)\[(\d+)\]$")

#: The name of the time grid in a file (not an input or an output).
TIME = "time"

#: A run's status columns (neither inputs nor outputs): flagged failed (0/1), and why.
FAILED, REASON = "failed", "reason"

#: Longest column name (a series' step index not counted): the longest name uqguide can give an
#: input or an output (:data:`uqguide.core.names.PLAIN_NAME_RULE`).
MAX_NAME_CHARS = 200


def _unprintable(name: str) -> str | None:
    for ch in name:
        if not ch.isprintable():
            what = "byte-order mark" if ch == "\ufeff" else \
                unicodedata.name(ch, "control character").lower()
            return f"{what} U+{ord(ch):04X}"
    return None


def data_error(source: str, text: str) -> ConfigError:
    """The error of the data file ``source`` (as messages name it): ``data: <source>: <text>``."""
    return ConfigError(f"data: {source}: {text}", field="data")


def check_names(names: Sequence[str], source: str, where: Callable[[int], str]) -> None:
    """ConfigError when a column name is empty, unprintable, too long, repeated, or a series'
    steps have a gap or a repeat (module docstring). ``names`` are the columns in the file's
    order (blanks stripped), ``source`` the file as messages name it, ``where`` maps a column
    index to its place (``"line 1, column 3"``)."""
    def fail(j: int, text: str) -> ConfigError:
        return data_error(source, f"{where(j)}: {text}")

    seen: dict[str, int] = {}
    steps: dict[str, dict[int, int]] = {}
    for j, name in enumerate(names):
        if not name:
            raise fail(j, "empty column name")
        bad = _unprintable(name)
        if bad is not None:
            raise fail(j, f"column name {name!r} holds a {bad}; a column name is printable "
                          f"text")
        m = STEP.match(name)
        base = m.group(1) if m else name
        if len(base) > MAX_NAME_CHARS:
            raise fail(j, f"a column name of {len(base):,} characters ({name[:20]!r}...); "
                          f"allowed at most {MAX_NAME_CHARS}")
        if name in seen:
            raise fail(j, f"column {name!r} appears twice (also {where(seen[name])}); each "
                          f"column needs its own name")
        seen[name] = j
        if m:
            step = int(m.group(2))
            other = steps.setdefault(base, {}).get(step)
            if other is not None:
                raise fail(j, f"columns {names[other]!r} and {name!r} are both step {step} of "
                              f"series {base!r}")
            steps[base][step] = j
    for base, by_step in steps.items():
        if base in seen:
            raise data_error(source, f"column {base!r} and columns {base}[0], ... both present; "
                                     f"a name is either a scalar or a series")
        if len(by_step) != max(by_step) + 1:
            # the first absent step, found without building range(max + 1): an index such as
            # y[99999999999] must not allocate
            missing = next(k for k, s in enumerate(sorted(by_step)) if s != k)
            raise data_error(source, f"column {base}[{missing}] is missing (series {base!r} has "
                                     f"steps up to {base}[{max(by_step)}]; its columns must be "
                                     f"{base}[0], {base}[1], ... without gaps)")
