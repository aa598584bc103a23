"""The netCDF-4 form of a result file's groups (format 2), written and read with h5py.

Each ``methods/<label>`` group is a self-contained netCDF-4 group: the variables of the
method's Dataset (:mod:`uqguide.results.dataset`) with HDF5 dimension scales for every dimension,
strings as UTF-8. So ``xarray.open_dataset(path, group="methods/mc1000", engine="h5netcdf")``
gives named dimensions and the time coordinate, and plain h5py reads the same arrays by name.

A file is laid out whole first, as a tree of :class:`Group`, and then written by one call of
:func:`write_group`: the caller (:mod:`uqguide.results.result`) says what goes where, this module
how it is stored. Arrays too large to hold twice (a generated design, the failure reasons) are
:class:`Blocks`, converted and written a block at a time during that call.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import h5py
import numpy as np

if TYPE_CHECKING:
    import xarray as xr

UTF8 = h5py.string_dtype("utf-8")


def h5_array(values: Any) -> np.ndarray:
    """``values`` as HDF5 can store them: text as UTF-8 variable-length strings, numbers
    unchanged."""
    a = np.asarray(values)
    if a.dtype.kind in "OUS":
        return np.array([str(v) for v in a.ravel()], dtype=UTF8).reshape(a.shape)
    return a


@dataclass
class Blocks:
    """Values written a block at a time, never held whole (a million runs' inputs or failure
    reasons): ``blocks()`` yields ``(index, values)``, written as ``dataset[index] = values``."""

    shape: tuple[int, ...]
    dtype: Any
    blocks: Callable[[], Iterable[tuple[Any, np.ndarray]]]


@dataclass
class Dataset:
    """A variable as the file stores it.

    ``data``: values, text stored as UTF-8; ``dims``: the dimension scale of each axis by name,
    one of its group's or of a group above (netCDF-4 scoping; None: none); ``attrs``: a list is
    stored as an array of UTF-8 strings; ``storage``: h5py's dataset-creation keywords
    (``compression``, ``chunks``, ``shuffle``...).
    """

    data: np.ndarray | Blocks
    dims: tuple[str, ...] | None = None
    attrs: dict[str, Any] = field(default_factory=dict)
    storage: dict[str, Any] = field(default_factory=dict)


@dataclass
class Group:
    """One group of the file, laid out whole before any of it is written.

    ``scales``: the group's dimensions, coordinate variables that are also the dimension scales
    of their name, created before the variables; ``groups``: subgroups, written after the
    variables, in order; ``fill(h5py_group)``, called last: content another module writes itself
    (a kept surrogate, :mod:`uqguide.results.surrogate`).
    """

    attrs: dict[str, Any] = field(default_factory=dict)
    scales: dict[str, Dataset] = field(default_factory=dict)
    variables: dict[str, Dataset] = field(default_factory=dict)
    groups: dict[str, Group] = field(default_factory=dict)
    fill: Callable[[h5py.Group], None] | None = None


def dataset_group(ds: xr.Dataset) -> Group:
    """The group of a Dataset (a method's statistics): its coordinates as dimension scales, its
    variables with them, uncompressed (statistics are small); add attributes and subgroups."""
    return Group(scales={str(d): Dataset(c.values, attrs=dict(c.attrs))
                         for d, c in ds.coords.items()},
                 variables={str(name): Dataset(v.values, tuple(map(str, v.dims)), dict(v.attrs))
                            for name, v in ds.data_vars.items()})


def write_group(g: h5py.Group, layout: Group,
                above: Mapping[str, h5py.Dataset] | None = None) -> None:
    """Write ``layout`` into the empty group ``g``, its subgroups with it: the file's one
    writing pass; ``above``: the dimension scales of the groups above, by name."""
    _set_attrs(g, layout.attrs)
    scales = dict(above or {})
    for dim, d in layout.scales.items():
        # a coordinate is its own dimension: nothing is attached to it
        scales[dim] = _write_dataset(g, dim, replace(d, dims=None), scales)
        scales[dim].make_scale(dim)
    for name, d in layout.variables.items():
        _write_dataset(g, name, d, scales)
    for name, sub in layout.groups.items():
        write_group(g.create_group(name), sub, scales)
    if layout.fill is not None:
        layout.fill(g)


def _set_attrs(obj: h5py.Group | h5py.Dataset, attrs: Mapping[str, Any]) -> None:
    for k, val in attrs.items():
        obj.attrs[k] = np.array(val, dtype=UTF8) if isinstance(val, list) else val


def _write_dataset(g: h5py.Group, name: str, d: Dataset,
                   scales: Mapping[str, h5py.Dataset]) -> h5py.Dataset:
    if isinstance(d.data, Blocks):
        ds = g.create_dataset(name, shape=d.data.shape, dtype=d.data.dtype, **d.storage)
        for index, values in d.data.blocks():
            ds[index] = values
    else:
        ds = g.create_dataset(name, data=h5_array(d.data), **d.storage)
    if d.dims is not None:
        for axis, dim in enumerate(d.dims):
            ds.dims[axis].attach_scale(scales[dim])
    _set_attrs(ds, d.attrs)
    return ds


def strings(values: Any) -> list[str]:
    """UTF-8 (format 2) or fixed-length bytes (format 1) strings of any shape as a flat list of
    str."""
    return [v.decode() if isinstance(v, bytes) else str(v) for v in np.asarray(values).ravel()]
