"""What a file of runs will take to read, known from its size and headers before any value is
read: a CSV's header and its count of lines, an HDF5 file's dataset shapes and types, an
``.npz`` file's array headers, a Parquet file's metadata. A header that claims terabytes is
then refused against ``max_memory`` (:mod:`uqguide.config.data_source`) before anything is
allocated, and an ``.npz`` array whose header claims more bytes than its member holds is
refused as damaged. The bytes a claim stands for, and the measured peaks:
docs/your-simulator.md#limits-of-a-file.
"""

from __future__ import annotations

import csv
import io
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .names import REASON, check_names
from .names import data_error as _fail

#: Longest cell of a number: a float64's shortest text is at most 24 characters
#: (``-2.2250738585072014e-308``); the rest is room for blanks and quotes.
MAX_NUMBER_CHARS = 64
#: Longest cell of text (a ``reason``, a column name).
MAX_TEXT_CHARS = 4096
#: Longest header line of a CSV [bytes]: a million columns of 16 characters.
MAX_HEADER_BYTES = 2**24
#: Cells a CSV reader converts at once (a block of rows): what the block's strings hold, about
#: 60 bytes a cell, is a bounded extra beside the table.
BLOCK_CELLS = 2**18
#: Bytes Python holds per text cell (a ``reason``) besides its characters: the str object's
#: header and the pointer to it.
TEXT_CELL_BYTES = 64
#: Bytes per cell of one block of a CSV being converted (the cell's str in the row's list).
BLOCK_CELL_BYTES = 64

_READ_CHUNK = 2**20


@dataclass(frozen=True)
class Claim:
    """What a file holds by its size and headers: ``rows`` (runs; for a CSV an upper bound, its
    lines after the header), numeric ``cells`` once read, ``extra_bytes`` the reading holds
    beside 8 a value (text cells, a conversion's copy, a CSV's line and block being
    converted), the claim in words for a refusal (``what``: ``"2,000,001 lines x 8
    columns"``), and for a CSV its header's ``columns`` and longest line ``line_bytes``."""

    rows: int
    cells: int
    extra_bytes: float
    what: str
    columns: tuple[str, ...] = ()
    line_bytes: int = 0


# ---------------------------------------------------------------------------- CSV
def line_limit(columns: tuple[str, ...]) -> int:
    """Longest data line of a CSV with these columns [characters]: every cell at its limit
    (:data:`MAX_NUMBER_CHARS`, the ``reason`` :data:`MAX_TEXT_CHARS`) and its separator."""
    text = sum(1 for c in columns if c == REASON)
    # a text cell's characters may take 4 bytes each in UTF-8, and quotes around it
    return (len(columns) - text) * (MAX_NUMBER_CHARS + 1) + text * (4 * MAX_TEXT_CHARS + 3) + 2


def _first_long(inner: bytes, limit: int) -> int:
    """Index (from 0) of the first line longer than ``limit`` bytes among the whole lines of
    ``inner`` (each ending with its newline), -1 when there is none."""
    nl = np.frombuffer(inner, dtype=np.uint8) == 10
    # Fast path: a line of more than limit bytes holds a whole aligned block of
    # (limit + 2) // 2 bytes without a newline; when every block has one, no line is long.
    block = (limit + 2) // 2
    padded = np.concatenate([nl, np.ones(-nl.size % block, dtype=bool)])
    if padded.reshape(-1, block).any(axis=1).all():
        return -1
    lengths = np.diff(np.flatnonzero(nl), prepend=-1) - 1
    over = np.flatnonzero(lengths > limit)
    return int(over[0]) if over.size else -1


def _count_lines(path: Path, limit: int) -> tuple[int, int]:
    """The file's lines (a last one without its newline counted), without decoding or holding
    more than a chunk; stops at the first line longer than ``limit`` bytes. Returns the count
    and the number (from 1) of the first line over ``limit``, 0 when none is."""
    lines, run = 0, 0  # run: bytes of the line not yet ended
    with path.open("rb") as f:
        while chunk := f.read(_READ_CHUNK):
            first = chunk.find(b"\n")
            if first < 0 or run + first > limit:
                run += len(chunk) if first < 0 else first
                if run > limit:
                    return lines, lines + 1
                continue
            last = chunk.rfind(b"\n")
            inside = _first_long(chunk[first + 1:last + 1], limit)
            if inside >= 0:
                return lines, lines + 2 + inside
            lines += chunk.count(b"\n", first, last + 1)
            run = len(chunk) - last - 1
            if run > limit:
                return lines, lines + 1
    return lines + (run > 0), 0


def csv_header(path: Path, source: str) -> tuple[tuple[str, ...], int]:
    """A CSV's column names (a UTF-8 byte-order mark stripped, as CSV readers do) and the
    header's length [bytes]; ConfigError naming the file when it is not a CSV header."""
    with path.open("rb") as f:
        raw = f.readline(MAX_HEADER_BYTES + 1)
    if len(raw) > MAX_HEADER_BYTES and not raw.endswith(b"\n"):
        raise _fail(source, f"line 1 (the header) is longer than {MAX_HEADER_BYTES:,} bytes; "
                            f"a header names the columns, one short name each")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise _fail(source, f"not a text CSV file ({exc.reason})") from None
    try:
        header = next(csv.reader(io.StringIO(text)), [])
    except csv.Error as exc:
        raise _fail(source, f"line 1: not a CSV header ({exc})") from None
    if not any(cell.strip() for cell in header):
        raise _fail(source, "empty file; the first line must name the columns")
    names = tuple(c.strip() for c in header)
    for j, name in enumerate(names):
        if len(name) > MAX_TEXT_CHARS:
            raise _fail(source, f"line 1, column {j + 1}: a cell of {len(name):,} characters; "
                                f"allowed at most {MAX_TEXT_CHARS:,}")
    check_names(list(names), source, lambda j: f"line 1, column {j + 1}")
    return names, len(raw)


def csv_claim(path: Path, source: str) -> Claim:
    """The claim of a CSV: its header's columns times its lines; ConfigError when a line is
    longer than its cells can be (:func:`line_limit`)."""
    columns, header_bytes = csv_header(path, source)
    # the header's own length is checked by csv_header: a data line may be as long
    limit = max(line_limit(columns), header_bytes)
    lines, too_long = _count_lines(path, limit)
    if too_long:
        raise _fail(source, f"line {too_long:,} is longer than {limit:,} bytes, what "
                            f"{len(columns)} cells can take: a cell is at most "
                            f"{MAX_NUMBER_CHARS} characters (a number) or {MAX_TEXT_CHARS:,} "
                            f"(a reason)")
    rows = max(lines - 1, 0)
    numeric = sum(1 for c in columns if c != REASON)
    text = rows * TEXT_CELL_BYTES + path.stat().st_size if REASON in columns else 0.0
    block = min(rows * len(columns), max(BLOCK_CELLS, len(columns))) * BLOCK_CELL_BYTES
    return Claim(rows, rows * numeric, text + block + 4.0 * limit,
                 f"{rows:,} rows x {len(columns):,} columns", columns, limit)


# ---------------------------------------------------------------------------- HDF5
def hdf5_claim(path: Path, source: str) -> Claim:
    """The claim of an HDF5 file: its top-level datasets' shapes and types (module docstring)."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            names = [k for k in f if isinstance(f.get(k), h5py.Dataset)]
            shapes = {k: (tuple(int(s) for s in f[k].shape), f[k].dtype) for k in names}
    except (OSError, KeyError) as exc:
        raise _fail(source, f"not a readable HDF5 file ({exc})") from None
    check_names(names, source, lambda j: f"dataset {j + 1}")
    return _arrays_claim(shapes, source, "dataset", path.stat().st_size)


# ---------------------------------------------------------------------------- npz
def _npy_header(z: zipfile.ZipFile, info: zipfile.ZipInfo, source: str
                ) -> tuple[tuple[int, ...], np.dtype]:
    from numpy.lib import format as npy

    name = info.filename
    try:
        with z.open(info) as f:
            version = npy.read_magic(f)
            if version == (1, 0):
                shape, _, dtype = npy.read_array_header_1_0(f)
            elif version == (2, 0):
                shape, _, dtype = npy.read_array_header_2_0(f)
            else:
                raise ValueError(f"format version {version} (a structured array)")
            header = f.tell()
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise _fail(source, f"member {name!r} is not a NumPy array ({exc})") from None
    count = int(np.prod(shape, dtype=object))
    holds = info.file_size - header
    if dtype.hasobject or count * dtype.itemsize > holds:
        what = "Python objects (pickled), which are never loaded" if dtype.hasobject else \
            f"{count * dtype.itemsize:,} bytes, but the member holds {max(holds, 0):,}"
        raise _fail(source, f"member {name!r}: its header claims shape {shape} {dtype}, "
                            f"{what}; save the runs with numpy.savez")
    return shape, dtype


def npz_claim(path: Path, source: str) -> Claim:
    """The claim of an ``.npz`` file: its arrays' headers, each checked against the bytes its
    member holds (module docstring)."""
    try:
        with zipfile.ZipFile(path) as z:
            infos = z.infolist()
            names = [i.filename[:-4] if i.filename.endswith(".npy") else i.filename
                     for i in infos]
            check_names(names, source, lambda j: f"member {infos[j].filename!r}")
            shapes = {n: _npy_header(z, i, source) for n, i in zip(names, infos)}
    except (OSError, zipfile.BadZipFile) as exc:
        raise _fail(source, f"not a readable .npz file ({exc})") from None
    return _arrays_claim(shapes, source, "array", 0)


# ---------------------------------------------------------------------------- Parquet
def parquet_claim(path: Path, source: str) -> Claim:
    """The claim of a Parquet file: rows and columns from its metadata (pyarrow's)."""
    try:
        import pyarrow.parquet as pq
    except ImportError:
        # without pyarrow the reader says what to install (fastparquet reads without a claim)
        return Claim(0, 0, 0.0, "")
    try:
        meta = pq.ParquetFile(str(path)).metadata
    except Exception as exc:  # noqa: BLE001 - pyarrow's errors: all the file's fault
        raise _fail(source, f"not a readable Parquet file ({exc})") from None
    rows, cols = int(meta.num_rows), int(meta.num_columns)
    # Arrow's buffers and the DataFrame built from them are alive while the columns are copied
    return Claim(rows, rows * cols, 16.0 * rows * cols, f"{rows:,} rows x {cols:,} columns")


# ---------------------------------------------------------------------------- arrays
def _arrays_claim(shapes: dict[str, tuple[tuple[int, ...], np.dtype]], source: str,
                  kind: str, file_bytes: int) -> Claim:
    """The claim of named arrays (HDF5 datasets, ``.npz`` members) by shape and type."""
    cells, extra, rows = 0, 0.0, 0
    for name, (shape, dtype) in shapes.items():
        count = int(np.prod(shape, dtype=object))
        if shape:
            rows = max(rows, int(shape[0]))
        if name == REASON or dtype.kind in "SUO":
            if dtype.kind in "SU" and dtype.itemsize > 4 * MAX_TEXT_CHARS:
                raise _fail(source, f"{kind} {name!r} holds text of {dtype.itemsize:,} bytes "
                                    f"an element; allowed at most {4 * MAX_TEXT_CHARS:,}")
            # text: each element a Python str (variable-length ones no longer than the file)
            extra += count * (TEXT_CELL_BYTES + dtype.itemsize) + file_bytes
            continue
        cells += count
        if dtype != np.float64:
            extra += count * dtype.itemsize  # read in its own type, then converted
    big = max(shapes.items(), key=lambda kv: int(np.prod(kv[1][0], dtype=object)),
              default=None)
    what = f"{len(shapes)} {kind}s" + ("" if big is None else
                                       f", the largest {big[0]!r} of shape {big[1][0]} "
                                       f"{big[1][1]}")
    return Claim(rows, cells, extra, what)
