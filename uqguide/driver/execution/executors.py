"""Executors: where chunks run (this process, a local process pool, a Dask cluster). All give
bit-identical numbers: a chunk's result does not depend on where it ran, and the driver folds
chunks in index order."""

from __future__ import annotations

import logging
import multiprocessing
import os
from collections.abc import Collection, Iterator, Sequence
from contextlib import contextmanager
from concurrent.futures import (FIRST_COMPLETED, CancelledError, Future, ProcessPoolExecutor,
                                wait)
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Protocol

import numpy as np

from ...errors import ClusterLost, ConfigError, WorkerStartError
from ...models.base import Model
from ...core.temp_folders import multiprocessing_folder
from ...core.types import GeneratedRows, ModelOutput, RowRange
from .cluster_watch import (NO_WORKERS_TIMEOUT, NoWorkerWatch, cancelled_message,
                            scheduler_lost)
from .chunks import DEFAULT_BATCH_SIZE, ChunkJob, ChunkResult, Task, Timing
from .guard import close_guards
from .isolation import common_grid
from .processes import WORKERS_DID_NOT_START, init_worker, sigint_ignored
from .transport import ModelHandle
from .worker import isolate_crash, run_chunk, run_chunk_in_worker, warm_up

log = logging.getLogger(__name__)


class Executor(Protocol):
    """Evaluates chunks and yields their results as they complete (any order)."""

    batch_size: int | None
    #: Workers on this machine, in other processes: they can write per-run values into shared
    #: memory (:mod:`uqguide.driver.execution.shared_rows`) instead of sending them.
    shares_memory: bool

    def map_chunks(self, job: ChunkJob, tasks: Sequence[Task],
                   x: np.ndarray | GeneratedRows) -> Iterator[ChunkResult]:
        """Evaluate the chunks ``tasks`` (rows ``[start, stop)`` of the design ``x (n, d)``, SI
        units, only those rows read), yielding one ChunkResult per task in the order they complete
        (the driver folds them by index)."""
        ...

    def abort(self) -> None: ...

    def close(self) -> None: ...


class SerialExecutor:
    """Evaluates chunks one after another in this process. ``batch_size``: samples per model
    call (memory only, never the numbers), default the config's."""

    shares_memory = False  # nothing to share: the values are in this process already
    #: A crashing model call would take the driver with it: the driver puts the calls of a
    #: model that may crash in a guard process (:mod:`.guard`).
    in_process = True

    def __init__(self, batch_size: int | None = None) -> None:
        self.batch_size = batch_size

    def map_chunks(self, job: ChunkJob, tasks: Sequence[Task],
                   x: np.ndarray | GeneratedRows) -> Iterator[ChunkResult]:
        """Evaluate the chunks here, in order (see :meth:`Executor.map_chunks`)."""
        for t in tasks:
            yield run_chunk(job, t, x[t.start:t.stop])

    def evaluate(self, model: Model, x: np.ndarray, names: Sequence[str],
                 outputs: Collection[str], timing: Timing | None = None) -> ModelOutput:
        """Evaluate ``model`` batch by batch on ``x (n, d)`` (SI units, column ``j`` for
        ``names[j]``), samples that raise isolated; ``timing`` is incremented by the model seconds
        and the ``n`` runs."""
        bs = self.batch_size or DEFAULT_BATCH_SIZE
        job = ChunkJob(ModelHandle(model), tuple(names), tuple(outputs), bs)
        n = x.shape[0]
        tasks = [Task(i, s, min(n, s + bs)) for i, s in enumerate(range(0, max(n, 1), bs))]
        results = list(self.map_chunks(job, tasks, x))
        if timing is not None:
            timing.model_seconds += sum(r.model_seconds for r in results)
            timing.compile_seconds += sum(r.compile_seconds for r in results)
            timing.n_runs += n
        return ModelOutput.concatenate(common_grid([r.output() for r in results]))

    def abort(self) -> None:
        pass

    def close(self) -> None:
        close_guards()


class _WindowedExecutor:
    """Shared loop of the pool executors: at most ``window`` chunks in flight (bounds what
    waits in memory and lets Ctrl-C stop quickly), results yielded as they complete."""

    batch_size: int | None
    window: int

    def _submit(self, job: ChunkJob, task: Task, x: np.ndarray | RowRange) -> Any:
        raise NotImplementedError

    def map_chunks(self, job: ChunkJob, tasks: Sequence[Task],
                   x: np.ndarray | GeneratedRows) -> Iterator[ChunkResult]:
        todo = list(tasks)[::-1]
        running: dict[Any, Task] = {}
        try:
            while todo or running:
                while todo and len(running) < self.window:
                    t = todo.pop()
                    # a design made on demand is made by the worker (RowRange), not here
                    rows = x.lazy(t.start, t.stop) if isinstance(x, GeneratedRows) else \
                        x[t.start:t.stop]
                    running[self._submit(job, t, rows)] = t
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
                 x: np.ndarray | GeneratedRows) -> Iterator[ChunkResult]:
        raise NotImplementedError

    def _cancel(self, futures: list[Any]) -> None:
        for f in futures:
            f.cancel()


class ProcessExecutor(_WindowedExecutor):
    """A local pool of ``workers`` processes (``concurrent.futures``, ``spawn`` start method).

    ``spawn`` (not ``fork``): a forked child of a process holding threads (numba, BLAS, a Dask
    client) can deadlock. Workers import uqguide and rebuild the model once each.
    """

    shares_memory = True

    def __init__(self, workers: int, batch_size: int | None = None,
                 start_method: str = "spawn") -> None:
        if workers < 1:
            raise ConfigError(f"--workers: must be at least 1 (got {workers})", field="workers")
        self.workers = workers
        self.batch_size = batch_size
        self.window = 2 * workers
        multiprocessing_folder()  # before the workers start: they inherit it
        self._ctx = multiprocessing.get_context(start_method)
        self._pool: ProcessPoolExecutor | None = None
        self._started = self._ctx.Event()

    def _get_pool(self) -> ProcessPoolExecutor:
        if self._pool is None:
            threads = max(1, (os.cpu_count() or 1) // self.workers)
            self._pool = ProcessPoolExecutor(self.workers, mp_context=self._ctx,
                                             initializer=init_worker,
                                             initargs=(threads, self._started))
        return self._pool

    def start(self) -> None:
        """Start the worker processes now, so they import uqguide and numba while the driver
        still checks the config and opens the run folder."""
        pool = self._get_pool()
        with sigint_ignored():
            for _ in range(self.workers):
                pool.submit(warm_up)

    def _drop_pool(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
        self._pool = None

    def _submit(self, job: ChunkJob, task: Task, x: np.ndarray | RowRange) -> Future:
        with sigint_ignored():  # a submit may start worker processes
            return self._get_pool().submit(run_chunk_in_worker, job, task, x)

    def _cancel(self, futures: list[Any]) -> None:
        # Not cancelled one by one: on Ctrl-C abort() ends the workers, and Python 3.11's pool
        # then fails on futures already cancelled (InvalidStateError in its manager thread);
        # otherwise close() cancels what is left.
        pass

    def _wait_some(self, futures: list[Future]) -> list[Future]:
        done, _ = wait(futures, return_when=FIRST_COMPLETED)
        return sorted(done, key=futures.index)

    def _collect(self, job: ChunkJob, fut: Future, task: Task, running: dict[Any, Task],
                 x: np.ndarray | GeneratedRows) -> Iterator[ChunkResult]:
        try:
            yield fut.result()
            return
        except BrokenProcessPool:
            if not self._started.is_set():
                # No worker ever started: fresh pools would die the same way, so bisecting
                # the chunks in them would only repeat the death once per sample.
                raise WorkerStartError(WORKERS_DID_NOT_START) from None
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
        self._drop_pool()
        for t in sorted(suspects, key=lambda t: t.index):
            try:
                yield self._submit(job, t, x[t.start:t.stop]).result()
            except BrokenProcessPool:
                log.warning("chunk %d (%d samples) crashed its worker again; finding the "
                            "sample(s) by bisection in guard processes", t.index, t.n)
                self._drop_pool()
                yield isolate_crash(job, t, x[t.start:t.stop])

    def abort(self) -> None:
        if self._pool is not None:
            # concurrent.futures cannot stop a running task; the workers ignore SIGINT, so
            # end them here (Python >= 3.14 has terminate_workers() for this).
            for p in list(getattr(self._pool, "_processes", {}).values()):
                p.terminate()
            # Wait for the pool's manager thread to see its workers gone and release the
            # queues' semaphores; otherwise an exit right after leaves them to the resource
            # tracker, which warns on stderr after the interrupted run's last line.
            self._drop_pool()

    def close(self) -> None:
        self._drop_pool()
        close_guards()


class DaskExecutor(_WindowedExecutor):
    """Chunks submitted to a ``dask.distributed`` cluster (``address``, e.g.
    ``tcp://10.0.0.5:8786``, a ``scheduler_file`` or an existing ``client``, not closed).

    Each chunk is one ``client.submit(..., pure=False, retries=retries)`` (``pure=False``: two
    chunks with equal inputs must both run, a resubmitted one not be served from a stale key).
    A cluster without a worker for ``no_workers_timeout`` seconds, or a lost scheduler, stops
    the run with :class:`~uqguide.errors.ClusterLost`. How it behaves: ``docs/scale.md``.
    """

    shares_memory = False  # workers may be on other machines

    def __init__(self, address: str | None = None, scheduler_file: str | None = None,
                 client: Any = None, batch_size: int | None = None, retries: int = 2,
                 no_workers_timeout: float = NO_WORKERS_TIMEOUT) -> None:
        if not 0 < no_workers_timeout < float("inf"):
            raise ConfigError(f"--no-workers-timeout: must be a positive number of seconds "
                              f"(got {no_workers_timeout})", field="no_workers_timeout")
        try:
            from distributed import Client
        except ImportError:  # pragma: no cover - depends on the installation
            raise ConfigError("--scheduler: Dask is not installed; pip install "
                              "'uqguide[dask]'", field="scheduler") from None
        self._own = client is None
        if not logging.getLogger().isEnabledFor(logging.INFO):
            # Dask's own handler logs at INFO (a lost scheduler's "Batched Comm Closed" with
            # its traceback, before the run's one line): at uqguide's default verbosity only
            # its warnings pass; -v shows the rest.
            logging.getLogger("distributed").setLevel(logging.WARNING)
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
        where = getattr(getattr(client, "scheduler", None), "address", None)
        self.where = str(where or address or scheduler_file)
        self.watch = NoWorkerWatch(self._count_workers, no_workers_timeout, self.where)
        self._lost = False

    def map_chunks(self, job: ChunkJob, tasks: Sequence[Task],
                   x: np.ndarray | GeneratedRows) -> Iterator[ChunkResult]:
        try:
            yield from super().map_chunks(job, tasks, x)
        except ClusterLost:
            self._lost = True
            raise

    def _connected(self) -> bool:
        return getattr(self.client, "status", "running") == "running"

    def _count_workers(self) -> int | None:
        """Workers the scheduler has now; None when the client lost its scheduler."""
        if not self._connected():
            return None
        try:
            # a scheduler that stopped answering (its host gone without closing the
            # connection) counts as no worker: the watch's clock then runs
            nthreads = self.client.sync(self.client.scheduler.ncores,
                                        callback_timeout=min(10.0, self.watch.timeout / 2))
        except (OSError, TimeoutError):
            return 0
        return len(nthreads)

    def _submit(self, job: ChunkJob, task: Task, x: np.ndarray | RowRange) -> Any:
        return self.client.submit(run_chunk, job, task, x, pure=False, retries=self.retries)

    def _wait_some(self, futures: list[Any]) -> list[Any]:
        from distributed import TimeoutError as DaskTimeout
        from distributed import wait as dwait

        while True:
            try:
                done, _ = dwait(futures, timeout=self.watch.poll_seconds,
                                return_when="FIRST_COMPLETED")
            except CancelledError as exc:  # Dask cancels every future of a lost scheduler
                raise ClusterLost(cancelled_message(exc, self.where, self._connected())) \
                    from None
            except (DaskTimeout, TimeoutError):
                self.watch.check()
                continue
            self.watch.saw_worker()  # a chunk came back
            return sorted(done, key=futures.index)

    def _collect(self, job: ChunkJob, fut: Any, task: Task, running: dict[Any, Task],
                 x: np.ndarray | GeneratedRows) -> Iterator[ChunkResult]:
        from distributed import KilledWorker
        from distributed.comm import CommClosedError

        try:
            result = fut.result()
        except KilledWorker as exc:
            log.warning("chunk %d (%d samples) keeps killing its workers (%s); finding the "
                        "sample(s) by bisection in guard processes here", task.index, task.n,
                        exc)
            result = isolate_crash(job, task, x[task.start:task.stop])
        except CancelledError as exc:
            raise ClusterLost(cancelled_message(exc, self.where, self._connected())) from None
        except CommClosedError:  # the scheduler died while the result was fetched
            raise ClusterLost(f"{scheduler_lost(self.where)} (while fetching chunk "
                              f"{task.index})") from None
        except _no_worker_errors() as exc:  # the scheduler's own no-workers-timeout
            raise ClusterLost(f"the Dask cluster at {self.where} has no worker for chunk "
                              f"{task.index} ({type(exc).__name__})") from None
        finally:
            fut.release()
        yield result

    def abort(self) -> None:
        pass  # the generator's cleanup cancels the chunks in flight; the cluster stays up

    def close(self) -> None:
        if self._own:
            self._own = False  # once: close() may be called again on the way out
            if not self._lost:
                self.client.close()
                return
            # Closing a client that lost its scheduler cancels its reconnection attempt, which
            # Dask logs as an error with a traceback: the run has said what happened.
            with _silenced("distributed.client", "distributed.utils"):
                self.client.close()


def _no_worker_errors() -> tuple[type[BaseException], ...]:
    """Dask's errors for a task that found no worker (newer versions only)."""
    from distributed import scheduler

    return tuple(e for e in (getattr(scheduler, "NoValidWorkerError", None),
                             getattr(scheduler, "NoWorkerError", None)) if e is not None)


@contextmanager
def _silenced(*names: str) -> Iterator[None]:
    loggers = [logging.getLogger(n) for n in names]
    before = [lg.disabled for lg in loggers]
    for lg in loggers:
        lg.disabled = True
    try:
        yield
    finally:
        for lg, was in zip(loggers, before):
            lg.disabled = was


def make_executor(workers: int | None = None, scheduler: str | None = None,
                  scheduler_file: str | None = None,
                  no_workers_timeout: float = NO_WORKERS_TIMEOUT) -> Executor:
    """An executor, to be closed by the caller: Dask if a scheduler (address or file) is given,
    a process pool of ``workers`` processes when ``workers >= 1``, else this process."""
    if scheduler or scheduler_file:
        return DaskExecutor(address=scheduler, scheduler_file=scheduler_file,
                            no_workers_timeout=no_workers_timeout)
    if workers:
        return ProcessExecutor(workers)
    return SerialExecutor()
