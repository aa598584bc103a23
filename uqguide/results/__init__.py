"""What a run produces, above ``config``.

- ``result``: :class:`~uqguide.results.result.Result` and its HDF5 file, laid out whole and
  written in one pass;
- ``netcdf_file``: the netCDF-4 form of the file's groups: the layout and its one writer;
- ``surrogate``: a PCE method's surrogate, kept in the file and read back;
- ``statistics``: a run's statistics described once (which there are, their names, labels,
  points, intervals, standard errors and control-variate rows): what the file, the views, the
  report tables and the gate read;
- ``labelled``: a method's statistics as named, labelled arrays (the variables of the file's
  method groups and of the xarray view);
- ``frames``: the xarray Dataset and the tidy pandas table.
"""
