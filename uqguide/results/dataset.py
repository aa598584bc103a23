"""A result's statistics as one ``xarray.Dataset``: built here from the methods'
:class:`~uqguide.core.types.OutputStats`, stored as the result file's method groups, read back
(:func:`read_stats`, from a file group or a Dataset alike, so reading a file needs no xarray),
stacked along ``label`` (:func:`stack`) and viewed as a tidy table (:func:`frames`).

Per output ``o``: ``o`` (statistic, [time,] o_component) with mean, std, skewness, kurtosis,
its covariance, intervals, Sobol' indices and quantiles, and a validated PCE's ``o_corrected``
and ``o_fallback``. Each moment variable's ``source`` attribute names whose values it holds
(:data:`SOURCES`); ``o_usable`` is 0 where the method withholds its own.

The variables, their dimensions and coordinates: docs/result-file.md#a-methods-variables.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ..core.types import STAT_NAMES, OutputStats
from ..stats.quantiles import level_name

if TYPE_CHECKING:
    import pandas as pd
    import xarray as xr

    from ..models.base import OutputInfo

BOUNDS = ("low", "high")
#: Whose values a moment variable holds (its ``source`` attribute) and how the label of its rows
#: ends in :func:`frames`: the method's ``own``; a validated PCE's control-variate
#: estimate, ``cv``; the Monte Carlo estimate of a PCE's own runs where the PCE withholds its
#: moment, ``mc`` (NaN elsewhere). Where ``o_usable`` is 0 the own value is ``withheld`` (NaN).
SOURCES = {"own": "", "cv": "+cv", "mc": "+mc"}
#: The dimension along which :func:`stack` stacks the methods, and the column of
#: :func:`frames` that names a row's method. Not ``method``: ``Dataset.sel(method=...)``
#: is xarray's own keyword (the fill method), so a dimension of that name could not be selected.
LABEL = "label"


def _xarray() -> Any:
    import xarray

    return xarray


def component_dim(output: str, second: bool = False) -> str:
    """Name of an output's component dimension, ``"<output>_component"``, or with ``second``
    the covariance's second one, ``"<output>_component2"``."""
    return f"{output}_component2" if second else f"{output}_component"


class Variable(NamedTuple):
    """One variable of the Dataset before xarray holds it: what the statistics' readers that
    need no xarray (the report tables, the gate) read, as they read an ``xarray.Variable``."""

    dims: tuple[str, ...]
    values: Any
    attrs: dict[str, Any]


def layout(stats: Mapping[str, OutputStats], outputs: Sequence[OutputInfo],
           time: np.ndarray, input_names: Sequence[str]
           ) -> tuple[dict[str, Variable], dict[str, Variable]]:
    """The coordinates and variables of one method's statistics ``stats`` (by output name; the
    outputs without statistics are left out) on the grid ``time (T,)`` [s]: the variables of
    the module docstring with units, and the coordinates of every dimension they may use."""
    coords = {
        "time": Variable(("time",), np.asarray(time, dtype=float),
                         {"units": "s", "long_name": "time"}),
        "input": Variable(("input",), np.array(input_names, dtype=object), {}),
        "statistic": Variable(("statistic",), np.array(STAT_NAMES, dtype=object), {}),
        "bound": Variable(("bound",), np.array(BOUNDS, dtype=object), {}),
    }
    variables: dict[str, Variable] = {}
    for o in outputs:
        if o.name in stats:
            variables.update(_output_variables(o, stats[o.name], coords))
    return coords, variables


def stats_dataset(stats: Mapping[str, OutputStats], outputs: Sequence[OutputInfo],
                  time: np.ndarray, input_names: Sequence[str]) -> xr.Dataset:
    """The Dataset of :func:`layout`, with the coordinates its variables use (``time``
    always)."""
    coords, variables = layout(stats, outputs, time, input_names)
    used = {d for v in variables.values() for d in v.dims}
    return _xarray().Dataset(variables, coords={d: c for d, c in coords.items()
                                                if d in used or d == "time"})


def without_single_components(ds: xr.Dataset, outputs: Sequence[OutputInfo]) -> xr.Dataset:
    """``ds`` without the size-1 component dimensions of its one-component outputs, so that a
    one-component series is ``(statistic, time)`` and plots as it is; each stays a scalar
    coordinate naming the component. The result file keeps them (:func:`layout`)."""
    dims = [component_dim(o.name, second) for o in outputs if o.k == 1
            for second in (False, True)]
    return ds.squeeze([d for d in dims if d in ds.dims])


#: The dimensions :func:`layout` puts before an output's component dimension.
_LEADING = ("bound", "statistic", "quantile", "time")


def _with_components(v: xr.DataArray, output: str, second: bool) -> xr.DataArray:
    """``v`` with the component dimensions :func:`without_single_components` took away, where
    :func:`layout` has them (after the leading dimensions; the covariance's second next)."""
    at = sum(d in _LEADING for d in v.dims)
    for dim in [component_dim(output)] + ([component_dim(output, True)] if second else []):
        if dim not in v.dims and dim in v.coords:
            v = v.expand_dims(dim, axis=at)
        at += 1
    return v


def _output_variables(o: OutputInfo, s: OutputStats,
                      coords: dict[str, Variable]) -> dict[str, Variable]:
    """The variables of one output's statistics; adds the coordinates they need to ``coords``."""
    base = (*(("time",) if o.kind == "series" else ()), component_dim(o.name))
    names = np.array(o.components, dtype=object)
    for second in (False, True):
        dim = component_dim(o.name, second)
        coords[dim] = Variable((dim,), names, {})
    out = {
        o.name: Variable(("statistic", *base), np.stack([s.stat(n) for n in STAT_NAMES]),
                         {"units": o.unit, "long_name": o.description, "kind": o.kind,
                          "n_used": int(s.n_used), "moments_method": s.moments_method,
                          "source": "own"}),
        f"{o.name}_cov": Variable((*base, component_dim(o.name, True)), s.cov,
                                  {"units": f"({o.unit})^2"}),
    }
    if s.sem is not None:
        out[f"{o.name}_sem"] = Variable(base, s.sem, {"units": o.unit})
    given = [n for n in STAT_NAMES if n in s.ci]
    if given:
        ci = np.full((2, len(STAT_NAMES), *s.mean.shape), np.nan)
        for j, n in enumerate(STAT_NAMES):
            if n in s.ci:
                ci[:, j] = s.ci[n]
        out[f"{o.name}_ci"] = Variable(("bound", "statistic", *base), ci,
                                       {"description": "95% interval", "statistics": given})
    groups = s.sobol_group_first is not None and bool(s.sobol_groups)
    if groups:
        coords["group"] = Variable(("group",), np.array(s.sobol_groups, dtype=object), {})
    group_estimator = s.sobol_estimator or ("pce" if s.sobol_first is not None else "given-data")
    for kind, dim, estimator in (("first", "input", s.sobol_estimator or "pce"),
                                 ("total", "input", s.sobol_estimator or "pce"),
                                 ("group_first", "group", group_estimator),
                                 ("group_total", "group", group_estimator)):
        sobol, sobol_ci = getattr(s, f"sobol_{kind}"), getattr(s, f"sobol_{kind}_ci")
        if sobol is None or (dim == "group" and not groups):
            continue
        out[f"{o.name}_sobol_{kind}"] = Variable((*base, dim), sobol,
                                                 {"units": "1", "estimator": estimator})
        if sobol_ci is not None:
            out[f"{o.name}_sobol_{kind}_ci"] = Variable(
                ("bound", *base, dim), sobol_ci, {"units": "1", "description": "95% interval"})
    table = s.quantile_table()
    if table is not None:
        levels = np.asarray(table[0], dtype=float)
        if "quantile" in coords and not np.array_equal(coords["quantile"].values, levels):
            raise ValueError(f"output {o.name!r} has quantile levels {levels.tolist()}, "
                             f"another output {coords['quantile'].values.tolist()}")
        coords["quantile"] = Variable(("quantile",), levels, {})
        out[f"{o.name}_quantile"] = Variable(("quantile", *base), table[1], {"units": o.unit})
        out[f"{o.name}_ci_quantile"] = Variable(("bound", "quantile", *base), table[2],
                                                {"units": o.unit})
    for field, source, what, band_what in (
            ("corrected", "cv", "control-variate estimates (PCE + mean model-minus-surrogate on "
                                "validation runs)",
             "95% interval from the validation runs (delta method, stratified)"),
            ("fallback", "mc", "where the PCE withholds a moment: the Monte Carlo estimate of "
                               "its own fit and validation runs",
             "95% interval, the runs treated as independent draws")):
        values, bands = getattr(s, field), getattr(s, f"{field}_ci")
        if values:
            out[f"{o.name}_{field}"] = Variable(
                ("statistic", *base), np.stack([values[n] for n in STAT_NAMES]),
                {"units": o.unit, "source": source, "description": what})
            out[f"{o.name}_{field}_ci"] = Variable(
                ("bound", "statistic", *base), np.stack([bands[n] for n in STAT_NAMES], axis=1),
                {"description": band_what})
    if s.validation_error is not None:
        out[f"{o.name}_validation_error"] = Variable(
            base, np.asarray(s.validation_error, dtype=float),
            {"units": "1", "description": "mean squared model-minus-surrogate difference over "
                                          "the model's variance, validation runs"})
    if s.usable is not None:
        out[f"{o.name}_usable"] = Variable(
            base, np.asarray(s.usable, dtype=np.uint8),
            {"units": "1", "description": "0 where the own moments are withheld (NaN)"})
    return out


def misshapen(s: OutputStats, o: OutputInfo, n_steps: int, where: str) -> str | None:
    """What is wrong with the shapes of one output's moments, sem and intervals on a grid of
    ``n_steps`` steps, if anything (what the Dataset cannot hold)."""
    want = (n_steps, o.k) if o.kind == "series" else (o.k,)
    for name in STAT_NAMES:
        arr = np.asarray(s.stat(name))
        if arr.shape != want or arr.dtype.kind not in "fiu":
            return (f"{where}: {name} has shape {arr.shape} and type {arr.dtype}, "
                    f"expected {want} numbers")
    if s.sem is not None and np.shape(s.sem) != want:
        return f"{where}: sem has shape {np.shape(s.sem)}, expected {want}"
    for name in STAT_NAMES:
        if name in s.ci and np.shape(s.ci[name]) != (2, *want):
            return f"{where}: ci_{name} has shape {np.shape(s.ci[name])}"
    return None


#: The arrays of :class:`OutputStats` a variable ``<output>_<field>`` holds as they are.
_AS_THEY_ARE = ("sem", "sobol_first", "sobol_total", "sobol_first_ci", "sobol_total_ci",
                "sobol_group_first", "sobol_group_first_ci", "sobol_group_total",
                "sobol_group_total_ci", "validation_error")


def read_stats(g: Any, outputs: Sequence[OutputInfo]) -> dict[str, OutputStats]:
    """The inverse of :func:`layout`, from its variables (a Dataset, also one of
    :func:`without_single_components`, or a mapping of :class:`Variable`) or a result file's
    method group (h5py) alike: by output name, for the outputs that have statistics."""
    def get(name: str, output: str | None = None) -> Any:
        v = g[name]
        if output is not None and hasattr(v, "expand_dims"):  # xarray's, maybe squeezed
            v = _with_components(v, output, name == f"{output}_cov")
        return v.values if hasattr(v, "values") else v[()]

    def attrs(name: str) -> dict[str, Any]:
        # h5py gives a list attribute back as an array of str
        return {k: (list(v) if isinstance(v, np.ndarray) and v.dtype.kind == "O" else v)
                for k, v in g[name].attrs.items()}

    stats = {}
    for o in outputs:
        name = o.name
        if name not in g:
            continue
        m, a = get(name, name), attrs(name)
        stats[name] = s = OutputStats(mean=m[0], std=m[1], skewness=m[2], kurtosis=m[3],
                                      cov=get(f"{name}_cov", name), n_used=int(a["n_used"]),
                                      moments_method=str(a["moments_method"]))
        for field in _AS_THEY_ARE:
            if f"{name}_{field}" in g:
                setattr(s, field, get(f"{name}_{field}", name))
        if f"{name}_ci" in g:
            arr, known = get(f"{name}_ci", name), list(attrs(f"{name}_ci")["statistics"])
            s.ci = {n: arr[:, j] for j, n in enumerate(STAT_NAMES) if n in known}
        if f"{name}_quantile" in g:
            s.quantile_levels = tuple(float(p) for p in get("quantile"))
            s.quantiles = get(f"{name}_quantile", name)
            s.ci_quantiles = get(f"{name}_ci_quantile", name)
        s.sobol_estimator = next((str(attrs(f"{name}_sobol_{kind}").get("estimator", "pce"))
                                  for kind in ("first", "total", "group_first", "group_total")
                                  if f"{name}_sobol_{kind}" in g), "")
        if f"{name}_sobol_group_first" in g:
            s.sobol_groups = tuple(v.decode() if isinstance(v, bytes) else str(v)
                                   for v in get("group"))
        for field in ("corrected", "fallback"):
            if f"{name}_{field}" in g:
                values, bands = get(f"{name}_{field}", name), get(f"{name}_{field}_ci", name)
                setattr(s, field, {n: values[j] for j, n in enumerate(STAT_NAMES)})
                setattr(s, f"{field}_ci", {n: bands[:, j] for j, n in enumerate(STAT_NAMES)})
        if f"{name}_usable" in g:
            s.usable = np.asarray(get(f"{name}_usable", name)).astype(bool)
    return stats


def stack(parts: list[xr.Dataset], labels: list[str]) -> xr.Dataset:
    """Methods' Datasets along a ``label`` dimension, NaN where a method lacks a variable."""
    xr = _xarray()
    # Give every part every variable (NaN where a method has none) so they stack cleanly.
    for name in {n for p in parts for n in p.data_vars}:
        like = next(p[name] for p in parts if name in p.data_vars)
        for p in parts:
            if name not in p.data_vars:
                p[name] = xr.full_like(like, np.nan, dtype=float)
    for p in parts:
        p.attrs = {}
    ds = xr.concat(parts, dim=LABEL, data_vars="all", coords="minimal",
                   compat="equals", join="outer")
    return ds.assign_coords({LABEL: labels})


def frames(ds: xr.Dataset, output: OutputInfo, label: str) -> list[pd.DataFrame]:
    """The rows of :meth:`uqguide.results.result.Result.to_dataframe` of ``output`` in one
    method's Dataset ``ds``: the own moments, the sem, the quantiles, then the other
    :data:`SOURCES`' moments, labelled ``<label>+cv`` and ``<label>+mc`` (the latter only where
    given); none where ``ds`` has no statistics of ``output``."""
    import pandas as pd

    out = []
    time = ds["time"].values
    for row_label, stat, value, ci, sparse in _rows(ds, output.name, label):
        value = np.asarray(value, dtype=float)
        comp = np.broadcast_to(np.array(output.components, dtype=object), value.shape)
        cols: dict[str, Any] = {LABEL: row_label}
        if output.kind == "series":
            cols["time"] = np.broadcast_to(time[:, None], value.shape).ravel()
        nan = np.full(value.size, np.nan)
        cols.update(component=comp.ravel(), statistic=stat, value=value.ravel(),
                    ci_low=nan if ci is None else ci[0].ravel(),
                    ci_high=nan if ci is None else ci[1].ravel())
        frame = pd.DataFrame(cols)
        if sparse:
            frame = frame[frame["value"].notna()]
            if frame.empty:
                continue
        out.append(frame)
    return out


#: Columns of :meth:`~uqguide.results.result.Result.to_dataframe` renamed, still answered with
#: a DeprecationWarning until the version named (CHANGELOG.md).
RENAMED_COLUMNS = {"method": (LABEL, "0.3")}


@functools.cache
def tidy_frame_class() -> type:
    """The DataFrame of :meth:`~uqguide.results.result.Result.to_dataframe`: a pandas DataFrame
    that still answers a renamed column (``df["method"]``, ``df.method``, ``groupby("method")``)
    by its new name, with a DeprecationWarning."""
    import pandas as pd

    def new_name(frame: pd.DataFrame, key: Any) -> Any:
        if isinstance(key, str) and key in RENAMED_COLUMNS and key not in frame.columns:
            name, until = RENAMED_COLUMNS[key]
            warnings.warn(f"to_dataframe(): the column {key!r} is now {name!r}; {key!r} goes "
                          f"in uqguide {until}", DeprecationWarning, stacklevel=3)
            return name
        return key

    class TidyFrame(pd.DataFrame):
        @property
        def _constructor(self) -> type:  # a filtered or sorted frame keeps the old names
            return TidyFrame

        def __getitem__(self, key: Any) -> Any:
            return super().__getitem__(new_name(self, key))

        def __getattr__(self, name: str) -> Any:
            return super().__getattr__(new_name(self, name))

        def groupby(self, by: Any = None, *args: Any, **kwargs: Any) -> Any:
            keys = [new_name(self, k) for k in by] if isinstance(by, list) else new_name(self, by)
            return super().groupby(keys, *args, **kwargs)

    return TidyFrame


def _rows(ds: xr.Dataset, o: str, label: str) -> list[tuple[str, str, Any, Any, bool]]:
    """``(label, statistic, values, interval or None, given only where not NaN)`` of output
    ``o`` in ``ds``: the own moments, the sem, the quantiles, then the other sources'."""
    if o not in ds:
        return []
    known = ds[f"{o}_ci"].attrs["statistics"] if f"{o}_ci" in ds else []
    rows = [(label, n, ds[o].values[j], ds[f"{o}_ci"].values[:, j] if n in known else None,
             False) for j, n in enumerate(STAT_NAMES)]
    if f"{o}_sem" in ds:
        rows.append((label, "sem", ds[f"{o}_sem"].values, None, False))
    if f"{o}_quantile" in ds:
        rows += [(label, level_name(float(p)), ds[f"{o}_quantile"].values[j],
                  ds[f"{o}_ci_quantile"].values[:, j], False)
                 for j, p in enumerate(ds["quantile"].values)]
    for name in (f"{o}_corrected", f"{o}_fallback"):
        if name in ds:
            source = ds[name].attrs["source"]
            rows += [(label + SOURCES[source], n, ds[name].values[j],
                      ds[f"{name}_ci"].values[:, j], source == "mc")
                     for j, n in enumerate(STAT_NAMES)]
    return rows
