"""How model runs execute: chunks, in this process, in a local process pool, or on Dask.

A design's rows are split into chunks (:class:`Task`); :func:`run_chunk` evaluates one
wherever the executor puts it, optionally reduced there to mergeable summaries. The executors
give bit-identical numbers; a failed sample, call or worker costs only its samples. Modules,
bottom up: :mod:`.transport`, :mod:`.chunks`, :mod:`.isolation`, :mod:`.processes`,
:mod:`.guard`, :mod:`.shared_rows`, :mod:`.worker`, :mod:`.cluster_watch`,
:mod:`.executors`. How each failure is contained: ``docs/scale.md#failures``.
"""

from __future__ import annotations

from .chunks import (DEFAULT_BATCH_SIZE, ChunkJob, ChunkResult, Containment, Reducer, Task,
                     Timing)
from .executors import DaskExecutor, Executor, ProcessExecutor, SerialExecutor, make_executor
from .isolation import assemble_pieces, common_grid, evaluate_batch, failed_output
from .transport import ModelHandle
from .worker import isolate_crash, join_pieces, run_chunk

__all__ = [
    "DEFAULT_BATCH_SIZE", "ChunkJob", "ChunkResult", "Containment", "DaskExecutor", "Executor",
    "ModelHandle", "ProcessExecutor", "Reducer", "SerialExecutor", "Task", "Timing",
    "assemble_pieces", "common_grid", "evaluate_batch", "failed_output", "isolate_crash",
    "join_pieces", "make_executor", "run_chunk",
]
