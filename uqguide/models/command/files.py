"""The files a ``command`` model exchanges with its program: the batch's inputs written, its
outputs read back (formats in ``docs/your-simulator.md``).

CSV (the default)
    ``inputs.csv``: a header of the input names, one row per sample, values in ``repr``
    precision (they read back as the same doubles). ``outputs.csv``: a header naming the scalar
    outputs (``name``, or ``name[j]`` for component ``j`` of a multi-component output), optional
    ``failed`` (0/1) and ``reason`` columns, then one row per sample in the inputs' order. A
    series output is its own file ``outputs_<name>.csv`` (``outputs_<name>_<j>.csv`` per
    component): the first row is the time grid [s], then one row per sample.
HDF5
    ``inputs.h5``: a dataset ``(n,)`` per input name. ``outputs.h5``: a dataset per output,
    ``(n,)``/``(n, k)`` for a scalar, ``(n, T)``/``(n, T, k)`` for a series, ``time`` ``(T,)``
    when there are series, optional ``failed`` ``(n,)`` 0/1 and ``reason`` ``(n,)`` strings.

A file that breaks the format is a :class:`~uqguide.errors.ModelError` naming the file, the line
(and the sample it holds) and the column: the program is wrong, not a sample, so the run stops
rather than fail every sample the same way.
"""

from __future__ import annotations

import csv
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import ModelError

#: Reason of a sample the program flagged with ``failed = 1`` and no ``reason``.
FLAGGED = "the command marked it failed"
NON_FINITE = "non-finite output value"


@dataclass(frozen=True)
class OutputSpec:
    """What is read for one output: its name, kind and number of components."""

    name: str
    kind: str
    components: int


@dataclass
class ReadOutputs:
    """The outputs of a batch as read: grid ``(T,)``, scalars ``(n, k)``, series ``(n, T, k)``,
    and the samples the program flagged (``flagged`` ``(n,)``, ``reasons`` ``(n,)``)."""

    time: np.ndarray
    scalars: dict[str, np.ndarray]
    series: dict[str, np.ndarray]
    flagged: np.ndarray
    reasons: np.ndarray


def scalar_columns(spec: OutputSpec) -> list[str]:
    """CSV column names of a scalar output: ``name``, or ``name[j]`` per component.

    Parameters
    ----------
    spec : OutputSpec

    Returns
    -------
    list of str
    """
    if spec.components == 1:
        return [spec.name]
    return [f"{spec.name}[{j}]" for j in range(spec.components)]


def series_files(outputs: Path, spec: OutputSpec) -> list[Path]:
    """The CSV files of a series output beside the outputs file ``outputs``.

    Parameters
    ----------
    outputs : Path
        The scalar outputs file (``.../outputs.csv``).
    spec : OutputSpec

    Returns
    -------
    list of Path
        ``<stem>_<name>.csv``, or ``<stem>_<name>_<j>.csv`` for each component ``j``.
    """
    stem = outputs.with_suffix("").name
    if spec.components == 1:
        return [outputs.with_name(f"{stem}_{spec.name}.csv")]
    return [outputs.with_name(f"{stem}_{spec.name}_{j}.csv") for j in range(spec.components)]


# ---------------------------------------------------------------------------- inputs
def write_inputs(path: Path, names: Sequence[str], x: np.ndarray, fmt: str) -> None:
    """Write a batch's inputs.

    Parameters
    ----------
    path : Path
        ``inputs.csv`` or ``inputs.h5``.
    names : sequence of str, length d
        Input names (plain names: they cannot break the CSV).
    x : ndarray, shape (n, d)
        The samples, SI units.
    fmt : {"csv", "hdf5"}
    """
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
def read_outputs(path: Path, specs: Sequence[OutputSpec], n: int, fmt: str) -> ReadOutputs:
    """Read a batch's outputs written by the program.

    Parameters
    ----------
    path : Path
        ``outputs.csv`` or ``outputs.h5``.
    specs : sequence of OutputSpec
        The outputs to read.
    n : int
        Samples of the batch.
    fmt : {"csv", "hdf5"}

    Returns
    -------
    ReadOutputs

    Raises
    ------
    ModelError
        A missing file, a short one, a missing column, a cell that is not a number: naming the
        file, the line and the column.
    """
    if fmt == "hdf5":
        return _read_hdf5(path, specs, n)
    scalar_specs = [s for s in specs if s.kind == "scalar"]
    flagged = np.zeros(n, dtype=bool)
    reasons = np.full(n, "", dtype=object)
    scalars: dict[str, np.ndarray] = {}
    if scalar_specs or path.exists():
        table, flagged, reasons = _read_scalar_csv(path, scalar_specs, n)
        scalars = {s.name: table[s.name] for s in scalar_specs}
    series: dict[str, np.ndarray] = {}
    time: np.ndarray | None = None
    grid_file: Path | None = None
    for s in specs:
        if s.kind != "series":
            continue
        parts = []
        for f in series_files(path, s):
            t, values = _read_series_csv(f, n, flagged)
            if time is None:
                time, grid_file = t, f
            elif t.shape != time.shape or not np.array_equal(t, time):
                raise ModelError(f"{f}: line 1: the time grid differs from that of {grid_file} "
                                 f"(every series of a batch shares one grid)")
            parts.append(values)
        series[s.name] = np.stack(parts, axis=-1)
    return ReadOutputs(time=np.zeros(0) if time is None else time, scalars=scalars,
                       series=series, flagged=flagged, reasons=reasons)


def _open_csv(path: Path) -> list[list[str]]:
    try:
        with path.open(newline="", encoding="utf-8") as f:
            return [row for row in csv.reader(f)]
    except FileNotFoundError:
        raise ModelError(f"{path}: the command exited with status 0 but did not write this "
                         f"file") from None
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ModelError(f"{path}: cannot be read as CSV ({exc})") from None


def _number(cell: str, path: Path, line: int, sample: int, col: int, name: str) -> float:
    try:
        return float(cell)
    except ValueError:
        raise ModelError(f"{path}: line {line} (sample {sample}), column {col} '{name}': "
                         f"{cell!r} is not a number") from None


def _sample_rows(rows: list[list[str]], path: Path, n: int, first_line: int) -> list[list[str]]:
    """The ``n`` sample rows after the first line (empty trailing lines dropped; a line of
    empty cells is a row: a failed sample's)."""
    body = rows[1:]
    while body and not body[-1]:
        body.pop()
    if len(body) != n:
        if len(body) < n:
            raise ModelError(f"{path}: {len(body)} sample rows, expected {n} (one per sample, "
                             f"in order): line {first_line + len(body) + 1} (sample "
                             f"{len(body)}) is missing")
        raise ModelError(f"{path}: {len(body)} sample rows, expected {n} (one per sample, in "
                         f"order): line {first_line + n + 1} is one too many")
    return body


def _column(body: list[list[str]], j: int, flagged: np.ndarray, path: Path, name: str
            ) -> np.ndarray:
    """Column ``j`` of the sample rows as floats; a flagged sample's empty cell is NaN."""
    cells = [row[j] for row in body]
    try:
        # one conversion for the whole column (Python's correctly rounded parser, in C)
        return np.array(cells, dtype=float)
    except ValueError:
        pass
    out = np.empty(len(cells))
    for i, c in enumerate(cells):
        cell = c.strip()
        out[i] = (np.nan if flagged[i] and not cell else
                  _number(cell, path, i + 2, i, j + 1, name))
    return out


def _check_widths(body: list[list[str]], width: int, path: Path, what: str) -> None:
    for i, row in enumerate(body):
        if len(row) != width:
            missing = f": column {len(row) + 1} is missing" if len(row) < width else ""
            raise ModelError(f"{path}: line {i + 2} (sample {i}): {len(row)} cells, {what} "
                             f"has {width}{missing}")


def _declared(columns: Iterable[str]) -> list[str]:
    """The ``outputs`` entries that declare a header's columns: ``y`` for ``y``, ``{name: y,
    components: k}`` for ``y[0] .. y[k-1]``, in the header's order."""
    counts: dict[str, int] = {}
    for c in columns:
        m = re.fullmatch(r"(.+)\[(\d+)\]", c)
        name, k = (m.group(1), int(m.group(2)) + 1) if m else (c, 0)
        counts[name] = max(counts.get(name, 0), k)
    return [f"{{name: {nm}, components: {k}}}" if k else nm for nm, k in counts.items()]


def _read_scalar_csv(path: Path, specs: Sequence[OutputSpec], n: int
                     ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    rows = _open_csv(path)
    if not rows:
        raise ModelError(f"{path}: line 1: the file is empty; expected a header naming the "
                         f"columns {', '.join(c for s in specs for c in scalar_columns(s))}")
    header = [h.strip() for h in rows[0]]
    where = {h: j for j, h in enumerate(header)}
    for s in specs:
        for c in scalar_columns(s):
            if c not in where:
                others = _declared(h for h in header if h and h not in ("failed", "reason"))
                hint = (f"; the model's 'outputs' lists what the program writes (default "
                        f"[y]): for this header, outputs: [{', '.join(others)}]"
                        if others else "")
                raise ModelError(f"{path}: line 1: no column '{c}' in the header "
                                 f"{','.join(header)!r}{hint}")
    body = _sample_rows(rows, path, n, 1)
    _check_widths(body, len(header), path, "the header")
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


def _read_series_csv(path: Path, n: int, flagged: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    rows = _open_csv(path)
    if not rows:
        raise ModelError(f"{path}: line 1: the file is empty; expected the time grid, then "
                         f"one row per sample")
    t = np.array([_number(c.strip(), path, 1, -1, j + 1, "time") for j, c in enumerate(rows[0])])
    if t.size > 1 and not (np.all(np.isfinite(t)) and np.all(np.diff(t) >= 0)):
        raise ModelError(f"{path}: line 1: the time grid must be finite and non-decreasing")
    body = _sample_rows(rows, path, n, 1)
    _check_widths(body, t.size, path, "the time grid on line 1")
    try:
        return t, np.array(body, dtype=float).reshape(n, t.size)
    except ValueError:
        pass
    values = np.column_stack([_column(body, j, flagged, path, f"t={t[j]:g}")
                              for j in range(t.size)]) if t.size else np.empty((n, 0))
    return t, values.reshape(n, t.size)


def _read_hdf5(path: Path, specs: Sequence[OutputSpec], n: int) -> ReadOutputs:
    import h5py

    if not path.exists():
        raise ModelError(f"{path}: the command exited with status 0 but did not write this "
                         f"file")
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ModelError(f"{path}: cannot be read as HDF5 ({exc})") from None
    with f:
        def dataset(name: str) -> np.ndarray:
            if name not in f:
                raise ModelError(f"{path}: no dataset '{name}' (it has: "
                                 f"{', '.join(sorted(f)) or 'none'})")
            return np.asarray(f[name][()])

        time = np.zeros(0)
        if any(s.kind == "series" for s in specs):
            time = np.asarray(dataset("time"), dtype=float).reshape(-1)
        flagged = np.zeros(n, dtype=bool)
        reasons = np.full(n, "", dtype=object)
        if "failed" in f:
            raw = dataset("failed").reshape(-1)
            if raw.shape != (n,) or not np.isin(raw, (0, 1)).all():
                raise ModelError(f"{path}: dataset 'failed' must be ({n},) of 0/1, got "
                                 f"shape {raw.shape}")
            flagged = raw.astype(bool)
            given = ([r.decode() if isinstance(r, bytes) else str(r)
                      for r in dataset("reason").reshape(-1)] if "reason" in f else [""] * n)
            if len(given) != n:
                raise ModelError(f"{path}: dataset 'reason' has {len(given)} rows, expected "
                                 f"{n}")
            reasons[flagged] = [given[i].strip() or FLAGGED for i in np.flatnonzero(flagged)]
        scalars: dict[str, np.ndarray] = {}
        series: dict[str, np.ndarray] = {}
        for s in specs:
            a = dataset(s.name)
            if a.dtype.kind not in "fiu":
                raise ModelError(f"{path}: dataset '{s.name}' is {a.dtype}, not numbers")
            a = a.astype(float)
            shape = (n, time.size, s.components) if s.kind == "series" else (n, s.components)
            drop = 2 if s.kind == "series" else 1
            if a.shape == shape[:drop] and s.components == 1:
                a = a.reshape(shape)
            if a.shape != shape:
                raise ModelError(f"{path}: dataset '{s.name}' has shape {a.shape}, expected "
                                 f"{shape} (samples{', time' if drop == 2 else ''}, "
                                 f"components)")
            (series if s.kind == "series" else scalars)[s.name] = a
    return ReadOutputs(time=time, scalars=scalars, series=series, flagged=flagged,
                       reasons=reasons)
