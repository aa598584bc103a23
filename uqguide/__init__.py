"""uqguide: uncertainty propagation through closed-loop spacecraft guidance simulations.

The package is organised around three abstractions:

- :class:`uqguide.models.base.Model` maps a batch of input samples ``x (n, d)`` to named
  outputs (time series ``(n, T, k)`` and scalars ``(n, k)``) plus a failure mask;
- :class:`uqguide.methods.base.Method` designs the runs to make and turns the model's outputs
  into statistics (Monte Carlo, full-tensor PCE, Smolyak PCE, adaptive sparse PCE);
- :class:`uqguide.result.Result` holds the statistics, diagnostics and provenance of a run
  and writes them to HDF5.
"""

__version__ = "0.1.0"
