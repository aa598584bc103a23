"""Any executable as a model (Dakota's fork interface, UQLab's UQLink): ``model.py`` (the
parameters and the batch interface), ``files.py`` (the inputs and outputs files, CSV or HDF5),
``process.py`` (running the program, killed as a process group on timeout)."""

from .model import CommandModel, CommandParams

__all__ = ["CommandModel", "CommandParams"]
