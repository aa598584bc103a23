"""Evaluating one chunk wherever an executor puts it: in model calls of ``batch_size`` samples,
in guard processes when a timeout or crash isolation asks, then reduced where it ran."""

from __future__ import annotations

import logging
import os
import time
from dataclasses import replace

import numpy as np

from ...core.types import ModelOutput, RowRange
from ...errors import WorkerStartError
from .chunks import ChunkJob, ChunkResult, Task
from .guard import GuardUnavailable, guard_for, guarded_batch
from .isolation import Spent, common_grid, skipping_known, timed_batch
from .processes import OVER_MEMORY_EXIT, limit_memory
from .shared_rows import write_in_place

log = logging.getLogger(__name__)


def _evaluate(job: ChunkJob, rows: np.ndarray, first: int, spent: Spent) -> ModelOutput:
    """One model call on ``rows``, the stretch of the design starting at row ``first``: in a
    guard process when the job asks for one, else here; ``spent`` incremented by its CPU
    where it ran."""
    if job.timeout_s is not None or job.guarded:
        guard = guard_for(job.timeout_s, job.memory_limit)
        if not (job.guard_fallback and guard.unavailable):
            tell = job.on_isolated
            told = None if tell is None else (lambda r, why: tell(first + r, why))
            try:
                return guarded_batch(job.model, rows, job.names, job.outputs, job.timeout_s,
                                     job.memory_limit, told, spent)
            except (GuardUnavailable, WorkerStartError) as exc:
                if not job.guard_fallback:
                    raise
                guard.unavailable = str(exc)
                log.warning("model '%s' runs in this process: %s. A sample that crashes its "
                            "process ends the run (resumable)", job.model.model.name, exc)
    out, here = timed_batch(job.model.model, rows, job.names, job.outputs)
    spent.add(here)
    return out


def run_chunk(job: ChunkJob, task: Task, x: np.ndarray | RowRange) -> ChunkResult:
    """Evaluate one chunk ``x (m, d)`` (SI units; a RowRange is made here) in model calls of
    ``job.batch_size`` samples, then reduce it with ``job.reducer`` (given the chunk's index)
    when there is one, in whichever process the executor chose."""
    model = job.model.model
    x = np.asarray(x)  # a RowRange: the rows are made here
    m = x.shape[0]
    spent = Spent()
    t0 = time.perf_counter()
    known = {r - task.start: why for r, why in job.known.items() if task.start <= r < task.stop}
    parts = []
    for s in range(0, max(m, 1), job.batch_size):
        here = {r - s: why for r, why in known.items() if s <= r < s + job.batch_size}

        def call(rows: np.ndarray, at: int, first: int = task.start + s) -> ModelOutput:
            return _evaluate(job, rows, first + at, spent)

        parts.append(skipping_known(model, x[s:s + job.batch_size], job.outputs, here, call))
    # a first call that compiles the kernel is timed as compiling, not as running the model
    compiled = spent.compile_seconds
    return _finish(job, task, parts, max(time.perf_counter() - t0 - compiled, 0.0), compiled,
                   spent.cpu_seconds)


def join_pieces(job: ChunkJob, task: Task, pieces: list[ChunkResult]) -> ChunkResult:
    """The chunk ``task`` from the unreduced results of model calls that cover its rows in
    order (its pieces, :mod:`uqguide.driver.pieces`), reduced as :func:`run_chunk` reduces
    it: the same rows joined, so the same numbers."""
    return _finish(job, task, [p.output() for p in pieces],
                   sum(p.model_seconds for p in pieces), sum(p.compile_seconds for p in pieces),
                   sum(p.cpu_seconds for p in pieces))


def _finish(job: ChunkJob, task: Task, parts: list[ModelOutput], model_seconds: float,
            compile_seconds: float, cpu_seconds: float) -> ChunkResult:
    """The chunk's result from the outputs of its model calls, reduced when the job says."""
    out = ModelOutput.concatenate(common_grid(parts))
    result = ChunkResult(task, out.failed, out.reasons, out.time, out.scalars, out.series,
                         model_seconds=model_seconds, compile_seconds=compile_seconds,
                         cpu_seconds=cpu_seconds)
    if job.reducer is None:
        return result
    result = replace(result, series={}, summary=job.reducer(out, task.index))
    return write_in_place(job.shared, result) if job.shared is not None else result


def run_chunk_in_worker(job: ChunkJob, task: Task, x: np.ndarray | RowRange) -> ChunkResult:
    """:func:`run_chunk` in a pool worker capped at ``job.memory_limit``: over it, the worker
    ends like a crash instead of failing every later sample with the memory still held."""
    limit_memory(job.memory_limit)
    try:
        return run_chunk(job, task, x)
    except MemoryError:
        os._exit(OVER_MEMORY_EXIT)


def isolate_crash(job: ChunkJob, task: Task, x: np.ndarray) -> ChunkResult:
    """Re-run a chunk ``x (m, d)`` that killed its worker, in this process, its model calls in
    guard processes bisected down to the samples that crash: they fail alone, with the reason."""
    return run_chunk(replace(job, guarded=True), task, x)


def warm_up() -> None:
    """A worker's first task when the pool is started ahead of the run: the imports every
    chunk needs (numba is imported here after the worker's initializer capped its threads)."""
    import numba  # noqa: F401
