"""How model runs execute: chunks, in this process, in a local process pool, or on Dask.

A design's rows are split into **chunks** (:class:`Task`: rows ``[start, stop)``); the method
decides the split (Monte Carlo: its random-stream chunks, so statistics are reduced per chunk
the same way wherever they run; other methods: ``batch_size`` slices). A chunk is evaluated by
:func:`run_chunk` wherever the executor puts it, in model calls of at most ``batch_size``
samples (memory only), and optionally reduced there to small mergeable summaries (the method's
``reduce``), so a worker sends back per-sample scalars and sums, not time series.

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
  is re-run here with its model calls in guard processes (:mod:`uqguide.guard`), bisected down
  to the samples that crash: they fail alone with the reason, the others keep their values;
- on Dask, a chunk whose workers keep dying (``KilledWorker``) is isolated likewise;
- with the config's ``timeout_s``, every model call runs in a guard process and a call that
  does not return in time is killed and bisected the same way: a hanging sample costs itself.

A :class:`~uqguide.errors.ModelError` (a model breaking its own contract) is a bug and
propagates.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Collection, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from .errors import ConfigError, ModelError
from .models.base import Model, ModelOutput

log = logging.getLogger(__name__)

#: Samples per model call when neither the config nor the executor says otherwise.
DEFAULT_BATCH_SIZE = 10_000


@dataclass
class Timing:
    """Seconds spent in the model, summed over chunks (worker-seconds: with ``w`` workers busy
    this grows ``w`` times faster than the wall clock), and the number of runs."""

    model_seconds: float = 0.0
    n_runs: int = 0


@dataclass(frozen=True)
class Task:
    """One chunk of a design: rows ``[start, stop)`` of ``x``, chunk number ``index``."""

    index: int
    start: int
    stop: int

    @property
    def n(self) -> int:
        return self.stop - self.start


class Reducer(Protocol):
    """Turns a chunk's outputs into small named arrays where the chunk ran (picklable)."""

    def __call__(self, out: ModelOutput, index: int) -> dict[str, np.ndarray]: ...


@dataclass
class ChunkResult:
    """What comes back from one chunk.

    Attributes
    ----------
    task : Task
    failed : ndarray of bool, shape (m,)
    reasons : ndarray of object, shape (m,)
    time : ndarray, shape (T,)
        The model's grid (may be empty when every sample of the chunk failed).
    scalars : dict of str to ndarray, shape (m, k)
    series : dict of str to ndarray, shape (m, T, k)
        Empty when the chunk was reduced.
    summary : dict of str to ndarray
        The method's reduction of the chunk (empty when not reduced).
    model_seconds : float
        Wall seconds of the model calls of this chunk.
    """

    task: Task
    failed: np.ndarray
    reasons: np.ndarray
    time: np.ndarray
    scalars: dict[str, np.ndarray]
    series: dict[str, np.ndarray] = field(default_factory=dict)
    summary: dict[str, np.ndarray] = field(default_factory=dict)
    model_seconds: float = 0.0

    @property
    def n_failed(self) -> int:
        return int(np.sum(self.failed))

    def output(self) -> ModelOutput:
        return ModelOutput(time=self.time, series=self.series, scalars=self.scalars,
                           failed=self.failed, reasons=self.reasons)


# ---------------------------------------------------------------------------- the model in workers
_MODEL_CACHE: dict[tuple[str, str], Model] = {}


class ModelHandle:
    """A model that travels to worker processes as its registered name and parameters.

    Rebuilding in the worker (once per process: cached) avoids pickling whatever a simulator
    keeps (compiled kernels, caches); a model that is not the registered class of its name
    (a test's own subclass) is pickled whole.
    """

    def __init__(self, model: Model) -> None:
        self.model = model

    def __getstate__(self) -> dict[str, Any]:
        from .registry import MODELS, model_class

        m = self.model
        if m.name in MODELS and model_class(m.name) is type(m):
            return {"name": m.name, "params": m.params.model_dump_json()}
        return {"model": m}

    def __setstate__(self, state: dict[str, Any]) -> None:
        if "model" in state:
            self.model = state["model"]
            return
        key = (state["name"], state["params"])
        if key not in _MODEL_CACHE:
            from .registry import model_class

            cls = model_class(state["name"])
            _MODEL_CACHE[key] = cls(cls.Params.model_validate_json(state["params"]))
        self.model = _MODEL_CACHE[key]


@dataclass
class ChunkJob:
    """What every chunk of one design shares (sent along with each chunk; small)."""

    model: ModelHandle
    names: tuple[str, ...]
    outputs: tuple[str, ...]
    batch_size: int
    reducer: Reducer | None = None
    #: Seconds a model call may take; set, every call runs in a guard process
    #: (:mod:`uqguide.guard`) and a call that hangs or crashes fails only its samples.
    timeout_s: float | None = None
    #: Run the calls in a guard process even without a timeout (crash isolation).
    guarded: bool = False


def run_chunk(job: ChunkJob, task: Task, x: np.ndarray) -> ChunkResult:
    """Evaluate one chunk ``x (m, d)`` in model calls of ``job.batch_size`` samples, then reduce
    it with ``job.reducer`` when there is one. Runs in whichever process the executor chose."""
    model = job.model.model
    m = x.shape[0]
    t0 = time.perf_counter()
    if job.timeout_s is not None or job.guarded:
        from .guard import guarded_batch

        parts = [guarded_batch(job.model, x[s:s + job.batch_size], job.names, job.outputs,
                               job.timeout_s) for s in range(0, max(m, 1), job.batch_size)]
    else:
        parts = [evaluate_batch(model, x[s:s + job.batch_size], job.names, job.outputs)
                 for s in range(0, max(m, 1), job.batch_size)]
    out = ModelOutput.concatenate(common_grid(parts))
    seconds = time.perf_counter() - t0
    if job.reducer is None:
        return ChunkResult(task, out.failed, out.reasons, out.time, out.scalars, out.series,
                           model_seconds=seconds)
    summary = job.reducer(out, task.index)
    return ChunkResult(task, out.failed, out.reasons, out.time, out.scalars,
                       summary=summary, model_seconds=seconds)


def evaluate_batch(model: Model, x: np.ndarray, names: Sequence[str],
                   outputs: Collection[str]) -> ModelOutput:
    """``model.evaluate`` on ``x (n, d)``; samples whose evaluation raises fail alone.

    When the call raises, the batch is split in halves recursively until the raising samples
    are single (the others are evaluated normally; the model is deterministic per sample, so
    their values do not depend on the split).
    """
    pieces: list[ModelOutput | tuple[int, str]] = []
    _bisect(model, x, names, outputs, pieces)
    raised = [p[1] for p in pieces if not isinstance(p, ModelOutput)]
    if raised:
        log.warning("model '%s' raised on %d of %d samples of a batch (they fail; first: %s)",
                    model.name, len(raised), x.shape[0], raised[0])
    return assemble_pieces(model, pieces, outputs)


def assemble_pieces(model: Model, pieces: Sequence[ModelOutput | tuple[int, str]],
                    outputs: Collection[str]) -> ModelOutput:
    """One batch's output from its evaluated pieces and its failed ones (``(n, reason)``), in
    order; failed pieces get the grid of an evaluated one (or of a probe run)."""
    grid = next((p.time for p in pieces if isinstance(p, ModelOutput)), None)
    if grid is None and any(model.output_info(o).kind == "series" for o in outputs):
        grid = _probe_grid(model, outputs)
    grid = np.zeros(0) if grid is None else grid
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
    except Exception as exc:  # noqa: BLE001 - a raising model call is isolated, not fatal
        if x.shape[0] <= 1:
            pieces.append((x.shape[0], f"{type(exc).__name__}: {exc}"))
            return
    half = x.shape[0] // 2
    _bisect(model, x[:half], names, outputs, pieces)
    _bisect(model, x[half:], names, outputs, pieces)


def _probe_grid(model: Model, outputs: Collection[str]) -> np.ndarray | None:
    """The time grid of the model's nominal run (for a batch in which every sample raised)."""
    try:
        return model.evaluate(np.zeros((1, 0)), [], outputs).time
    except ModelError:
        raise
    except Exception:  # noqa: BLE001 - no grid to be had: the failed chunk carries none
        return None


def common_grid(parts: list[ModelOutput]) -> list[ModelOutput]:
    """Give all-failed parts without a grid the grid of the others, so they concatenate."""
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
    """An all-failed ModelOutput of the right shapes (NaN values) with one reason.

    ``time_grid`` defaults to the grid of the model's nominal run when it has time series (an
    empty grid if even that raises).
    """
    infos = [model.output_info(o) for o in outputs]
    if time_grid is None:
        time_grid = np.zeros(0)
        if any(i.kind == "series" for i in infos):
            probe = _probe_grid(model, outputs)
            time_grid = probe if probe is not None else time_grid
    T = time_grid.shape[0]
    return ModelOutput(
        time=time_grid,
        series={i.name: np.full((n, T, i.k), np.nan) for i in infos if i.kind == "series"},
        scalars={i.name: np.full((n, i.k), np.nan) for i in infos if i.kind == "scalar"},
        failed=np.ones(n, dtype=bool),
        reasons=np.full(n, reason, dtype=object),
    )


def isolate_crash(job: ChunkJob, task: Task, x: np.ndarray) -> ChunkResult:
    """Re-run a chunk that killed its worker, in this process, its model calls in guard
    processes bisected down to the samples that crash: they fail alone, with the reason."""
    from dataclasses import replace

    return run_chunk(replace(job, guarded=True), task, x)


# ---------------------------------------------------------------------------- executors
class Executor(Protocol):
    """Evaluates chunks and yields their results as they complete (any order)."""

    batch_size: int | None

    def map_chunks(self, job: ChunkJob, tasks: Sequence[Task],
                   x: np.ndarray) -> Iterator[ChunkResult]: ...

    def abort(self) -> None: ...

    def close(self) -> None: ...


class SerialExecutor:
    """Evaluates chunks one after another in this process.

    Parameters
    ----------
    batch_size : int, optional
        Samples per model call (memory / cache granularity; does not change the numbers);
        default the config's ``batch_size``.
    """

    def __init__(self, batch_size: int | None = None) -> None:
        self.batch_size = batch_size

    def map_chunks(self, job: ChunkJob, tasks: Sequence[Task],
                   x: np.ndarray) -> Iterator[ChunkResult]:
        for t in tasks:
            yield run_chunk(job, t, x[t.start:t.stop])

    def evaluate(self, model: Model, x: np.ndarray, names: Sequence[str],
                 outputs: Collection[str], timing: Timing | None = None) -> ModelOutput:
        """Evaluate ``model`` on ``x (n, d)`` batch by batch; returns the joined output."""
        bs = self.batch_size or DEFAULT_BATCH_SIZE
        job = ChunkJob(ModelHandle(model), tuple(names), tuple(outputs), bs)
        n = x.shape[0]
        tasks = [Task(i, s, min(n, s + bs)) for i, s in enumerate(range(0, max(n, 1), bs))]
        results = list(self.map_chunks(job, tasks, x))
        if timing is not None:
            timing.model_seconds += sum(r.model_seconds for r in results)
            timing.n_runs += n
        return ModelOutput.concatenate(common_grid([r.output() for r in results]))

    def abort(self) -> None:
        pass

    def close(self) -> None:
        from .guard import close_guards

        close_guards()


def _ignore_sigint() -> None:
    # Ctrl-C on a terminal reaches the whole process group: the driver handles it (stops and
    # leaves a resumable run); workers must not die printing tracebacks.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _init_worker(threads: int) -> None:
    """Worker start: ignore SIGINT and cap compiled kernels' threads at the worker's share of
    the cores (N workers each running an all-core numba kernel would oversubscribe the machine).
    Numba reads the variable when first imported, which in a spawned worker is after this."""
    _ignore_sigint()
    from .guard import die_with_parent

    die_with_parent()  # a driver killed (out of memory) must not leave workers holding its pipes
    os.environ.setdefault("NUMBA_NUM_THREADS", str(threads))


@contextmanager
def _sigint_ignored() -> Iterator[None]:
    """Ignore SIGINT while worker processes are started, so they inherit the ignore from birth
    (Python keeps an inherited SIG_IGN) and a Ctrl-C during their start-up cannot kill them
    with a traceback."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


class _WindowedExecutor:
    """Shared loop of the pool executors: at most ``window`` chunks in flight (bounds what
    waits in memory and lets Ctrl-C stop quickly), results yielded as they complete."""

    batch_size: int | None
    window: int

    def _submit(self, job: ChunkJob, task: Task, x: np.ndarray) -> Any:
        raise NotImplementedError

    def map_chunks(self, job: ChunkJob, tasks: Sequence[Task],
                   x: np.ndarray) -> Iterator[ChunkResult]:
        todo = list(tasks)[::-1]
        running: dict[Any, Task] = {}
        try:
            while todo or running:
                while todo and len(running) < self.window:
                    t = todo.pop()
                    running[self._submit(job, t, x[t.start:t.stop])] = t
                for fut in self._wait_some(list(running)):
                    if fut in running:  # not already taken by a crash recovery
                        task = running.pop(fut)
                        yield from self._collect(job, fut, task, running, x)
        finally:
            self._cancel(list(running))

    def abort(self) -> None:
        """Stop at once (Ctrl-C): chunks in flight are dropped, the run stays resumable."""

    def _wait_some(self, futures: list[Any]) -> list[Any]:
        raise NotImplementedError

    def _collect(self, job: ChunkJob, fut: Any, task: Task, running: dict[Any, Task],
                 x: np.ndarray) -> Iterator[ChunkResult]:
        raise NotImplementedError

    def _cancel(self, futures: list[Any]) -> None:
        for f in futures:
            f.cancel()


class ProcessExecutor(_WindowedExecutor):
    """A local pool of worker processes (``concurrent.futures``, ``spawn`` start method).

    ``spawn`` (not ``fork``): a forked child of a process holding threads (numba, BLAS, a Dask
    client) can deadlock. Workers import uqguide and rebuild the model once each.

    Parameters
    ----------
    workers : int
        Number of worker processes (>= 1).
    batch_size : int, optional
        Samples per model call; default the config's.
    """

    def __init__(self, workers: int, batch_size: int | None = None,
                 start_method: str = "spawn") -> None:
        if workers < 1:
            raise ConfigError(f"--workers: must be at least 1 (got {workers})", field="workers")
        self.workers = workers
        self.batch_size = batch_size
        self.window = 2 * workers
        self._ctx = multiprocessing.get_context(start_method)
        self._pool: ProcessPoolExecutor | None = None

    def _get_pool(self) -> ProcessPoolExecutor:
        if self._pool is None:
            threads = max(1, (os.cpu_count() or 1) // self.workers)
            self._pool = ProcessPoolExecutor(self.workers, mp_context=self._ctx,
                                             initializer=_init_worker, initargs=(threads,))
        return self._pool

    def _rebuild(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
        self._pool = None

    def _submit(self, job: ChunkJob, task: Task, x: np.ndarray) -> Future:
        with _sigint_ignored():  # a submit may start worker processes
            return self._get_pool().submit(run_chunk, job, task, x)

    def _cancel(self, futures: list[Any]) -> None:
        # Not cancelled one by one: on Ctrl-C abort() ends the workers, and Python 3.11's pool
        # then fails on futures already cancelled (InvalidStateError in its manager thread);
        # otherwise close() cancels what is left.
        pass

    def _wait_some(self, futures: list[Future]) -> list[Future]:
        done, _ = wait(futures, return_when=FIRST_COMPLETED)
        return sorted(done, key=futures.index)

    def _collect(self, job: ChunkJob, fut: Future, task: Task, running: dict[Any, Task],
                 x: np.ndarray) -> Iterator[ChunkResult]:
        try:
            yield fut.result()
            return
        except BrokenProcessPool:
            pass
        # Every chunk in flight died with the pool; which one killed it is unknown. Keep those
        # that had finished, re-run the others one at a time in fresh pools: the culprit
        # crashes again and fails alone.
        suspects = [task]
        for f in list(running):
            t = running.pop(f)
            if f.done() and not f.cancelled() and f.exception() is None:
                yield f.result()
            else:
                suspects.append(t)
        log.warning("a worker process died; re-running the %d chunks in flight one by one",
                    len(suspects))
        self._rebuild()
        for t in sorted(suspects, key=lambda t: t.index):
            try:
                yield self._submit(job, t, x[t.start:t.stop]).result()
            except BrokenProcessPool:
                log.warning("chunk %d (%d samples) crashed its worker again; finding the "
                            "sample(s) by bisection in guard processes", t.index, t.n)
                self._rebuild()
                yield isolate_crash(job, t, x[t.start:t.stop])

    def abort(self) -> None:
        if self._pool is not None:
            # concurrent.futures cannot stop a running task; the workers ignore SIGINT, so
            # end them here (Python >= 3.14 has terminate_workers() for this).
            for p in list(getattr(self._pool, "_processes", {}).values()):
                p.terminate()
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = None

    def close(self) -> None:
        from .guard import close_guards

        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
        close_guards()


class DaskExecutor(_WindowedExecutor):
    """Chunks submitted to a ``dask.distributed`` cluster.

    Each chunk is one ``client.submit(run_chunk, ..., pure=False, retries=retries)``:
    ``pure=False`` because two chunks with equal inputs must still both run (and a resubmitted
    chunk must not be served from a stale key); ``retries`` re-runs a chunk whose task raised
    (e.g. a lost connection). A chunk whose workers keep dying (Dask's ``KilledWorker`` after
    ``distributed.scheduler.allowed-failures``) fails whole with the reason. Workers need
    uqguide (and a callable model's module) importable; they never write files.

    Parameters
    ----------
    address : str, optional
        Scheduler address, e.g. ``tcp://10.0.0.5:8786``.
    scheduler_file : str, optional
        A scheduler file written by ``dask scheduler --scheduler-file``.
    client : distributed.Client, optional
        An existing client (used as is, not closed).
    batch_size : int, optional
    retries : int
    """

    def __init__(self, address: str | None = None, scheduler_file: str | None = None,
                 client: Any = None, batch_size: int | None = None, retries: int = 2) -> None:
        try:
            from distributed import Client
        except ImportError:  # pragma: no cover - depends on the installation
            raise ConfigError("--scheduler: Dask is not installed; pip install "
                              "'uqguide[dask]'", field="scheduler") from None
        self._own = client is None
        if client is None:
            try:
                client = Client(address=address, scheduler_file=scheduler_file, timeout="30s")
            except (OSError, TimeoutError, ValueError) as exc:
                where = address or scheduler_file
                raise ConfigError(f"--scheduler: cannot connect to the Dask scheduler at "
                                  f"{where} ({type(exc).__name__}: {exc})",
                                  field="scheduler") from None
        self.client = client
        self.batch_size = batch_size
        self.retries = retries
        n_threads = sum(self.client.nthreads().values()) or 1
        self.window = 2 * n_threads

    def _submit(self, job: ChunkJob, task: Task, x: np.ndarray) -> Any:
        return self.client.submit(run_chunk, job, task, x, pure=False, retries=self.retries)

    def _wait_some(self, futures: list[Any]) -> list[Any]:
        from distributed import wait as dwait

        done, _ = dwait(futures, return_when="FIRST_COMPLETED")
        return sorted(done, key=futures.index)

    def _collect(self, job: ChunkJob, fut: Any, task: Task, running: dict[Any, Task],
                 x: np.ndarray) -> Iterator[ChunkResult]:
        from distributed import KilledWorker

        try:
            yield fut.result()
        except KilledWorker as exc:
            log.warning("chunk %d (%d samples) keeps killing its workers (%s); finding the "
                        "sample(s) by bisection in guard processes here", task.index, task.n,
                        exc)
            yield isolate_crash(job, task, x[task.start:task.stop])
        finally:
            fut.release()

    def abort(self) -> None:
        pass  # the generator's cleanup cancels the chunks in flight; the cluster stays up

    def close(self) -> None:
        if self._own:
            self._own = False  # once: close() may be called again on the way out
            self.client.close()


def make_executor(workers: int | None = None, scheduler: str | None = None,
                  scheduler_file: str | None = None) -> Executor:
    """The executor the command line asked for: Dask if a scheduler is given, a process pool
    for ``workers >= 1``, else this process."""
    if scheduler and scheduler_file:
        raise ConfigError("--scheduler-file: give either --scheduler or --scheduler-file, "
                          "not both", field="scheduler_file")
    if scheduler or scheduler_file:
        if workers:
            raise ConfigError("--workers: not used with a Dask scheduler (the cluster has its "
                              "own workers)", field="workers")
        return DaskExecutor(address=scheduler, scheduler_file=scheduler_file)
    if workers:
        return ProcessExecutor(workers)
    return SerialExecutor()


__all__ = [
    "ChunkJob", "ChunkResult", "DaskExecutor", "Executor", "ModelHandle", "ProcessExecutor",
    "Reducer", "SerialExecutor", "Task", "Timing", "evaluate_batch", "failed_output",
    "make_executor", "run_chunk",
]
