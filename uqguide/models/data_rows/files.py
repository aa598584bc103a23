"""A file of runs read into named columns: one row per run, a column per input and per scalar
output, a series as ``name[0]``, ``name[1]``, ... or one ``(n, T)`` dataset.

Formats (CSV, Parquet, HDF5, ``.npz``), the time grid, how a failed run is written, and the
limits checked before reading: docs/config.md#data-file-formats. What the rows must satisfy
against the config's inputs is :mod:`.checks`; a file that cannot be read is a ConfigError
naming the file (and the line and column of a cell that is not a number).
"""

from __future__ import annotations

import csv
import hashlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...core.csv_rows import RowFaults, bounded_lines, floats, row_blocks
from ...errors import ConfigError
from .claims import (BLOCK_CELLS, MAX_NUMBER_CHARS, MAX_TEXT_CHARS, Claim, csv_claim, hdf5_claim,
                     npz_claim, parquet_claim)
from .names import FAILED, REASON, STEP, TIME, check_names, data_error

#: The file suffixes read, by format.
SUFFIXES = {".csv": "csv", ".parquet": "parquet", ".h5": "hdf5", ".hdf5": "hdf5",
            ".npz": "npz"}

#: How each format's claim is measured before it is read (:mod:`.claims`).
CLAIMS = {"csv": csv_claim, "parquet": parquet_claim, "hdf5": hdf5_claim, "npz": npz_claim}

__all__ = ["ARRAYS", "FAILED", "REASON", "SUFFIXES", "TIME", "Table", "read_table",
           "table_from_arrays"]

#: How messages (and a stored config) name runs given from Python rather than read from a file.
ARRAYS = "<arrays>"


@dataclass(frozen=True, eq=False)
class Table:
    """The runs of a file, as named float64 ``columns`` (``(n,)`` per plain column, ``(n, T)``
    per series).

    ``source`` is the file's path as the config gives it (``"<arrays>"`` for data from
    Python); ``time`` its grid ``(T,)`` [s], if any; ``first_line`` the file line of row 0 (2
    for a CSV with its header; 0: rows are named by number alone); ``digest`` the SHA-256 of
    the columns' names and values (a run's identity); ``flagged`` and ``reasons`` ``(n,)`` the
    ``failed`` and ``reason`` columns ("" where empty), when the file has them.
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
        raise data_error(source, f"row {i + 1}{line}, column 'failed': {raw[i]:g} is "
                         f"not 0 or 1 (1 marks a run that failed; 0 or empty, one that ran)")
    return raw == 1


def _text(values: Any) -> np.ndarray:
    """A column of text (bytes from HDF5 decoded; missing values as "")."""
    out = np.empty(len(values), dtype=object)
    for i, v in enumerate(values):
        v = v.decode("utf-8", "replace") if isinstance(v, bytes) else v
        out[i] = "" if v is None or (isinstance(v, float) and np.isnan(v)) else str(v).strip()
    return out


def _group_series(flat: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Plain columns kept, the ``name[j]`` columns of each series stacked into ``(n, T)``
    (the names already checked: :func:`.names.check_names`)."""
    plain: dict[str, np.ndarray] = {}
    steps: dict[str, dict[int, np.ndarray]] = {}
    for name, v in flat.items():
        m = STEP.match(name)
        if m is None:
            plain[name] = v
        else:
            steps.setdefault(m.group(1), {})[int(m.group(2))] = v
    for name, by_step in steps.items():
        plain[name] = np.column_stack([by_step[j] for j in range(len(by_step))])
    return plain


def _read_csv(path: Path, source: str, claim: Claim) -> dict[str, np.ndarray]:
    """The columns of a CSV whose header and size :func:`.claims.csv_claim` measured, read a
    block of rows at a time into columns allocated once (never the whole file as text)."""
    header = list(claim.columns)
    numeric = [j for j, name in enumerate(header) if name != REASON]
    values = np.empty((len(numeric), claim.rows))
    texts: list[str] | None = [] if REASON in header else None

    def not_a_number(first: int, j: int) -> Callable[[int, str], ConfigError]:
        return lambda k, cell: data_error(source, f"row {first + k + 1} (line {first + k + 2}), "
                                                  f"column {header[j]!r}: {cell!r} is not a number")

    faults = RowFaults(
        lambda line, r: data_error(source, f"line {line}: {len(r)} cells, the header names "
                                           f"{len(header)} columns"),
        lambda line: data_error(source, f"line {line}: blank line inside the data (a run's "
                                        f"outputs that failed are a row of NaN or empty cells "
                                        f"after its inputs)"),
        lambda _: data_error(source, f"more rows than its {claim.rows:,} lines; the file changed "
                                     f"while it was read"))
    n = 0
    try:
        with path.open(newline="", encoding="utf-8-sig") as f:
            records = csv.reader(bounded_lines(f, claim.line_bytes + 1, lambda line: data_error(
                source, f"line {line}: longer than {claim.line_bytes:,} characters; the file "
                f"changed while it was read")))
            next(records, None)  # the header, read by the claim
            for first, block in row_blocks(records, len(header), claim.rows,
                                           max(1, BLOCK_CELLS // max(len(header), 1)), faults,
                                           lambda r: not any(cell.strip() for cell in r),
                                           lambda r, line: _check_cells(r, header, source, line)):
                n = first + len(block)
                for i, j in enumerate(numeric):
                    values[i, first:n] = floats([r[j].strip() or "nan" for r in block],
                                                not_a_number(first, j))
                if texts is not None:
                    texts.extend(r[header.index(REASON)] for r in block)
    except UnicodeDecodeError as exc:
        raise data_error(source, f"not a text CSV file ({exc.reason})") from None
    except csv.Error as exc:
        raise data_error(source, f"not a CSV file ({exc})") from None
    # views: the rows are contiguous, no copy
    flat = {header[j]: values[i, :n] for i, j in enumerate(numeric)}
    if texts is not None:
        flat[REASON] = _text(texts)
    return {name: flat[name] for name in header}


def _check_cells(r: list[str], header: list[str], source: str, line: int) -> None:
    """ConfigError naming the first cell longer than its limit (a number's, a reason's)."""
    if max(map(len, r)) <= MAX_NUMBER_CHARS:  # every cell within the smaller limit
        return
    for j, cell in enumerate(r):
        limit = MAX_TEXT_CHARS if header[j] == REASON else MAX_NUMBER_CHARS
        if len(cell) > limit:
            raise data_error(source, f"line {line}, column {header[j]!r}: a cell of "
                             f"{len(cell):,} characters; allowed at most {limit:,} "
                             f"({'a reason' if limit == MAX_TEXT_CHARS else 'a number'})")


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
        raise data_error(source, f"reading Parquet needs pyarrow or fastparquet, "
                         f"which are not installed ({exc}); pip install pyarrow, or save the "
                         f"runs as CSV, HDF5 or .npz") from None
    check_names([str(c).strip() for c in frame.columns], source,
                lambda j: f"column {j + 1}")
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
            raise data_error(source, f"row {bad + 1}, column {str(name)!r}: "
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
            raise data_error(source, f"column {name!r} is not numeric") from None
        if arr.ndim not in (1, 2) and not (name == TIME and arr.ndim == 1):
            raise data_error(source, f"column {name!r} has shape {arr.shape}; allowed "
                             f"(n,) for an input or scalar output, (n, T) for a series")
        out[str(name)] = arr
    return out


def _read_hdf5(path: Path, source: str) -> dict[str, np.ndarray]:
    import h5py

    try:
        with h5py.File(path, "r") as f:
            items = {k: f[k][()] for k in f if isinstance(f.get(k), h5py.Dataset)}
    except (OSError, KeyError) as exc:
        raise data_error(source, f"not a readable HDF5 file ({exc})") from None
    return _read_arrays(items, source)


def _read_npz(path: Path, source: str) -> dict[str, np.ndarray]:
    try:
        with np.load(path, allow_pickle=False) as z:
            items = {k: z[k] for k in z.files}
    except (OSError, ValueError) as exc:
        raise data_error(source, f"not a readable .npz file ({exc})") from None
    return _read_arrays(items, source)


def read_table(path: str | Path, source: str | None = None,
               check: Callable[[Claim], None] | None = None) -> Table:
    """Read the file of runs at ``path`` (its suffix says the format: :data:`SUFFIXES`), named
    ``source`` in messages (default: ``path``), once ``check`` (which raises ConfigError to
    refuse, as ``max_memory`` does) passed what it claims (:class:`~.claims.Claim`). ConfigError
    naming the file (and the line and column of a bad cell) when it cannot be read."""
    p = Path(path)
    source = source or str(path)
    fmt = SUFFIXES.get(p.suffix.lower())
    if fmt is None:
        raise data_error(source, f"unknown file type {p.suffix!r}; allowed: "
                         f"{', '.join(SUFFIXES)}")
    if not p.is_file():
        raise data_error(source, "file not found"
                         + (" (a path is relative to the config file's folder)"
                            if not Path(source).is_absolute() else ""))
    claim = CLAIMS[fmt](p, source)
    if check is not None:
        check(claim)
    if fmt == "csv":
        return _table(_read_csv(p, source, claim), source, 2, grid_in_file=False)
    readers = {"parquet": _read_parquet, "hdf5": _read_hdf5, "npz": _read_npz}
    return _table(readers[fmt](p, source), source, 0, grid_in_file=True)


def table_from_arrays(columns: Mapping[str, Any], source: str = ARRAYS) -> Table:
    """A table of ``columns`` already in memory (``uqguide.fit``): ``(n,)`` per column, ``(n,
    T)`` per series (or its steps as ``name[j]`` columns), ``time (T,)`` optional; messages name
    it ``source``."""
    check_names([str(k) for k in columns], source, lambda j: f"column {j + 1}")
    return _table(_read_arrays(columns, source), source, 0, grid_in_file=True)


def _table(flat: dict[str, np.ndarray], source: str, first_line: int, *,
           grid_in_file: bool) -> Table:
    # A CSV holds runs only: a column named time there is a column like any other.
    time = flat.pop(TIME, None) if grid_in_file else None
    reasons = flat.pop(REASON, None)
    raw = flat.pop(FAILED, None)
    if raw is not None and raw.ndim != 1:
        raise data_error(source, f"column 'failed' has shape {raw.shape}; allowed "
                         f"(n,), 0 or 1 per run")
    flagged = None if raw is None else _flags(raw, source, first_line)
    columns = _group_series(flat)
    if not columns:
        raise data_error(source, "no columns")
    lengths = {k: v.shape[0] for k, v in columns.items()}
    if len(set(lengths.values())) > 1:
        k0 = next(iter(lengths))
        k = next(k for k, v in lengths.items() if v != lengths[k0])
        raise data_error(source, f"column {k!r} has {lengths[k]} rows, column {k0!r} "
                         f"{lengths[k0]}; every column holds one value per run")
    n = next(iter(lengths.values()))
    for name, col in ((FAILED, flagged), (REASON, reasons)):
        if col is not None and col.shape[0] != n:
            raise data_error(source, f"column {name!r} has {col.shape[0]} rows, the "
                             f"others {n}; every column holds one value per run")
    return Table(source, columns, time, first_line, _digest(columns, time, flagged, reasons),
                 flagged, reasons)
