"""Names that become file names, HDF5 path components and table columns.

A method's label names its group in the result file and its rows in the tables; an output's name
names its HDF5 datasets and its figure files (``<name>_<output>.png``). A ``/`` in either is a new
HDF5 group and a new folder, ``.`` and ``..`` are folders already, and a name the plots cannot
turn into a file name leaves a result that ``uqguide plot`` and ``report`` cannot read. Such a
name is refused when the config is loaded, not met after the run.
"""

from __future__ import annotations

import re

#: Letters, digits, ``_``, ``.`` and ``-``; not only dots.
PLAIN_NAME = re.compile(r"^[A-Za-z0-9_.\-]{1,200}$")

PLAIN_NAME_RULE = ("1 to 200 letters, digits, '_', '.' or '-', not only dots (it names files, "
                   "HDF5 groups and table columns)")


def is_plain_name(name: object) -> bool:
    """Whether ``name`` may name a file, an HDF5 path component and a table column."""
    return isinstance(name, str) and bool(PLAIN_NAME.match(name)) and set(name) != {"."}


def check_plain_name(name: object) -> str:
    """``name`` unchanged if :func:`is_plain_name`, else ValueError (for pydantic validators)."""
    if not is_plain_name(name):
        raise ValueError(f"must be {PLAIN_NAME_RULE}")
    return name  # type: ignore[return-value]
