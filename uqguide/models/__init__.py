"""Models, above ``stats``: the contract (``base``), benchmarks, simulators, user callables.

A program in any language is the ``command`` model (``command/``: files, process, model); an
FMU the ``fmu`` model (``fmu/``: archive, simulate, model; FMPy is an optional extra).
Both find relative paths from their config's folder (``config_dir``).
A simulator is a folder: ``model.py`` (parameters and the batch interface) and the compiled
``kernel_numba.py``, imported on first use by a ``_compiled()`` loader in the model's module
(its NumPy reference is a test oracle, ``tests/oracles/``). ``record_rows`` holds the compiled
record writers the kernels share; ``kernels`` the cache and the compile notice.
"""
