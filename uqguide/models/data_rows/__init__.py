"""Runs already made, as the model (config ``data:`` in place of ``model:``): ``files.py``
(a CSV, Parquet, HDF5 or ``.npz`` file, or arrays in memory, read into named columns),
``arrays.py`` (the same from arrays, DataFrames or Datasets held in Python),
``checks.py`` (the rows against the config's inputs: missing columns, NaN, support,
duplicates, goodness of fit) and ``model.py`` (the model that answers a design row with the
outputs the file holds for it)."""

from .arrays import table_of
from .files import Table, read_table, table_from_arrays
from .model import DataModel, DataParams

__all__ = ["DataModel", "DataParams", "Table", "read_table", "table_from_arrays", "table_of"]
