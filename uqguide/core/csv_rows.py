"""The one reader of a CSV file's rows, for the ``command`` model's outputs files and for
``data:`` files: lines read within a bound (:func:`bounded_lines`), rows of a fixed width taken
a block at a time, blank lines and too few or too many rows refused (:func:`row_blocks`), cells
converted to float64 as Python's ``float`` reads them (:func:`floats`). Each caller words the
refusals its own way (:class:`RowFaults`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import TextIO, cast

import numpy as np


def bounded_lines(f: TextIO, limit: int, too_long: Callable[[int], Exception], line: int = 1
                  ) -> Iterator[str]:
    """The lines of ``f`` from its position (the first is ``line``), each of at most ``limit``
    characters with its line end; ``too_long(line)`` is raised for a longer one, having read
    only ``limit + 1`` of its characters."""
    while text := f.readline(limit + 1):
        if len(text) > limit:
            raise too_long(line)
        yield text
        line += 1


@dataclass(frozen=True)
class RowFaults:
    """How a caller words each refusal of :func:`row_blocks` (each returns what is raised):
    ``width(line, row)`` a row of another width, ``blank(line)`` a blank line with rows after
    it, ``extra(rows)`` a row past the most allowed (``rows``: the rows up to the last line that
    is not blank), ``short(rows)`` fewer rows than the most (None: allowed)."""

    width: Callable[[int, list[str]], Exception]
    blank: Callable[[int], Exception]
    extra: Callable[[int], Exception]
    short: Callable[[int], Exception] | None = None


def row_blocks(records: Iterable[list[str]], width: int, most: int, block: int,
               faults: RowFaults, blank: Callable[[list[str]], bool] = lambda r: not r,
               check: Callable[[list[str], int], None] | None = None
               ) -> Iterator[tuple[int, list[list[str]]]]:
    """The rows of ``records`` (parsed CSV lines after line 1, so the first is line 2), each of
    ``width`` cells, at most ``most``, in blocks of at most ``block`` rows with the index of
    each block's first. ``blank`` says which records are blank lines: those at the end are
    dropped, any other is refused. ``check(row, line)`` raises to refuse a row. A block is
    emptied when the next is asked for."""
    rows: list[list[str]] = []
    taken, gap = 0, 0  # gap: the line of the first blank line since the last row
    records = iter(records)
    for line, r in enumerate(records, start=2):
        if blank(r):
            gap = gap or line
            continue
        if taken == most:
            last = line
            for after, r in enumerate(records, start=line + 1):
                last = last if blank(r) else after
            raise faults.extra(last - 1)
        if gap:
            raise faults.blank(gap)
        if len(r) != width:
            raise faults.width(line, r)
        if check is not None:
            check(r, line)
        rows.append(r)
        taken += 1
        if len(rows) == block or taken == most:  # a full block is read before what follows
            yield taken - len(rows), rows
            rows.clear()  # its strings freed before the next block's are read
    if rows:
        yield taken - len(rows), rows
    if taken < most and faults.short is not None:
        raise faults.short(taken)


def floats(cells: list[str] | list[list[str]], bad: Callable[[int, str], Exception],
           empty: Callable[[int], bool] | None = None) -> np.ndarray:
    """``cells`` (or rows of them) as float64, each read as Python's ``float`` does (blanks
    around it ignored); an empty cell is NaN where ``empty(i)`` holds, and ``bad(i, cell)`` is
    raised for the first other cell that is not a number (``i`` counts the cells row by row,
    ``cell`` stripped)."""
    try:
        return np.array(cells, dtype=float)  # one conversion, in C
    except ValueError:
        pass
    rows = bool(cells) and isinstance(cells[0], list)
    flat = [c for r in cells for c in r] if rows else cast("list[str]", cells)
    out = np.empty(len(flat))
    for i, c in enumerate(flat):
        cell = c.strip()
        if not cell and empty is not None and empty(i):
            out[i] = np.nan
            continue
        try:
            out[i] = float(cell)
        except ValueError:
            raise bad(i, cell) from None
    return out.reshape(len(cells), -1) if rows else out
