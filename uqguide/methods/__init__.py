"""Uncertainty-propagation methods, above ``pce``.

- ``base``: the contract. A ``Method`` designs its runs and propagates them through the
  driver's runner (by default: evaluate, refine, estimate); a ``StreamingMethod`` is estimated
  instead from chunks reduced where they ran and folded in chunk order;
- ``monte_carlo`` (a streaming method): its design, a chunk's sums where it ran, the driver's
  merge of them and the error budget;
- ``pce_quadrature`` (``pce_tensor``, ``pce_smolyak``), ``pce_adaptive``, with
  ``pce_validated`` (the PCEs' shared step: keep, validate, correct, withhold);
- ``subset_simulation``: a rare event's probability;
- ``sobol_saltelli`` (a streaming method): first-order and total Sobol' indices of a
  pick-freeze design, Monte Carlo moments of its ``A`` and ``B`` rows;
- ``mfmc``: multi-fidelity Monte Carlo over fidelity levels of one model (pilot, allocation,
  main runs: its own ``propagate``).

Each method is registered by name in ``uqguide.config.registry``.
"""

# The names a method's author needs (docs/architecture.md, "A plugin package"), imported on first
# use.
_PUBLIC = {"Method": "base", "StreamingMethod": "base", "MethodSettings": "base",
           "Design": "base", "RunPlan": "base", "RunContext": "base", "GivenRows": "base",
           "Estimate": "base", "ModelOutput": "base", "GeneratedRows": "base"}
__all__ = sorted(_PUBLIC)


def __getattr__(name: str) -> object:
    if name in _PUBLIC:
        from importlib import import_module

        return getattr(import_module(f"{__name__}.{_PUBLIC[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
