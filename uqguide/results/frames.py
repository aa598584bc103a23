"""A Result as an xarray Dataset or a tidy pandas table (``Result.to_xarray``,
``Result.to_dataframe``).

The Dataset's variables are those of :mod:`uqguide.results.labelled` (the same as a format-2 result
file's ``methods/<label>`` group), with a ``label`` dimension when several methods are taken
together (``ds.sel(label="mc1000")``): a statistic a method does not give (a PCE's standard
error, a Monte Carlo Sobol' index) is NaN for it. xarray is an optional dependency
(``pip install 'uqguide[xarray]'``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from ..errors import ResultError
from .labelled import method_variables
from .statistics import method_statistics
from ..core.types import Estimate

if TYPE_CHECKING:
    import pandas as pd
    import xarray as xr

    from ..models.base import OutputInfo


class MethodRun(Protocol):
    """What these views read of a method's run (:class:`uqguide.results.result.MethodRun`); a
    protocol, so that the result, which offers the views, is not imported by them."""

    @property
    def label(self) -> str: ...
    @property
    def estimate(self) -> Estimate: ...
    @property
    def n_runs(self) -> int: ...
    @property
    def n_failed(self) -> int: ...
    @property
    def model_seconds(self) -> float: ...
    @property
    def fit_seconds(self) -> float: ...


class Result(Protocol):
    """What these views read of a :class:`uqguide.results.result.Result`."""

    @property
    def name(self) -> str: ...
    @property
    def model(self) -> str: ...
    @property
    def reference(self) -> str | None: ...
    @property
    def runs(self) -> Sequence[MethodRun]: ...
    @property
    def outputs(self) -> Sequence[OutputInfo]: ...
    @property
    def time(self) -> np.ndarray: ...
    @property
    def input_names(self) -> Sequence[str]: ...
    def run(self, label: str) -> MethodRun: ...
    def output(self, name: str) -> OutputInfo: ...


#: The dimension along which :func:`to_xarray` stacks the methods, and the column of
#: :func:`to_dataframe` that names a row's method.
LABEL = "label"


def _xarray():
    try:
        import xarray
    except ImportError:
        raise ImportError("Result.to_xarray needs xarray: pip install 'uqguide[xarray]'") from None
    return xarray


def method_dataset(result: Result, run: MethodRun) -> xr.Dataset:
    """The statistics of one method as a Dataset (attrs: the method's cost and diagnostics):
    the variables of :func:`uqguide.results.labelled.method_variables`, ``time`` in s."""
    xr = _xarray()
    coords, variables = method_variables(
        method_statistics(run.label, run.estimate.stats, result.outputs), result.time,
        result.input_names)
    used = {d for v in variables.values() for d in v.dims}
    ds = xr.Dataset(
        {name: (v.dims, v.data, dict(v.attrs)) for name, v in variables.items()},
        coords={d: (c.dims, c.data, dict(c.attrs)) for d, c in coords.items()
                if d in used or d == "time"},
    )
    ds.attrs.update(name=result.name, model=result.model, label=run.label,
                    method=run.estimate.method, n_runs=run.n_runs, n_failed=run.n_failed,
                    model_seconds=run.model_seconds, fit_seconds=run.fit_seconds)
    return ds


def to_xarray(result: Result, label: str | None = None) -> xr.Dataset:
    """The statistics of method ``label``, or of every method along a ``label`` dimension
    (NaN where a method lacks a variable; ``method_name``, ``n_runs`` and ``n_failed`` along
    ``label``): ``ds.sel(label="mc1000")``.

    The dimension is ``label``, not ``method``: ``Dataset.sel(method=...)`` is xarray's own
    keyword (the fill method), so a dimension of that name could not be selected by keyword.
    """
    xr = _xarray()
    if label is not None:
        return method_dataset(result, result.run(label))
    parts = [method_dataset(result, r) for r in result.runs]
    if not parts:
        raise ResultError("this result has no methods")
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
    ds = ds.assign_coords({LABEL: [r.label for r in result.runs]})
    ds["method_name"] = (LABEL, np.array([r.estimate.method for r in result.runs],
                                         dtype=object))
    ds["n_runs"] = (LABEL, np.array([r.n_runs for r in result.runs]))
    ds["n_failed"] = (LABEL, np.array([r.n_failed for r in result.runs]))
    ds.attrs.update(name=result.name, model=result.model, reference=result.reference or "")
    return ds


def to_dataframe(result: Result, output: str) -> pd.DataFrame:
    """Every statistic of ``output`` at every time step, one row per value.

    Columns: ``label``, ``time`` [s] (series only), ``component``, ``statistic`` (mean, std,
    skewness, kurtosis, sem, q<level>), ``value`` (output's unit), ``ci_low``, ``ci_high`` (NaN
    where the method gives no interval). A validated PCE's control-variate moments are rows of
    their own, labelled ``<label>+cv``, and so is the Monte Carlo estimate of a PCE's own runs
    where it withholds a moment, ``<label>+mc`` (only there; :mod:`uqguide.results.statistics`).
    """
    import pandas as pd

    info = result.output(output)
    frames = []
    for r in result.runs:
        v = method_statistics(r.label, r.estimate.stats, [info]).get(output)
        if v is None:
            continue
        rows: list[tuple[str, str, np.ndarray, np.ndarray | None]] = [
            (st.label, st.name, st.value, st.ci) for st in v.moments]
        if v.sem is not None:
            rows.append((r.label, "sem", v.sem, None))
        rows += [(st.label, st.name, st.value, st.ci) for st in v.quantiles + v.corrected]
        fallback = len(rows)
        rows += [(st.label, st.name, st.value, st.ci) for st in v.fallback]
        for i, (lab, stat, value, ci) in enumerate(rows):
            value = np.asarray(value, dtype=float)
            comp = np.broadcast_to(np.array(info.components, dtype=object), value.shape)
            cols: dict[str, Any] = {LABEL: lab}
            if info.kind == "series":
                cols["time"] = np.broadcast_to(result.time[:, None], value.shape).ravel()
            cols.update(component=comp.ravel(), statistic=stat, value=value.ravel(),
                        ci_low=(ci[0].ravel() if ci is not None
                                else np.full(value.size, np.nan)),
                        ci_high=(ci[1].ravel() if ci is not None
                                 else np.full(value.size, np.nan)))
            frame = pd.DataFrame(cols)
            if i >= fallback:  # given only where the PCE withholds its own value
                frame = frame[frame["value"].notna()]
                if frame.empty:
                    continue
            frames.append(frame)
    if not frames:
        raise ResultError(f"no method of this result has statistics of {output!r}")
    return pd.concat(frames, ignore_index=True)
