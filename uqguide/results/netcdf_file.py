"""The netCDF-4 form of a result file's groups (format 2), written and read with h5py.

Each ``methods/<label>`` group is a self-contained netCDF-4 group: the variables of
:mod:`uqguide.results.labelled` with HDF5 dimension scales for every dimension (``time``, ``input``,
``statistic``, ``bound``, ``quantile``, ``<output>_component``...), strings as UTF-8. So
``xarray.open_dataset(path, group="methods/mc1000", engine="h5netcdf")`` gives named
dimensions and the time coordinate, and plain h5py reads the same arrays by name.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import h5py
import numpy as np

from .labelled import Variable, method_variables, stats_from_variables

if TYPE_CHECKING:
    from ..models.base import OutputInfo
    from ..stats.moments import OutputStats

UTF8 = h5py.string_dtype("utf-8")


def h5_array(values: Any) -> np.ndarray:
    """``values`` as HDF5 can store them: text as UTF-8 variable-length strings.

    Parameters
    ----------
    values : array_like

    Returns
    -------
    ndarray
        Same shape; numbers unchanged.
    """
    a = np.asarray(values)
    if a.dtype.kind in "OUS":
        return np.array([str(v) for v in a.ravel()], dtype=UTF8).reshape(a.shape)
    return a


def write_scale(g: h5py.Group, name: str, values: Any, **attrs: Any) -> h5py.Dataset:
    """A coordinate variable: a dataset that is also the dimension scale ``name``.

    Parameters
    ----------
    g : h5py.Group
    name : str
        The dimension's name.
    values : array_like, shape (m,)
        Its coordinates.
    **attrs
        Attributes (``units``, ``long_name``).

    Returns
    -------
    h5py.Dataset
    """
    d = g.create_dataset(name, data=h5_array(values))
    d.make_scale(name)
    d.attrs.update(attrs)
    return d


def attach(d: h5py.Dataset, scales: list[h5py.Dataset]) -> None:
    """Attach one dimension scale per axis of ``d``, in order.

    Parameters
    ----------
    d : h5py.Dataset
    scales : list of h5py.Dataset
        One per dimension of ``d``.
    """
    for axis, scale in enumerate(scales):
        d.dims[axis].attach_scale(scale)


def write_variable(g: h5py.Group, name: str, v: Variable, scales: dict[str, h5py.Dataset],
                   compress: bool = False) -> h5py.Dataset:
    """One labelled variable as a dataset with its dimension scales and attributes.

    Parameters
    ----------
    g : h5py.Group
    name : str
    v : Variable
        Dimensions, data and attributes.
    scales : dict of str to h5py.Dataset
        The group's dimension scales by name (every dimension of ``v``).
    compress : bool
        gzip the data when it is larger than 4096 values.

    Returns
    -------
    h5py.Dataset
    """
    d = g.create_dataset(name, data=h5_array(v.data),
                         compression="gzip" if compress and v.data.size > 4096 else None)
    attach(d, [scales[dim] for dim in v.dims])
    for k, val in v.attrs.items():
        d.attrs[k] = np.array(val, dtype=UTF8) if isinstance(val, list) else val
    return d


def write_method_stats(g: h5py.Group, stats: dict[str, OutputStats], outputs: list[OutputInfo],
                       time: np.ndarray, input_names: list[str]) -> dict[str, h5py.Dataset]:
    """The statistics of one method into ``g``.

    Parameters
    ----------
    g : h5py.Group
    stats : dict of str to OutputStats
    outputs : list of OutputInfo
    time : ndarray, shape (T,)
        Time grid [s].
    input_names : list of str

    Returns
    -------
    dict of str to h5py.Dataset
        Its dimension scales by name.
    """
    coords, variables = method_variables(stats, outputs, time, input_names)
    scales = {dim: write_scale(g, dim, values) for dim, values in coords.items()}
    scales["time"].attrs.update(units="s", long_name="time")
    for name, v in variables.items():
        write_variable(g, name, v, scales)
    return scales


def read_method_stats(g: h5py.Group, outputs: list[OutputInfo]) -> dict[str, OutputStats]:
    """The statistics :func:`write_method_stats` wrote into ``g``.

    Parameters
    ----------
    g : h5py.Group
    outputs : list of OutputInfo

    Returns
    -------
    dict of str to OutputStats
        By output name.
    """
    def get(name: str) -> np.ndarray:
        return g[name][()]

    def attrs(name: str) -> dict[str, Any]:
        return {k: (strings(v) if isinstance(v, np.ndarray) and v.dtype.kind == "O" else v)
                for k, v in g[name].attrs.items()}

    return stats_from_variables(get, lambda name: name in g, attrs, outputs)


def strings(values: Any) -> list[str]:
    """UTF-8 (format 2) or fixed-length bytes (format 1) strings as str.

    Parameters
    ----------
    values : array_like
        Strings or bytes, any shape.

    Returns
    -------
    list of str
        Flattened.
    """
    return [v.decode() if isinstance(v, bytes) else str(v) for v in np.asarray(values).ravel()]
