"""The simulators' NumPy reference kernels, kept as test oracles.

Each ``<model>.py`` here is an independently written NumPy version of the compiled closed loop
in ``uqguide/models/<model>/kernel_numba.py``: same arguments, same results to round-off (the
same arithmetic in another order, as another compiler or CPU would order it). The tests compare
the two, and :func:`substituted` runs a model on its oracle instead of its compiled kernel,
which is how the round-off check (``tests/test_roundoff_robustness.py``,
``scripts/update_golden.py``) reruns the golden baselines and paper checks.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator
from contextlib import contextmanager

#: Where each model loads its compiled kernel (a module-level ``_compiled()`` loader) and the
#: oracle that takes its place: module, function.
ORACLES: dict[str, tuple[str, str]] = {
    "uqguide.models.ftcapn.model": ("tests.oracles.ftcapn", "simulate_numpy"),
    "uqguide.models.gmm.model": ("tests.oracles.gmm", "simulate"),
    "uqguide.models.gmm_ftc.model": ("tests.oracles.gmm_ftc", "run_closed_loop"),
    "uqguide.models.ft_as.runner": ("tests.oracles.ft_as", "simulate"),
}


@contextmanager
def substituted() -> Iterator[None]:
    """Every model in :data:`ORACLES` runs its NumPy oracle inside the block (this process)."""
    saved = []
    try:
        for where, (module, name) in ORACLES.items():
            target = importlib.import_module(where)
            oracle = getattr(importlib.import_module(module), name)
            saved.append((target, target._compiled))
            target._compiled = lambda oracle=oracle: oracle
        yield
    finally:
        for target, loader in saved:
            target._compiled = loader
