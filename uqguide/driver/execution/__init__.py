"""How model runs execute: chunks, in this process, in a local process pool, or on Dask.

A design's rows are split into **chunks** (:class:`Task`: rows ``[start, stop)``); the method
decides the split (Monte Carlo: its random-stream chunks, so statistics are reduced per chunk
the same way wherever they run; other methods: ``batch_size`` slices). A chunk is evaluated by
:func:`run_chunk` wherever the executor puts it, in model calls of at most ``batch_size``
samples (memory only), and optionally reduced there to small mergeable summaries (the method's
``reduce``), so a worker sends back per-sample scalars and sums, not time series. A local
process pool's workers write the per-sample values (scalars, values kept for quantiles) in
place, into the driver's arrays in shared memory, and send only the sums
(:mod:`.shared_rows`).

Executors (all give bit-identical numbers, since a chunk's result does not depend on where it
ran and the driver folds chunks in index order):

- :class:`SerialExecutor`: this process (default);
- :class:`ProcessExecutor`: a ``concurrent.futures`` pool of ``spawn`` processes;
- :class:`DaskExecutor`: a ``dask.distributed`` cluster (``pure=False``, ``retries``).

Only the driver writes files. Failures never sink a run:

- a sample the model flags (non-finite state, integrator bound) stays flagged with its reason;
- a model call that raises (a user's callable) is split in halves until the raising samples are
  single; they fail with ``"ExceptionType: message"``, the others keep their values (extra cost
  only on failure: at most ``2 k log2(m)`` calls for ``k`` raising samples of ``m``);
- a worker process that dies (segfault, ``os._exit``, out-of-memory kill) breaks the pool: the
  chunks in flight are re-run one at a time in a fresh pool; the one that kills its worker again
  is re-run here with its model calls in guard processes (:mod:`uqguide.driver.execution.guard`),
  bisected down to the samples that crash: they fail alone with the reason, the others keep
  their values;
- on Dask, a chunk whose workers keep dying (``KilledWorker``) is isolated likewise;
- with the config's ``timeout_s``, every model call runs in a guard process and a call that
  does not return in time is killed and bisected the same way: a hanging sample costs itself;
- without workers, a model that can crash its process (every ``callable``, any model with
  ``isolate: true``) runs its calls in a guard process too, so a segfault costs the samples
  that crash even serially; the built-in simulators keep the fast path in this process;
- the samples found to crash or hang are recorded in the run folder as they are found, and a
  resume fails them with the recorded reason without running them again;
- child processes (guards, pool workers) are capped at the run's ``max_memory``
  (``RLIMIT_AS``): a model that leaks ends its process, and is bisected like a crash.

A :class:`~uqguide.errors.ModelError` (a model breaking its own contract) is a bug and
propagates.

Modules, from the bottom up: :mod:`.transport` (the model in workers), :mod:`.chunks` (the
unit of work), :mod:`.isolation` (raising samples fail alone), :mod:`.processes` (signals and
lifetimes of child processes), :mod:`.guard` (timeouts and crashes), :mod:`.row_layout` and
:mod:`.shared_rows` (per-sample values written in place), :mod:`.worker` (one chunk, wherever
it runs), :mod:`.cluster_watch` (a Dask cluster gone) and :mod:`.executors`.
"""

from __future__ import annotations

from .chunks import (DEFAULT_BATCH_SIZE, ChunkJob, ChunkResult, Containment, Reducer, Task,
                     Timing)
from .executors import DaskExecutor, Executor, ProcessExecutor, SerialExecutor, make_executor
from .isolation import assemble_pieces, common_grid, evaluate_batch, failed_output
from .transport import ModelHandle
from .worker import isolate_crash, run_chunk

__all__ = [
    "DEFAULT_BATCH_SIZE", "ChunkJob", "ChunkResult", "Containment", "DaskExecutor", "Executor",
    "ModelHandle", "ProcessExecutor", "Reducer", "SerialExecutor", "Task", "Timing",
    "assemble_pieces", "common_grid", "evaluate_batch", "failed_output", "isolate_crash",
    "make_executor", "run_chunk",
]
