"""A fitted PCE of the study as a fidelity level of :mod:`uqguide.methods.mfmc`
(``fidelities: [..., {surrogate: apce}]``).

The surrogate is evaluated here, in the driver's process, on the same rows of the method's one
input stream as every other level: it costs microseconds per run, so workers would add
pickling and nothing else, and it is a deterministic function of the rows, so the numbers are
the same on any executor. Its chunks are not checkpointed: a resumed run re-fits the PCE from
the PCE method's own checkpoint (the same bits) and evaluates it again.

Why this keeps the estimate unbiased: the PCE was fitted on its own method's runs, drawn from
that method's seed stream, independent of the ``mfmc`` rows; on those rows it is a fixed
function of the inputs like any cheaper model. How good it is decides only how much variance
it removes (its correlation with the highest level, measured in the pilot).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..core.types import ModelOutput
from ..pce.surrogate import Surrogate
from .execution import Timing


@dataclass
class SurrogateLevel:
    """The surrogate of the PCE method ``label`` as a level.

    Attributes
    ----------
    label : str
        The PCE method's label in the config.
    surrogate : Surrogate
    time : ndarray, shape (T,)
        The grid of its series outputs (the PCE method's runs' grid).
    fixed_cpu_s : float
        What the PCE method spent: its model seconds and its fit seconds (the surrogate's
        price, charged to the ``mfmc`` method's saving).
    """

    label: str
    surrogate: Surrogate
    time: np.ndarray
    fixed_cpu_s: float

    def missing(self, outputs: Sequence[str]) -> list[str]:
        """The outputs it cannot predict (no expansion kept for them)."""
        return [o for o in outputs if o not in self.surrogate.names]

    def run(self, x: np.ndarray, outputs: Sequence[str], timing: Timing) -> ModelOutput:
        """Its values at the physical inputs ``x (n, d)``; the CPU seconds go to ``timing``."""
        t0 = time.process_time()
        w0 = time.perf_counter()
        values = self.surrogate(np.asarray(x, dtype=float), list(outputs))
        n = x.shape[0]
        series = {k: v for k, v in values.items() if v.ndim == 3}
        scalars = {k: v.reshape(n, -1) for k, v in values.items() if v.ndim != 3}
        timing.cpu_seconds += time.process_time() - t0
        timing.model_seconds += time.perf_counter() - w0
        timing.n_runs += n
        return ModelOutput(time=self.time, series=series,
                           scalars=scalars, failed=np.zeros(n, dtype=bool),
                           reasons=np.full(n, "", dtype=object))
