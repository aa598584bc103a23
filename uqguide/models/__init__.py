"""Models, above ``stats``: the contract (``base``), benchmarks, simulators, user callables.

A program in any language is the ``command`` model (``command/``: files, process, model); an
FMU the ``fmu`` model (``fmu/``: archive, simulate, model; FMPy is an optional extra).
Both find relative paths from their config's folder (``config_dir``).
A simulator is a folder: ``model.py`` (parameters and the batch interface) and the compiled
``kernel_numba.py``, imported on first use by a ``_compiled()`` loader in the model's module
(its NumPy reference is a test oracle, ``tests/oracles/``). ``record_rows`` holds the compiled
record writers the kernels share; ``kernels`` the cache and the compile notice.
"""

# The names a model's author needs (docs/architecture.md, "A plugin package"), imported on first
# use so that importing one simulator does not import the contract's dependencies twice over.
_PUBLIC = {"Model": "base", "ModelParams": "base", "InputInfo": "base", "OutputInfo": "base",
           "StepCount": "base", "failure_reasons": "base", "ModelOutput": "base"}
__all__ = sorted(_PUBLIC)


def __getattr__(name: str) -> object:
    if name in _PUBLIC:
        from importlib import import_module

        return getattr(import_module(f"{__name__}.{_PUBLIC[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
