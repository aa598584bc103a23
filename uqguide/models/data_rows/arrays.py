"""Runs held in Python (``uqguide.fit``): NumPy arrays, pandas DataFrames, xarray Datasets or
mappings of arrays, turned into the named columns of a :class:`~.files.Table`.

The rules, for the inputs ``x`` and the outputs ``y`` alike:

- a 2-D NumPy array ``(n, m)``: its columns, named in order by the given names (the inputs'
  names for ``x``; ``outputs``, default ``y0``, ``y1``, ... for ``y``); a 1-D array ``(n,)``
  is one column (``y`` by default);
- a DataFrame: its columns by name (a series as the columns ``name[0]``, ``name[1]``, ...);
- an xarray Dataset: its variables by name, ``(n,)`` or ``(n, T)`` along its first dimension,
  a series' time coordinate [s] becoming the time grid;
- a mapping of name to array: as given.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ...errors import ConfigError
from .files import ARRAYS, TIME, Table, table_from_arrays
from .names import check_names


def _columns(obj: Any, names: Sequence[str] | None, default: str, what: str
             ) -> dict[str, np.ndarray]:
    if hasattr(obj, "data_vars"):  # an xarray Dataset (a Mapping too: tested first)
        out = {}
        for k, v in obj.data_vars.items():
            out[str(k)] = np.asarray(v.values)
            if v.ndim == 2 and v.dims[1] in obj.coords and TIME not in out:
                out[TIME] = np.asarray(obj.coords[v.dims[1]].values, dtype=float)
        return out
    if hasattr(obj, "columns") and hasattr(obj, "to_numpy"):  # a DataFrame
        # a repeated name would come back from obj[k] as two columns, taken for a series
        check_names([str(k) for k in obj.columns], what, lambda j: f"column {j + 1}")
        return {str(k): obj[k].to_numpy() for k in obj.columns}
    if isinstance(obj, Mapping):
        return {str(k): np.asarray(v) for k, v in obj.items()}
    try:
        a = np.asarray(obj, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{what}: must be a NumPy array, a DataFrame, an xarray Dataset or "
                          f"a mapping of arrays (got {type(obj).__name__})",
                          field=what) from None
    if a.ndim == 1:
        a = a[:, None]
        names = list(names) if names is not None else [default]
    if a.ndim != 2:
        raise ConfigError(f"{what}: an array must be (n,) or (n, m); got shape {a.shape}",
                          field=what)
    if names is None:
        names = [f"{default}{j}" for j in range(a.shape[1])]
    if len(names) != a.shape[1]:
        raise ConfigError(f"{what}: {a.shape[1]} columns for {len(names)} names "
                          f"({', '.join(names)})", field=what)
    return {n: a[:, j] for j, n in enumerate(names)}


def table_of(x: Any, y: Any, input_names: Sequence[str],
             outputs: Sequence[str] | None = None, time: Sequence[float] | None = None
             ) -> Table:
    """The table of runs ``x`` (inputs: an array ``(n, d)`` whose columns are ``input_names``,
    a DataFrame, Dataset or mapping) and ``y`` (outputs: an array ``(n,)`` or ``(n, m)`` whose
    columns are ``outputs``, or as ``x``) held in Python (module docstring); ``time`` [s]
    replaces a Dataset's time coordinate."""
    xs = _columns(x, input_names, "x", "x")
    ys = _columns(y, outputs, "y", "y")
    both = sorted(set(xs) & set(ys) - {TIME})
    if both:
        raise ConfigError(f"y: column {both[0]!r} is also a column of x; name each column "
                          f"once", field="y")
    columns = {**xs, **ys}
    if time is not None:
        columns[TIME] = np.asarray(time, dtype=float)
    return table_from_arrays(columns, ARRAYS)
