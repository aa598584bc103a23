"""The work folders a ``command`` model's runs left: those of failed calls (kept to look into)
and of calls killed with their process. ``uqguide clean`` lists and removes them.

A folder counts as one only when it is uqguide's beyond doubt: named ``batch-<pid>-<8
letters>`` as :func:`tempfile.mkdtemp` made it, a real folder (not a link), holding the
inputs file of a call (``inputs.csv``/``inputs.h5``, or a ``per_sample`` call's
``sample-<i>`` folders), and of a process that is gone (a running call's stays).
"""

from __future__ import annotations

import re
import shutil
from dataclasses import dataclass
from pathlib import Path

from ...core.atomic import pid_alive

_NAME = re.compile(r"batch-(\d+)-[A-Za-z0-9_]{8}")


@dataclass(frozen=True)
class Leftover:
    path: Path
    size: int  # bytes of its files


def leftovers(root: Path) -> list[Leftover]:
    """The work folders in ``root`` that a finished run left (module docstring), by name."""
    found = []
    try:
        entries = sorted(root.iterdir())
    except OSError:
        return []
    for p in entries:
        m = _NAME.fullmatch(p.name)
        if m is None or p.is_symlink() or not p.is_dir() or pid_alive(int(m.group(1))):
            continue
        inside = {c.name for c in p.iterdir()}
        if not ({"inputs.csv", "inputs.h5"} & inside or any(
                re.fullmatch(r"sample-\d+", c) for c in inside)):
            continue
        size = sum(f.stat().st_size for f in p.rglob("*") if f.is_file() and not f.is_symlink())
        found.append(Leftover(p, size))
    return found


def remove(found: list[Leftover]) -> None:
    """Remove the folders :func:`leftovers` found."""
    for f in found:
        shutil.rmtree(f.path, ignore_errors=True)
