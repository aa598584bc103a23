"""Failure isolation inside one process: a model call that raises is split in halves until the
raising samples fail alone, with the reason; the others keep their values."""

from __future__ import annotations

import logging
import resource
import time
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ...errors import ModelError
from ...models import kernels
from ...models.base import Model
from ...core.types import ModelOutput
from .processes import memory_limited

log = logging.getLogger(__name__)


@dataclass
class Spent:
    """CPU seconds of model calls, measured in the process that made them (a guard process, a
    pool or Dask worker, the driver), with the programs it waited for (a ``command``'s), less
    ``compile_seconds`` spent compiling a kernel there."""

    cpu_seconds: float = 0.0
    compile_seconds: float = 0.0

    def add(self, other: Spent) -> None:
        self.cpu_seconds += other.cpu_seconds
        self.compile_seconds += other.compile_seconds


def _cpu_here() -> float:
    """CPU seconds of this process and of the child processes it has waited for."""
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + kids.ru_utime + kids.ru_stime


def timed_batch(model: Model, x: np.ndarray, names: Sequence[str],
                outputs: Collection[str]) -> tuple[ModelOutput, Spent]:
    """:func:`evaluate_batch` and the CPU it took here: the one place a model call's CPU is
    measured (the driver only adds up what the processes that ran the calls report)."""
    compiled, c0 = kernels.compile_seconds(), _cpu_here()
    out = evaluate_batch(model, x, names, outputs)
    compiled = kernels.compile_seconds() - compiled
    return out, Spent(max(_cpu_here() - c0 - compiled, 0.0), compiled)


def evaluate_batch(model: Model, x: np.ndarray, names: Sequence[str],
                   outputs: Collection[str]) -> ModelOutput:
    """``model.evaluate`` on ``x (n, d)``; a raising call is split in halves until the raising
    samples fail alone, with ``"ExceptionType: message"`` (the model is deterministic per
    sample, so the split does not change the others). A ModelError propagates."""
    pieces: list[ModelOutput | tuple[int, str]] = []
    _bisect(model, x, names, outputs, pieces)
    raised = [p[1] for p in pieces if not isinstance(p, ModelOutput)]
    if raised:
        log.warning("model '%s' raised on %d of %d samples of a batch (they fail; first: %s)",
                    model.name, len(raised), x.shape[0], raised[0])
    return assemble_pieces(model, pieces, outputs)


def assemble_pieces(model: Model, pieces: Sequence[ModelOutput | tuple[int, str]],
                    outputs: Collection[str]) -> ModelOutput:
    """One batch's output from its evaluated pieces and its failed ones (``(n_samples,
    reason)``), in order; failed pieces get the grid of an evaluated one (or of a probe run)."""
    grid = next((p.time for p in pieces if isinstance(p, ModelOutput)), None)
    if grid is None:
        grid = _probe_grid(model, outputs)
    parts = [p if isinstance(p, ModelOutput) else failed_output(model, p[0], outputs, p[1], grid)
             for p in pieces]
    return ModelOutput.concatenate(parts)


def _bisect(model: Model, x: np.ndarray, names: Sequence[str], outputs: Collection[str],
            pieces: list[ModelOutput | tuple[int, str]]) -> None:
    try:
        pieces.append(model.evaluate(x, names, outputs))
        return
    except ModelError:
        raise
    except MemoryError as exc:
        if memory_limited():  # a child over its limit ends: what leaked is still held here
            raise
        failure: Exception = exc
    except Exception as exc:  # noqa: BLE001 - a raising model call is isolated, not fatal
        failure = exc
    if x.shape[0] <= 1:
        pieces.append((x.shape[0], f"{type(failure).__name__}: {failure}"))
        return
    half = x.shape[0] // 2
    _bisect(model, x[:half], names, outputs, pieces)
    _bisect(model, x[half:], names, outputs, pieces)


def skipping_known(model: Model, x: np.ndarray, outputs: Collection[str],
                   known: Mapping[int, str],
                   evaluate: Callable[[np.ndarray, int], ModelOutput]) -> ModelOutput:
    """``evaluate(x)`` without the rows ``known`` (from the checkpoint) to crash or hang their
    process: they fail again with their reason, unrun; the others are evaluated in the
    stretches between them, ``evaluate(rows (m, d), first row)``."""
    rows = sorted(r for r in known if 0 <= r < x.shape[0])
    if not rows:
        return evaluate(x, 0)
    pieces: list[ModelOutput | tuple[int, str]] = []
    start = 0
    for r in rows:
        if r > start:
            pieces.append(evaluate(x[start:r], start))
        pieces.append((1, known[r]))
        start = r + 1
    if start < x.shape[0]:
        pieces.append(evaluate(x[start:], start))
    return assemble_pieces(model, pieces, outputs)


def _probe_grid(model: Model, outputs: Collection[str]) -> np.ndarray:
    """The time grid of the model's nominal run (for a batch in which every sample raised);
    empty without a series output."""
    if not any(model.output_info(o).kind == "series" for o in outputs):
        return np.zeros(0)
    try:
        return model.evaluate(np.zeros((1, 0)), [], outputs).time
    except ModelError:
        raise
    except Exception:  # noqa: BLE001 - no grid to be had: the failed chunk carries none
        return np.zeros(0)


def common_grid(parts: list[ModelOutput]) -> list[ModelOutput]:
    """Give all-failed parts without a grid NaN series on the grid of the others, so they
    concatenate."""
    grid = next((p.time for p in parts if p.time.size), None)
    if grid is None:
        return parts
    return [p if p.time.size or not p.failed.all() else _regrid(p, grid) for p in parts]


def _regrid(p: ModelOutput, grid: np.ndarray) -> ModelOutput:
    T = grid.shape[0]
    return ModelOutput(
        time=grid, scalars=p.scalars, failed=p.failed, reasons=p.reasons,
        series={k: np.full((v.shape[0], T, v.shape[2]), np.nan) for k, v in p.series.items()})


def failed_output(model: Model, n: int, outputs: Collection[str], reason: str,
                  time_grid: np.ndarray | None = None) -> ModelOutput:
    """An all-failed ModelOutput of ``n`` samples (NaN values) with one ``reason``; ``time_grid``
    defaults to the grid of the model's nominal run."""
    infos = [model.output_info(o) for o in outputs]
    if time_grid is None:
        time_grid = _probe_grid(model, outputs)
    T = time_grid.shape[0]
    return ModelOutput(
        time=time_grid,
        series={i.name: np.full((n, T, i.k), np.nan) for i in infos if i.kind == "series"},
        scalars={i.name: np.full((n, i.k), np.nan) for i in infos if i.kind == "scalar"},
        failed=np.ones(n, dtype=bool),
        reasons=np.full(n, reason, dtype=object),
    )
