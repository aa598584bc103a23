"""uqguide: uncertainty propagation through closed-loop spacecraft guidance simulations.

The package is organised around three abstractions:

- :class:`uqguide.models.base.Model` maps a batch of input samples ``x (n, d)`` to named
  outputs (time series ``(n, T, k)`` and scalars ``(n, k)``) plus a failure mask;
- :class:`uqguide.methods.base.Method` designs the runs to make and turns the model's outputs
  into statistics (Monte Carlo, full-tensor PCE, Smolyak PCE, adaptive sparse PCE);
- :class:`uqguide.results.result.Result` holds the statistics, diagnostics and provenance of a run
  and writes them to HDF5.

The Python API (imported on first use, so ``import uqguide`` stays cheap)::

    cfg = uqguide.load_config("ftcapn_table3")          # a file, a shipped study or a dict
    result = uqguide.run(cfg, workers=2, out="results")  # -> Result
    result = uqguide.read_result("results/ftcapn_table3.h5")
    result.to_xarray(), result.to_dataframe("omega_s")
"""

from __future__ import annotations

from typing import Any

from ._version import __version__
__all__ = ["load_config", "read_result", "run", "__version__"]


def __getattr__(name: str) -> Any:
    if name in ("load_config", "run", "read_result"):
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module 'uqguide' has no attribute {name!r}")
