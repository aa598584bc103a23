"""Any executable as a model (Dakota's fork interface, UQLab's UQLink): ``model.py`` (the
parameters and the batch interface), ``files.py`` (the inputs and outputs files, CSV or HDF5),
``process.py`` (running the program; nothing it starts outlives the call)."""

from .model import CommandModel, CommandParams

__all__ = ["CommandModel", "CommandParams"]
