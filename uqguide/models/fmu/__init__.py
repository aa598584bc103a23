"""An FMU (Functional Mock-up Unit, FMI 1.0/2.0/3.0, exported from Modelica, Simulink, ...) as
a model, through FMPy (the optional extra ``uqguide[fmu]``): ``params.py`` (the parameters,
checked against the FMU), ``model.py`` (the batch interface), ``archive.py`` (FMPy, the FMU's
description and its files, unzipped once per process), ``simulate.py`` (one instance per
batch, reset between its samples)."""

from .model import FmuModel
from .params import FmuOutput, FmuParams

__all__ = ["FmuModel", "FmuOutput", "FmuParams"]
