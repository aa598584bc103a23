"""A file of runs read into named columns: one row per run, a column per input and per scalar
output, a series as the columns ``name[0]``, ``name[1]``, ... (one per time step) or, in HDF5
and ``.npz``, one dataset ``(n, T)``.

Formats, chosen by the file's suffix:

``.csv``
    A header of column names, then one row per run; an empty cell or ``nan`` is NaN.
``.parquet``
    Read with pandas (needs ``pyarrow`` or ``fastparquet``: an optional dependency).
``.h5`` / ``.hdf5``
    A dataset per column at the file's top level: ``(n,)`` for an input or a scalar output,
    ``(n, T)`` for a series.
``.npz``
    The same, as NumPy arrays (``numpy.savez``).

A series' time grid [s] is the ``time`` dataset or array of an HDF5 or ``.npz`` file (a CSV
holds runs only), else the config's ``data.time``, else the step numbers ``0, 1, ..., T-1``.

A run that failed is a row of NaN (or empty) outputs after its inputs, or a row flagged in the
optional ``failed`` column (0/1; empty is 0) with its ``reason`` (text; optional): the columns a
``command`` model's outputs file has, so the batch runner a user already has can say why a run
failed, and the failed-runs table shows it. Neither is an input or an output.

Everything here reads and names; what the rows must satisfy against the config's inputs is
:mod:`.checks`. A file that cannot be read is a :class:`~uqguide.errors.ConfigError` naming
the file (and the line and column where a cell is not a number): it is the user's input.
"""

from __future__ import annotations

import csv
import hashlib
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import ConfigError

#: The file suffixes read, by format.
SUFFIXES = {".csv": "csv", ".parquet": "parquet", ".h5": "hdf5", ".hdf5": "hdf5",
            ".npz": "npz"}

#: A column of one time step of a series: ``name[j]``.
_STEP = re.compile(r"^(.+)\[(\d+)\]$")

#: The name of the time grid in a file (not an input or an output).
TIME = "time"

#: A run's status columns (neither inputs nor outputs): flagged failed (0/1), and why.
FAILED, REASON = "failed", "reason"

#: How messages (and a stored config) name runs given from Python rather than read from a file.
ARRAYS = "<arrays>"


@dataclass(frozen=True, eq=False)
class Table:
    """The runs of a file, as named columns.

    Attributes
    ----------
    source : str
        The file's path as the config gives it, or ``"<arrays>"`` for data from Python.
    columns : dict of str to ndarray
        ``(n,)`` per plain column, ``(n, T)`` per series; float64.
    time : ndarray or None
        The file's time grid ``(T,)`` [s], when it has one.
    first_line : int
        The file line of row 0 (2 for a CSV with its header; 0: the file has no lines and a
        row is named by its number alone).
    digest : str
        SHA-256 of the columns' names and values (a run's identity: another file, another run).
    flagged : ndarray of bool or None
        ``(n,)``: the rows the ``failed`` column marks, when the file has one.
    reasons : ndarray of str or None
        ``(n,)``: the ``reason`` column ("" where empty), when the file has one.
    """

    source: str
    columns: dict[str, np.ndarray]
    time: np.ndarray | None = None
    first_line: int = 0
    digest: str = field(default="")
    flagged: np.ndarray | None = None
    reasons: np.ndarray | None = None

    @property
    def n_rows(self) -> int:
        return int(next(iter(self.columns.values())).shape[0]) if self.columns else 0

    def where(self, row: int) -> str:
        """Row ``row`` (0-based) as a user finds it: ``row 5 (line 6)`` of a CSV, ``row 5``
        otherwise (rows counted from 1, as spreadsheets and editors do)."""
        text = f"row {row + 1}"
        return f"{text} (line {row + self.first_line})" if self.first_line else text

    def column_names(self) -> list[str]:
        """Every column as the file names it (a series' steps as ``name[j]``)."""
        out: list[str] = []
        for k, v in self.columns.items():
            out += [k] if v.ndim == 1 else [f"{k}[{j}]" for j in range(v.shape[1])]
        return out


def _digest(columns: Mapping[str, np.ndarray], time: np.ndarray | None,
            flagged: np.ndarray | None = None, reasons: np.ndarray | None = None) -> str:
    h = hashlib.sha256()
    for k in sorted(columns):
        a = np.ascontiguousarray(columns[k], dtype=float)
        h.update(repr((k, a.shape)).encode())
        h.update(a.tobytes())
    if time is not None:
        h.update(np.ascontiguousarray(time, dtype=float).tobytes())
    # status columns only when present: a file without them keeps the digest it always had
    if flagged is not None:
        h.update(b"failed" + flagged.astype(np.uint8).tobytes())
    if reasons is not None:
        h.update(repr(("reason", list(reasons))).encode())
    return h.hexdigest()


def _flags(raw: np.ndarray, source: str, first_line: int) -> np.ndarray:
    """The ``failed`` column as booleans: 0, 1 or empty (NaN, read as 0) only."""
    bad = ~(np.isnan(raw) | (raw == 0) | (raw == 1))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        line = f" (line {i + first_line})" if first_line else ""
        raise ConfigError(f"data: {source}: row {i + 1}{line}, column 'failed': {raw[i]:g} is "
                          f"not 0 or 1 (1 marks a run that failed; 0 or empty, one that ran)")
    return raw == 1


def _text(values: Any) -> np.ndarray:
    """A column of text (bytes from HDF5 decoded; missing values as "")."""
    out = np.empty(len(values), dtype=object)
    for i, v in enumerate(values):
        v = v.decode("utf-8", "replace") if isinstance(v, bytes) else v
        out[i] = "" if v is None or (isinstance(v, float) and np.isnan(v)) else str(v).strip()
    return out


def _group_series(flat: dict[str, np.ndarray], source: str) -> dict[str, np.ndarray]:
    """Plain columns kept, the ``name[j]`` columns of each series stacked into ``(n, T)``."""
    plain: dict[str, np.ndarray] = {}
    steps: dict[str, dict[int, np.ndarray]] = {}
    for name, v in flat.items():
        m = _STEP.match(name)
        if m is None:
            plain[name] = v
        else:
            steps.setdefault(m.group(1), {})[int(m.group(2))] = v
    for name, by_step in steps.items():
        if name in plain:
            raise ConfigError(f"data: {source}: column {name!r} and columns {name}[0], ... both "
                              f"present; a name is either a scalar or a series")
        missing = sorted(set(range(max(by_step) + 1)) - set(by_step))
        if missing:
            raise ConfigError(f"data: {source}: column {name}[{missing[0]}] is missing (series "
                              f"{name!r} has steps up to {name}[{max(by_step)}]; its columns "
                              f"must be {name}[0], {name}[1], ... without gaps)")
        plain[name] = np.column_stack([by_step[j] for j in range(len(by_step))])
    return plain


def _read_csv(path: Path, source: str) -> tuple[dict[str, np.ndarray], int]:
    try:
        with path.open(newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except UnicodeDecodeError as exc:
        raise ConfigError(f"data: {source}: not a text CSV file ({exc.reason})") from None
    if not rows or not any(cell.strip() for cell in rows[0]):
        raise ConfigError(f"data: {source}: empty file; the first line must name the columns")
    header = [c.strip() for c in rows[0]]
    for j, name in enumerate(header):
        if not name:
            raise ConfigError(f"data: {source}: line 1, column {j + 1}: empty column name")
        if header.index(name) != j:
            raise ConfigError(f"data: {source}: line 1: column {name!r} appears twice")
    body = [r for r in rows[1:] if any(cell.strip() for cell in r)]
    lines = [i + 2 for i, r in enumerate(rows[1:]) if any(cell.strip() for cell in r)]
    if lines != list(range(2, 2 + len(body))):
        blank = next(i for i, ln in enumerate(lines, start=2) if ln != i)
        raise ConfigError(f"data: {source}: line {blank}: blank line inside the data (a run's "
                          f"outputs that failed are a row of NaN or empty cells after its "
                          f"inputs)")
    flat: dict[str, np.ndarray] = {}
    for i, r in enumerate(body):
        if len(r) != len(header):
            raise ConfigError(f"data: {source}: line {i + 2}: {len(r)} cells, the header names "
                              f"{len(header)} columns")
    for j, name in enumerate(header):
        if name == REASON:
            flat[name] = _text([r[j] for r in body])
            continue
        cells = [r[j].strip() or "nan" for r in body]
        try:
            flat[name] = np.array(cells, dtype=float)
        except ValueError:
            i = next(i for i, c in enumerate(cells) if not _is_number(c))
            raise ConfigError(f"data: {source}: row {i + 1} (line {i + 2}), column {name!r}: "
                              f"{cells[i]!r} is not a number") from None
    return flat, 2


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _read_parquet(path: Path, source: str) -> dict[str, np.ndarray]:
    import pandas as pd

    try:
        frame = pd.read_parquet(path)
    except ImportError as exc:
        raise ConfigError(f"data: {source}: reading Parquet needs pyarrow or fastparquet, "
                          f"which are not installed ({exc}); pip install pyarrow, or save the "
                          f"runs as CSV, HDF5 or .npz") from None
    return _numeric_frame(frame, source)


def _numeric_frame(frame: Any, source: str) -> dict[str, np.ndarray]:
    flat = {}
    for name in frame.columns:
        if str(name) == REASON:
            flat[REASON] = _text(frame[name].tolist())
            continue
        try:
            flat[str(name)] = frame[name].to_numpy(dtype=float, na_value=np.nan)
        except (TypeError, ValueError):
            col = frame[name]
            bad = next(i for i, v in enumerate(col) if not _is_number(str(v)))
            raise ConfigError(f"data: {source}: row {bad + 1}, column {str(name)!r}: "
                              f"{col.iloc[bad]!r} is not a number") from None
    return flat


def _read_arrays(items: Mapping[str, Any], source: str) -> dict[str, np.ndarray]:
    out = {}
    for name, a in items.items():
        if str(name) == REASON:
            out[REASON] = _text(np.asarray(a).reshape(-1).tolist())
            continue
        try:
            arr = np.asarray(a, dtype=float)
        except (TypeError, ValueError):
            raise ConfigError(f"data: {source}: column {name!r} is not numeric") from None
        if arr.ndim not in (1, 2) and not (name == TIME and arr.ndim == 1):
            raise ConfigError(f"data: {source}: column {name!r} has shape {arr.shape}; allowed "
                              f"(n,) for an input or scalar output, (n, T) for a series")
        out[str(name)] = arr
    return out


def _read_hdf5(path: Path, source: str) -> dict[str, np.ndarray]:
    import h5py

    try:
        with h5py.File(path, "r") as f:
            items = {k: f[k][()] for k in f if isinstance(f[k], h5py.Dataset)}
    except OSError as exc:
        raise ConfigError(f"data: {source}: not a readable HDF5 file ({exc})") from None
    return _read_arrays(items, source)


def _read_npz(path: Path, source: str) -> dict[str, np.ndarray]:
    try:
        with np.load(path, allow_pickle=False) as z:
            items = {k: z[k] for k in z.files}
    except (OSError, ValueError) as exc:
        raise ConfigError(f"data: {source}: not a readable .npz file ({exc})") from None
    return _read_arrays(items, source)


def read_table(path: str | Path, source: str | None = None) -> Table:
    """Read a file of runs.

    Parameters
    ----------
    path : str or Path
        The file; its suffix says the format (:data:`SUFFIXES`).
    source : str, optional
        How messages name the file (default: ``path`` as given).

    Returns
    -------
    Table
        ConfigError naming the file (line and column where a cell is bad) when it cannot be
        read.
    """
    p = Path(path)
    source = source or str(path)
    fmt = SUFFIXES.get(p.suffix.lower())
    if fmt is None:
        raise ConfigError(f"data: {source}: unknown file type {p.suffix!r}; allowed: "
                          f"{', '.join(SUFFIXES)}", field="data")
    if not p.is_file():
        raise ConfigError(f"data: {source}: file not found"
                          + (" (a path is relative to the config file's folder)"
                             if not Path(source).is_absolute() else ""), field="data")
    first_line = 0
    if fmt == "csv":
        flat, first_line = _read_csv(p, source)
    elif fmt == "parquet":
        flat = _read_parquet(p, source)
    elif fmt == "hdf5":
        flat = _read_hdf5(p, source)
    else:
        flat = _read_npz(p, source)
    return _table(flat, source, first_line, grid_in_file=fmt != "csv")


def table_from_arrays(columns: Mapping[str, Any], source: str = ARRAYS) -> Table:
    """A table of columns already in memory (``uqguide.fit``).

    Parameters
    ----------
    columns : mapping of str to array_like
        ``(n,)`` per column, ``(n, T)`` per series (or its steps as ``name[j]`` columns),
        ``time`` ``(T,)`` optional.
    source : str
        How messages name the data.

    Returns
    -------
    Table
    """
    return _table(_read_arrays(columns, source), source, 0, grid_in_file=True)


def _table(flat: dict[str, np.ndarray], source: str, first_line: int, *,
           grid_in_file: bool) -> Table:
    # A CSV holds runs only: a column named time there is a column like any other.
    time = flat.pop(TIME, None) if grid_in_file else None
    reasons = flat.pop(REASON, None)
    raw = flat.pop(FAILED, None)
    if raw is not None and raw.ndim != 1:
        raise ConfigError(f"data: {source}: column 'failed' has shape {raw.shape}; allowed "
                          f"(n,), 0 or 1 per run")
    flagged = None if raw is None else _flags(raw, source, first_line)
    columns = _group_series(flat, source)
    if not columns:
        raise ConfigError(f"data: {source}: no columns")
    lengths = {k: v.shape[0] for k, v in columns.items()}
    if len(set(lengths.values())) > 1:
        k0 = next(iter(lengths))
        k = next(k for k, v in lengths.items() if v != lengths[k0])
        raise ConfigError(f"data: {source}: column {k!r} has {lengths[k]} rows, column {k0!r} "
                          f"{lengths[k0]}; every column holds one value per run")
    n = next(iter(lengths.values()))
    for name, col in ((FAILED, flagged), (REASON, reasons)):
        if col is not None and col.shape[0] != n:
            raise ConfigError(f"data: {source}: column {name!r} has {col.shape[0]} rows, the "
                              f"others {n}; every column holds one value per run")
    return Table(source, columns, time, first_line, _digest(columns, time, flagged, reasons),
                 flagged, reasons)
