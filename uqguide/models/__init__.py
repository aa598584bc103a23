"""Models: the contract (``base``), analytic benchmarks, simulators, and user callables."""
