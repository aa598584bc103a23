"""Evaluating one chunk wherever an executor puts it: in model calls of ``batch_size`` samples,
in guard processes when a timeout or crash isolation asks, then reduced where it ran."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ...core.types import ModelOutput, RowRange
from ...models import kernels
from .chunks import ChunkJob, ChunkResult, Task
from .guard import guarded_batch
from .isolation import common_grid, evaluate_batch
from .shared_rows import write_in_place


def run_chunk(job: ChunkJob, task: Task, x: np.ndarray | RowRange) -> ChunkResult:
    """Evaluate one chunk ``x (m, d)`` in model calls of ``job.batch_size`` samples, then reduce
    it with ``job.reducer`` when there is one. Runs in whichever process the executor chose.

    Parameters
    ----------
    job : ChunkJob
    task : Task
        Which chunk (its index is passed to the reducer).
    x : ndarray or RowRange, shape (m, d)
        The chunk's rows, inputs in SI units (a RowRange is made here).

    Returns
    -------
    ChunkResult
        Failures, reasons, grid and scalars ``(m, k)``; the series ``(m, T, k)`` when not
        reduced, the reducer's summary when reduced; the seconds spent in the model and, apart,
        those spent compiling its kernel.
    """
    model = job.model.model
    x = np.asarray(x)  # a RowRange: the rows are made here
    m = x.shape[0]
    compiled_before = kernels.compile_seconds()
    t0 = time.perf_counter()
    if job.timeout_s is not None or job.guarded:
        parts = [guarded_batch(job.model, x[s:s + job.batch_size], job.names, job.outputs,
                               job.timeout_s) for s in range(0, max(m, 1), job.batch_size)]
    else:
        parts = [evaluate_batch(model, x[s:s + job.batch_size], job.names, job.outputs)
                 for s in range(0, max(m, 1), job.batch_size)]
    out = ModelOutput.concatenate(common_grid(parts))
    # a first call that compiles the kernel is timed as compiling, not as running the model
    compiled = kernels.compile_seconds() - compiled_before
    seconds = max(time.perf_counter() - t0 - compiled, 0.0)
    if job.reducer is None:
        return ChunkResult(task, out.failed, out.reasons, out.time, out.scalars, out.series,
                           model_seconds=seconds, compile_seconds=compiled)
    summary = job.reducer(out, task.index)
    result = ChunkResult(task, out.failed, out.reasons, out.time, out.scalars,
                         summary=summary, model_seconds=seconds, compile_seconds=compiled)
    return write_in_place(job.shared, result) if job.shared is not None else result


def isolate_crash(job: ChunkJob, task: Task, x: np.ndarray) -> ChunkResult:
    """Re-run a chunk that killed its worker, in this process, its model calls in guard
    processes bisected down to the samples that crash: they fail alone, with the reason.

    Parameters
    ----------
    job : ChunkJob
    task : Task
    x : ndarray, shape (m, d)
        The chunk's rows.

    Returns
    -------
    ChunkResult
        As :func:`run_chunk` gives.
    """
    return run_chunk(replace(job, guarded=True), task, x)


def warm_up() -> None:
    """A worker's first task when the pool is started ahead of the run: the imports every
    chunk needs (numba is imported here after the worker's initializer capped its threads)."""
    import numba  # noqa: F401
