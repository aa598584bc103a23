"""What a run produces, above ``config``.

- ``result``: :class:`~uqguide.results.result.Result` and its HDF5 file;
- ``netcdf_file``: the netCDF-4 layout of the file's groups;
- ``surrogate``: a PCE method's surrogate, kept in the file and read back;
- ``labelled``: a method's statistics as named, labelled arrays (the one description the
  file, the xarray and pandas views read);
- ``frames``: the xarray Dataset and the tidy pandas table.
"""
