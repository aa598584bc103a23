"""Uncertainty-propagation methods, above ``pce``.

- ``base``: the contract. A ``Method`` designs its runs and propagates them through the
  driver's runner (by default: evaluate, refine, estimate); a ``StreamingMethod`` is estimated
  from chunks reduced where they ran, folded in chunk order;
- ``monte_carlo`` (streaming): its design, a chunk's sums, their merge and the error budget;
- ``pce_quadrature`` (``pce_tensor``, ``pce_smolyak``), ``pce_adaptive``, with
  ``pce_validated`` (the PCEs' shared step: keep, validate, correct, withhold);
- ``subset_simulation``: a rare event's probability;
- ``sobol_saltelli`` (streaming): Sobol' indices of a pick-freeze design;
- ``mfmc``: multi-fidelity Monte Carlo over a model's fidelity levels (its own ``propagate``).

Each method is registered under the entry point group ``uqguide.methods``; ``docs/methods.md``.
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
