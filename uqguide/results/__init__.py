"""What a run produces, above ``config``.

- ``result``: :class:`~uqguide.results.result.Result` and its HDF5 file, laid out whole and
  written in one pass;
- ``netcdf_file``: the netCDF-4 form of the file's groups: the layout and its one writer;
- ``surrogate``: a PCE method's surrogate, kept in the file and read back;
- ``dataset``: a method's statistics as one xarray Dataset, built from the methods' estimates:
  what the file's method groups store, ``to_xarray()`` returns and ``to_dataframe()`` reads;
- ``statistics``: a run's statistics described for the report tables and the gate (which there
  are, their names, labels, points, intervals, standard errors and control-variate rows).
"""

from collections.abc import Callable
from typing import Any

#: A stored config's input space and its model's derived outputs by name, what a surrogate read
#: from a file is rebuilt with: :func:`uqguide.config.run_config.stored_context`, which this
#: layer does not import; set by ``uqguide/__init__.py``, run before any of the package.
stored_context: Callable[[Any], tuple[Any, dict[str, Any]]] | None = None
