"""uqguide: uncertainty propagation through closed-loop spacecraft guidance simulations.

A :class:`uqguide.Model` maps input samples ``x (n, d)`` to named outputs (series ``(n, T, k)``,
scalars ``(n, k)``, a failure mask); a :class:`uqguide.Method` designs the runs and turns the
outputs into statistics; a :class:`uqguide.Result` holds them with diagnostics and provenance.
The Python API (imported on first use, so ``import uqguide`` stays cheap)::

    cfg = uqguide.load_config("ftcapn_table3")          # a file, a shipped study or a dict
    result = uqguide.run(cfg, workers=2, out="results")  # -> Result
    result = uqguide.read_result("results/ftcapn_table3.h5")
    result = uqguide.fit(x, y, inputs=[...])             # runs already made -> Result
    result.to_xarray(), result.to_dataframe("omega_s")

``dir(uqguide)`` lists the whole API. The layers and the contracts: docs/architecture.md.
"""

from __future__ import annotations

from types import ModuleType
from typing import TYPE_CHECKING, Any

from . import results
from ._version import __version__

if TYPE_CHECKING:  # what the lazy names below resolve to, for type checkers and IDEs
    from .api import fit, load_config, read_result, run
    from .config.run_config import RunConfig
    from .methods.base import Method
    from .models.base import Model
    from .results.result import Result

#: Public name -> the module that defines it. Imported on first access (PEP 562): ``import
#: uqguide`` must not pay for NumPy, h5py or pydantic before the API is used.
_LAZY = {
    "load_config": "uqguide.api",
    "run": "uqguide.api",
    "read_result": "uqguide.api",
    "fit": "uqguide.api",
    "Result": "uqguide.results.result",
    "RunConfig": "uqguide.config.run_config",
    "Model": "uqguide.models.base",
    "Method": "uqguide.methods.base",
}

__all__ = ["Method", "Model", "Result", "RunConfig", "__version__", "fit", "load_config",
           "read_result", "run"]


def _stored_context(config: Any) -> Any:
    from .config.run_config import stored_context

    return stored_context(config)


# results reads a stored surrogate's config through config, a layer it does not import
results.stored_context = _stored_context


def __getattr__(name: str) -> Any:
    where = _LAZY.get(name)
    if where is None:
        raise AttributeError(f"module 'uqguide' has no attribute {name!r}")
    from importlib import import_module

    value = getattr(import_module(where), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    # The public API (lazy names included, before their first use), the dunders and the
    # subpackages imported so far; not this module's own helpers (Any, TYPE_CHECKING).
    here = {k for k, v in globals().items() if k.startswith("__") or isinstance(v, ModuleType)}
    return sorted(here | set(__all__))
