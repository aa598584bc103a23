"""The files a ``command`` model exchanges with its program: the batch's inputs written, its
outputs read back.

CSV (the default): ``inputs.csv`` (a header of the input names, values in ``repr`` precision),
``outputs.csv`` (scalar columns ``name`` or ``name[j]``, optional ``failed`` and ``reason``)
and one ``outputs_<name>.csv`` per series (time grid first). HDF5: ``inputs.h5`` and
``outputs.h5``, one dataset per input or output. A file that breaks the format is a
:class:`~uqguide.errors.ModelError` naming the file, the line (and its sample) and the column:
the program is wrong, not a sample, so the run stops. A file that is not a regular file, or is
larger than the batch can need (:data:`CELL_BYTES`), fails the call like a crash, unread. The
formats: ``docs/your-simulator.md#2-the-files``; the size bound:
``docs/your-simulator.md#the-size-of-an-outputs-file``.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
import stat
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from functools import partial
from itertools import repeat
from pathlib import Path
from typing import Any

import numpy as np

from ...core.csv_rows import RowFaults, floats, row_blocks
from ...core.types import ModelOutput
from ...errors import ModelError
from .process import CommandFailed, Deadline

#: Reason of a sample the program flagged with ``failed = 1`` and no ``reason``.
FLAGGED = "the command marked it failed"
NON_FINITE = "non-finite output value"

#: Bytes a cell of an outputs file may take: a double in full precision is at most 24
#: characters (``%.17g``, ``repr``; 26 in a Fortran ``ES26.17E3`` field), with its separator
#: 25-27; 64 leaves room for padding (derivation and figures: ``docs/your-simulator.md``).
CELL_BYTES = 64
#: Bytes a sample's row may take beyond its cells: its ``reason`` text, CR LF.
ROW_BYTES = 4096
#: Bytes the header line of an outputs CSV file may take: 5000 names of 200 characters.
HEADER_BYTES = 1 << 20
#: Time points a series may have (a 1 kHz series of 17 minutes), in either format; its CSV
#: grid line may take ``GRID_POINTS * CELL_BYTES`` bytes.
GRID_POINTS = 1 << 20
#: Bytes an HDF5 outputs file may take beyond its datasets' values: superblock, object
#: headers and indexes (a few kB per dataset).
HDF5_BYTES = 1 << 20


@dataclass(frozen=True)
class OutputSpec:
    """What is read for one output: its name, kind and number of components."""

    name: str
    kind: str
    components: int


def scalar_columns(spec: OutputSpec) -> list[str]:
    """CSV column names of a scalar output: ``name``, or ``name[j]`` per component."""
    if spec.components == 1:
        return [spec.name]
    return [f"{spec.name}[{j}]" for j in range(spec.components)]


def series_files(outputs: Path, spec: OutputSpec) -> list[Path]:
    """The CSV files of a series output beside the scalar outputs file ``outputs``
    (``.../outputs.csv``): ``<stem>_<name>.csv``, or ``<stem>_<name>_<j>.csv`` per component."""
    stem = outputs.with_suffix("").name
    if spec.components == 1:
        return [outputs.with_name(f"{stem}_{spec.name}.csv")]
    return [outputs.with_name(f"{stem}_{spec.name}_{j}.csv") for j in range(spec.components)]


# ---------------------------------------------------------------------------- inputs
def write_inputs(path: Path, names: Sequence[str], x: np.ndarray, fmt: str) -> None:
    """Write a batch's samples ``x (n, d)`` [SI] of the inputs ``names`` (plain names: they
    cannot break the CSV) to ``path`` (``inputs.csv`` or ``inputs.h5`` by ``fmt``)."""
    if fmt == "hdf5":
        import h5py

        with h5py.File(path, "w") as f:
            for j, name in enumerate(names):
                f.create_dataset(name, data=np.ascontiguousarray(x[:, j], dtype=np.float64))
        return
    path.write_text(inputs_csv(names, x), encoding="utf-8")


def inputs_csv(names: Sequence[str], x: np.ndarray) -> str:
    """The CSV text of samples ``x`` (n, d) under the header ``names``."""
    # repr is the shortest string that reads back as the same double: the program sees the
    # very sample uqguide drew, so results do not depend on the file format.
    row = ",".join(["%r"] * len(names))  # one format per row: half the time of a join
    lines = [",".join(names)]
    lines += [row % tuple(r) for r in x.astype(float).tolist()]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------- outputs
def read_outputs(path: Path, specs: Sequence[OutputSpec], n: int, fmt: str,
                 deadline: Deadline | None = None) -> ModelOutput:
    """Read the outputs ``specs`` of a batch of ``n`` samples the program wrote to ``path``
    (``outputs.csv`` or ``outputs.h5`` by ``fmt``), by the ``deadline`` if given; ``failed``
    holds the samples the program flagged, ``reasons`` why.

    Raises ModelError for a missing or short file, a missing or repeated column, a cell that is
    not a number (naming the file, the line and the column); CommandFailed for a file that is
    not a regular file, is larger than the batch can need or is not read by the deadline (the
    call fails, and its batch is split, as if the program had crashed).
    """
    got = _read_hdf5(path, specs, n) if fmt == "hdf5" else _read_csv(path, specs, n, deadline)
    if deadline is not None:
        deadline.check(f"reading {path.name}")
    return got


def _read_csv(path: Path, specs: Sequence[OutputSpec], n: int, deadline: Deadline | None
              ) -> ModelOutput:
    scalar_specs = [s for s in specs if s.kind == "scalar"]
    flagged = np.zeros(n, dtype=bool)
    reasons = np.full(n, "", dtype=object)
    scalars: dict[str, np.ndarray] = {}
    if scalar_specs or os.path.lexists(path):
        scalars, flagged, reasons = _read_scalar_csv(path, scalar_specs, n, deadline)
    series: dict[str, np.ndarray] = {}
    time: np.ndarray | None = None
    grid_file: Path | None = None
    for s in specs:
        if s.kind != "series":
            continue
        parts = []
        for f in series_files(path, s):
            t, values = _read_series_csv(f, n, flagged, deadline)
            if time is None:
                time, grid_file = t, f
            elif t.shape != time.shape or not np.array_equal(t, time):
                raise ModelError(f"{f}: line 1: the time grid differs from that of {grid_file} "
                                 f"(every series of a batch shares one grid)")
            parts.append(values)
        series[s.name] = np.stack(parts, axis=-1)
    return ModelOutput(time=np.zeros(0) if time is None else time, scalars=scalars,
                       series=series, failed=flagged, reasons=reasons)


def _open_regular(path: Path) -> int:
    """A descriptor of the program's file ``path``, opened without blocking (a FIFO's open
    waits for a writer) and refused unless it is a regular file."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) |
                     getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise ModelError(f"{path}: the command exited with status 0 but did not write this "
                         f"file") from None
    except OSError as exc:
        raise ModelError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = ("a FIFO (named pipe)" if stat.S_ISFIFO(mode) else "a folder" if
                    stat.S_ISDIR(mode) else "a socket" if stat.S_ISSOCK(mode) else "a device"
                    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "not a regular file")
            raise CommandFailed(f"{path}: the program left {kind} here, not a regular file of "
                                f"its outputs (refused unread: it could block for ever or never "
                                f"end)")
    except BaseException:
        os.close(fd)
        raise
    return fd


def _too_large(path: Path, size: int, limit: int, why: str) -> CommandFailed:
    return CommandFailed(f"{path}: {size:,} bytes, more than the {limit:,} a batch can need "
                         f"({why}); refused unread")


class _OutputsFile:
    """One outputs CSV file of the program, opened without blocking and refused unless it is a
    regular file; its first line read with a bound, then its rows, once the first line has
    said how wide they are and the file's size has been checked against what they can need
    (:meth:`rows`)."""

    def __init__(self, path: Path, deadline: Deadline | None) -> None:
        self.path, self.deadline = path, deadline
        fd = _open_regular(path)
        self.size = os.fstat(fd).st_size
        # utf-8-sig: a byte-order mark (Excel's "CSV UTF-8") is read as CSV readers do
        self._f = io.open(fd, "r", encoding="utf-8-sig", newline="")
        self._first = 0

    def __enter__(self) -> _OutputsFile:
        return self

    def __exit__(self, *exc: Any) -> None:
        self._f.close()

    def _read(self, size: int) -> str:
        try:
            return self._f.readline(size) if not self._first else self._f.read(size)
        except UnicodeDecodeError as exc:
            raise ModelError(f"{self.path}: not UTF-8 text ({exc.reason})") from None
        except OSError as exc:
            raise ModelError(f"{self.path}: cannot be read ({exc.strerror or exc})") from None

    def first_line(self, limit: int, what: str) -> str:
        """Line 1 (``what`` it holds), of at most ``limit`` characters."""
        text = self._read(limit + 1)
        if len(text) > limit:
            raise CommandFailed(f"{self.path}: line 1 is longer than the {limit:,} characters "
                                f"{what} may take; refused")
        self._first = max(1, len(text))
        return text

    def rows(self, n: int, width: int, first: str, what: str, block: int
             ) -> Iterator[tuple[int, list[list[str]]]]:
        """The ``n`` sample rows after line 1, which is ``first`` and says that they have
        ``width`` cells (``what`` has that many), in blocks of at most ``block`` rows (with the
        index of each block's first): the file may not be larger than they can take (refused
        unread), a line not longer, and no line may hold many more cells (refused before any
        is parsed). Empty trailing lines are dropped, a line of empty cells is a row (a failed
        sample's)."""
        line = width * CELL_BYTES + ROW_BYTES
        limit = self._first + n * line
        if self.size > limit:
            raise _too_large(self.path, self.size, limit,
                             f"{first}, then {n} row(s) of {width} cell(s) at {CELL_BYTES} "
                             f"bytes a cell and {ROW_BYTES} a row")
        text = self._read(limit - self._first + 1)
        if self._first + len(text) > limit:  # it grew since
            raise _too_large(self.path, self._first + len(text), limit, "while it was read")
        lines = partial(io.StringIO, text, newline="")  # each pass one line at a time, in C
        commas = 2 * width + ROW_BYTES  # a row's commas, and those of a quoted reason
        if text and (max(map(len, lines())) > line or
                     max(map(str.count, lines(), repeat(","))) >= commas):
            for k, ln in enumerate(lines(), start=2):
                if len(ln) > line:
                    raise CommandFailed(f"{self.path}: line {k} is longer than the {line:,} "
                                        f"characters a row of {width} cells may take; refused")
                if ln.count(",") >= commas:
                    raise ModelError(f"{self.path}: line {k}: {ln.count(',') + 1:,} cells or "
                                     f"more, line 1 has {width}")
        if self.deadline is not None:
            self.deadline.check(f"reading {self.path.name}")
        path = self.path

        def cells(k: int, r: list[str]) -> ModelError:
            missing = f": column {len(r) + 1} is missing" if len(r) < width else ""
            return ModelError(f"{path}: line {k} (sample {k - 2}): {len(r)} cells, {what} has "
                              f"{width}{missing}")

        def count(got: int, why: str) -> ModelError:
            return ModelError(f"{path}: {got} sample rows, expected {n} (one per sample, in "
                              f"order): {why}")

        faults = RowFaults(cells, lambda k: cells(k, []),
                           lambda more: count(more, f"line {n + 2} is one too many"),
                           lambda i: count(i, f"line {i + 2} (sample {i}) is missing"))
        reader = csv.reader(lines())
        del text, lines  # the reader's StringIO holds a copy: the text is not held twice
        try:
            yield from row_blocks(reader, width, n, block, faults)
        except csv.Error as exc:
            raise ModelError(f"{path}: line {reader.line_num + 1}: cannot be read as CSV "
                             f"({exc})") from None


def _not_a_number(path: Path, line: int, sample: int, col: int, name: str, cell: str
                  ) -> ModelError:
    return ModelError(f"{path}: line {line} (sample {sample}), column {col} '{name}': "
                      f"{cell!r} is not a number")


def _declared(columns: Iterable[str]) -> list[str]:
    """The ``outputs`` entries that declare a header's columns: ``y`` for ``y``, ``{name: y,
    components: k}`` for ``y[0] .. y[k-1]``, in the header's order."""
    counts: dict[str, int] = {}
    for c in columns:
        m = re.fullmatch(r"(.+)\[(\d+)\]", c)
        name, k = (m.group(1), int(m.group(2)) + 1) if m else (c, 0)
        counts[name] = max(counts.get(name, 0), k)
    return [f"{{name: {nm}, components: {k}}}" if k else nm for nm, k in counts.items()]


def _header(path: Path, f: _OutputsFile, specs: Sequence[OutputSpec]) -> list[str]:
    """The header's column names, each once, holding every column of ``specs``."""
    text = f.first_line(HEADER_BYTES, "a header")
    if not text.strip("\r\n"):
        raise ModelError(f"{path}: line 1: the file is empty; expected a header naming the "
                         f"columns {', '.join(c for s in specs for c in scalar_columns(s))}")
    try:
        header = [h.strip() for h in next(csv.reader([text]))]
    except csv.Error as exc:
        raise ModelError(f"{path}: line 1: cannot be read as CSV ({exc})") from None
    seen: dict[str, int] = {}
    for j, h in enumerate(header):
        if h and h in seen:
            raise ModelError(f"{path}: line 1: column {j + 1} '{h}' repeats column "
                             f"{seen[h] + 1}; each column is named once")
        seen[h] = j
    for s in specs:
        for c in scalar_columns(s):
            if c not in seen:
                others = _declared(h for h in header if h and h not in ("failed", "reason"))
                hint = (f"; the model's 'outputs' lists what the program writes (default "
                        f"[y]): for this header, outputs: [{', '.join(others)}]"
                        if others else "")
                raise ModelError(f"{path}: line 1: no column '{c}' in the header "
                                 f"{','.join(header)!r}{hint}")
    return header


def _read_scalar_csv(path: Path, specs: Sequence[OutputSpec], n: int,
                     deadline: Deadline | None
                     ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    with _OutputsFile(path, deadline) as f:
        header = _header(path, f, specs)
        body = [r for _, rows in f.rows(n, len(header), "a header", "the header", max(1, n))
                for r in rows]  # one block
    where = {h: j for j, h in enumerate(header)}
    flagged = np.zeros(n, dtype=bool)
    reasons = np.full(n, "", dtype=object)
    fcol, rcol = where.get("failed"), where.get("reason")
    if fcol is not None:
        for i, row in enumerate(body):
            cell = row[fcol].strip()
            if cell not in ("0", "1"):
                raise ModelError(f"{path}: line {i + 2} (sample {i}), column {fcol + 1} "
                                 f"'failed': {row[fcol]!r} is not 0 or 1")
            if cell == "1":
                flagged[i] = True
                reasons[i] = (body[i][rcol].strip() if rcol is not None else "") or FLAGGED
    table = {s.name: np.column_stack([_column(body, where[c], flagged, path, c)
                                      for c in scalar_columns(s)]).reshape(n, s.components)
             for s in specs}
    return table, flagged, reasons


def _column(body: list[list[str]], j: int, flagged: np.ndarray, path: Path, name: str
            ) -> np.ndarray:
    """Column ``j`` of the sample rows as floats; a flagged sample's empty cell is NaN."""
    return floats([row[j] for row in body],
                  lambda i, cell: _not_a_number(path, i + 2, i, j + 1, name, cell),
                  flagged.__getitem__)


def _grid(path: Path, f: _OutputsFile) -> np.ndarray:
    """The time grid on line 1 of a series file: finite, non-decreasing, at most
    :data:`GRID_POINTS`."""
    text = f.first_line(GRID_POINTS * CELL_BYTES, "a time grid")
    if not text.strip("\r\n"):
        raise ModelError(f"{path}: line 1: the file is empty; expected the time grid, then "
                         f"one row per sample")
    if text.count(",") >= GRID_POINTS:
        raise CommandFailed(f"{path}: line 1: a time grid of {text.count(',') + 1:,} points, "
                            f"more than the {GRID_POINTS:,} a series may have; refused")
    t = floats(next(csv.reader([text])),
               lambda j, cell: _not_a_number(path, 1, -1, j + 1, "time", cell))
    if t.size > 1 and not (np.all(np.isfinite(t)) and np.all(np.diff(t) >= 0)):
        raise ModelError(f"{path}: line 1: the time grid must be finite and non-decreasing")
    return t


def _series_rows(rows: list[list[str]], first: int, t: np.ndarray, flagged: np.ndarray,
                 path: Path) -> np.ndarray:
    """Rows ``first, first + 1, ...`` of a series file as floats; a flagged sample's empty
    cell is NaN."""
    def bad(k: int, cell: str) -> ModelError:
        i, j = divmod(k, t.size)
        return _not_a_number(path, first + i + 2, first + i, j + 1, f"t={t[j]:g}", cell)

    return floats(rows, bad, lambda k: flagged[first + k // t.size])


def _read_series_csv(path: Path, n: int, flagged: np.ndarray, deadline: Deadline | None
                     ) -> tuple[np.ndarray, np.ndarray]:
    with _OutputsFile(path, deadline) as f:
        t = _grid(path, f)
        values = np.empty((n, t.size))
        # blocks of about a million cells: the rows' text is never held whole as strings
        block = max(1, (1 << 20) // max(1, t.size))
        for i, rows in f.rows(n, t.size, "a time grid", "the time grid on line 1", block):
            values[i:i + len(rows)] = _series_rows(rows, i, t, flagged, path)
    return t, values


def _dataset(f: Any, name: str, path: Path) -> Any:
    """The dataset ``name`` of the open HDF5 file ``f``, not yet read."""
    import h5py

    if name not in f:
        raise ModelError(f"{path}: no dataset '{name}' (it has: {', '.join(sorted(f)) or 'none'})")
    ds = f[name]
    if not isinstance(ds, h5py.Dataset):
        raise ModelError(f"{path}: '{name}' is a group, not a dataset")
    return ds


def _claims(path: Path, f: Any, specs: Sequence[OutputSpec], n: int
            ) -> tuple[int, dict[str, tuple[int, ...]]]:
    """Check every dataset that will be read against the shape the batch needs, before any
    is read (a chunked dataset can claim terabytes in a file of kilobytes); returns the
    number of time points and the shape each output is read in."""
    shapes: dict[str, tuple[int, ...]] = {}
    T = 0
    if any(s.kind == "series" for s in specs):
        T = _dataset(f, "time", path).size
        if T > GRID_POINTS:
            raise CommandFailed(f"{path}: dataset 'time' has {T:,} points, more than the "
                                f"{GRID_POINTS:,} a series may have; refused unread")
    for name in ("failed", "reason"):
        if name in f and _dataset(f, name, path).size != n:
            ds = f[name]
            raise ModelError(f"{path}: dataset '{name}' must be ({n},), got shape {ds.shape}")
    if "reason" in f and f["reason"].dtype.itemsize > ROW_BYTES:
        raise ModelError(f"{path}: dataset 'reason' holds strings of "
                         f"{f['reason'].dtype.itemsize:,} bytes; at most {ROW_BYTES} allowed")
    for s in specs:
        ds = _dataset(f, s.name, path)
        if ds.dtype.kind not in "fiu":
            raise ModelError(f"{path}: dataset '{s.name}' is {ds.dtype}, not numbers")
        shape = (n, T, s.components) if s.kind == "series" else (n, s.components)
        drop = 2 if s.kind == "series" else 1
        if ds.shape != shape and not (ds.shape == shape[:drop] and s.components == 1):
            raise ModelError(f"{path}: dataset '{s.name}' has shape {ds.shape}, expected "
                             f"{shape} (samples{', time' if drop == 2 else ''}, components)")
        shapes[s.name] = shape
    return T, shapes


def _read_hdf5(path: Path, specs: Sequence[OutputSpec], n: int) -> ModelOutput:
    import h5py

    os.close(_open_regular(path))
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ModelError(f"{path}: cannot be read as HDF5 ({exc})") from None
    with f:
        T, shapes = _claims(path, f, specs, n)
        values = sum(math.prod(shape) for shape in shapes.values()) + T
        limit = HDF5_BYTES + values * CELL_BYTES + n * ROW_BYTES
        size = os.path.getsize(path)
        if size > limit:
            raise _too_large(path, size, limit, f"{values:,} values at {CELL_BYTES} bytes, "
                             f"{ROW_BYTES} a row and {HDF5_BYTES:,} for the file's own records")
        flagged = np.zeros(n, dtype=bool)
        reasons = np.full(n, "", dtype=object)
        if "failed" in f:
            raw = np.asarray(f["failed"][()]).reshape(-1)
            if not np.isin(raw, (0, 1)).all():
                raise ModelError(f"{path}: dataset 'failed' must be ({n},) of 0/1")
            flagged = raw.astype(bool)
            given = ([r.decode() if isinstance(r, bytes) else str(r)
                      for r in np.asarray(f["reason"][()]).reshape(-1)] if "reason" in f
                     else [""] * n)
            reasons[flagged] = [given[i].strip() or FLAGGED for i in np.flatnonzero(flagged)]
        got = {name: np.asarray(f[name][()]).astype(float).reshape(shape)
               for name, shape in shapes.items()}
        time = np.asarray(f["time"][()], dtype=float).reshape(-1) if T else np.zeros(0)
    return ModelOutput(time=time, failed=flagged, reasons=reasons,
                       scalars={s.name: got[s.name] for s in specs if s.kind == "scalar"},
                       series={s.name: got[s.name] for s in specs if s.kind == "series"})
