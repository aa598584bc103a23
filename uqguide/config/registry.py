"""Name -> class for the models and methods uqguide can run.

The lists are explicit (as hapsira lists its propagators): adding a simulator or a method is one
line here. Entries are ``"module:Class"`` strings imported on first use, so ``uqguide models``
and config validation do not pay for importing every simulator.
"""

from __future__ import annotations

import difflib
import importlib
from typing import TYPE_CHECKING

from ..errors import ConfigError

if TYPE_CHECKING:
    from ..methods.base import Method
    from ..models.base import Model

MODELS: dict[str, str] = {
    "linear_gaussian": "uqguide.models.benchmarks:LinearGaussian",
    "lognormal": "uqguide.models.benchmarks:Lognormal",
    "ishigami": "uqguide.models.benchmarks:Ishigami",
    "borehole": "uqguide.models.benchmarks:Borehole",
    "euler_decay": "uqguide.models.euler_decay:EulerDecay",
    "sobol_g": "uqguide.models.sobol_g:SobolG",
    "callable": "uqguide.models.callable:CallableModel",
    "command": "uqguide.models.command:CommandModel",
    "fmu": "uqguide.models.fmu:FmuModel",
    "ftcapn": "uqguide.models.ftcapn:FTCAPN",
    "gmm_proximity": "uqguide.models.gmm.model:GMMProximity",
    "ft_as": "uqguide.models.ft_as:FTAS",
    "gmm_ftc": "uqguide.models.gmm_ftc:GMMFTC",
}

METHODS: dict[str, str] = {
    "monte_carlo": "uqguide.methods.monte_carlo:MonteCarlo",
    "pce_tensor": "uqguide.methods.pce_tensor:TensorPCE",
    "pce_smolyak": "uqguide.methods.pce_smolyak:SmolyakPCE",
    "pce_adaptive": "uqguide.methods.pce_adaptive:AdaptivePCE",
    "subset_simulation": "uqguide.methods.subset_simulation:SubsetSimulation",
    "sobol_saltelli": "uqguide.methods.sobol_saltelli:SobolSaltelli",
    "mfmc": "uqguide.methods.mfmc:MultiFidelityMC",
}


def _load(target: str) -> type:
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)


def did_you_mean(name: str, choices: list[str]) -> str:
    """A hint naming the closest of ``choices`` to a misspelt ``name``.

    Parameters
    ----------
    name : str
    choices : list of str

    Returns
    -------
    str
        ``" (did you mean 'x'?)"``, or ``""`` when nothing is close.
    """
    close = difflib.get_close_matches(name, choices, n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def _lookup(kind: str, table: dict[str, str], name: object, field: str) -> type:
    if not isinstance(name, str) or name not in table:
        hint = did_you_mean(name, list(table)) if isinstance(name, str) else ""
        raise ConfigError(
            f"{field}: unknown {kind} {name!r}{hint}; allowed: {', '.join(sorted(table))}",
            field=field,
        )
    return _load(table[name])


def model_class(name: object, field: str = "model.name") -> type[Model]:
    """The model class registered as ``name``; ConfigError naming ``field`` otherwise.

    Parameters
    ----------
    name : object
        As the config gives it.
    field : str
        The config field, for the message.

    Returns
    -------
    type of Model
    """
    return _lookup("model", MODELS, name, field)


def method_class(name: object, field: str = "methods.name") -> type[Method]:
    """The method class registered as ``name``; ConfigError naming ``field`` otherwise.

    Parameters
    ----------
    name : object
        As the config gives it.
    field : str
        The config field, for the message.

    Returns
    -------
    type of Method
    """
    return _lookup("method", METHODS, name, field)
