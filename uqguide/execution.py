"""How model runs execute: the batch is split into chunks, evaluated, and put back in order.

The split does not change any number (models are deterministic per sample and vectorised over
the batch), so the chunk size is a memory / granularity setting only. A chunk whose evaluation
raises is not allowed to sink the run: its samples are marked failed with the exception as the
reason, and the run goes on. A :class:`~uqguide.errors.ModelError` (a model breaking its own
contract) is a bug and propagates.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Collection, Sequence
from dataclasses import dataclass

import numpy as np

from .errors import ModelError
from .models.base import Model, ModelOutput

log = logging.getLogger(__name__)


@dataclass
class Timing:
    """Wall-clock seconds spent in the model, accumulated over calls."""

    model_seconds: float = 0.0
    n_runs: int = 0


class SerialExecutor:
    """Evaluates chunks one after another in this process.

    Parameters
    ----------
    batch_size : int
        Samples per model call (memory / cache granularity; does not change the numbers).
    """

    def __init__(self, batch_size: int = 10_000) -> None:
        self.batch_size = batch_size

    def evaluate(self, model: Model, x: np.ndarray, names: Sequence[str],
                 outputs: Collection[str], timing: Timing | None = None) -> ModelOutput:
        """Evaluate ``model`` on ``x (n, d)`` chunk by chunk; returns the joined output."""
        n = x.shape[0]
        parts = []
        t0 = time.perf_counter()
        for start in range(0, max(n, 1), self.batch_size):
            chunk = x[start:start + self.batch_size]
            parts.append(_evaluate_chunk(model, chunk, names, outputs))
        out = ModelOutput.concatenate(parts)
        if timing is not None:
            timing.model_seconds += time.perf_counter() - t0
            timing.n_runs += n
        return out


def _evaluate_chunk(model: Model, x: np.ndarray, names: Sequence[str],
                    outputs: Collection[str]) -> ModelOutput:
    try:
        return model.evaluate(x, names, outputs)
    except ModelError:
        raise
    except Exception as exc:  # noqa: BLE001 - a failing chunk is recorded, not fatal
        reason = f"{type(exc).__name__}: {exc}"
        log.warning("model '%s' raised on a chunk of %d samples: %s", model.name, len(x), reason)
        return failed_output(model, x.shape[0], outputs, reason)


def failed_output(model: Model, n: int, outputs: Collection[str], reason: str) -> ModelOutput:
    """An all-failed ModelOutput of the right shapes (NaN values), for a chunk that raised.

    The time grid comes from the model's nominal evaluation when it has time series.
    """
    infos = [model.output_info(o) for o in outputs]
    time_grid = np.zeros(0)
    if any(i.kind == "series" for i in infos):
        probe = model.evaluate(np.zeros((1, 0)), [], outputs)
        time_grid = probe.time
    T = time_grid.shape[0]
    return ModelOutput(
        time=time_grid,
        series={i.name: np.full((n, T, i.k), np.nan) for i in infos if i.kind == "series"},
        scalars={i.name: np.full((n, i.k), np.nan) for i in infos if i.kind == "scalar"},
        failed=np.ones(n, dtype=bool),
        reasons=np.full(n, reason, dtype=object),
    )
