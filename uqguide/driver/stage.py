"""Evaluating one design stage of one model, chunk by chunk, folded in chunk order.

A :class:`StageRunner`, the :class:`~uqguide.methods.base.Runner` the driver lends a method's
:meth:`~uqguide.methods.base.Method.propagate`, takes chunks restored from the checkpoint or
evaluated by the executor (a small stage's in pieces: :mod:`.chunk_pieces`), saves them as
they arrive, and folds (or joins) them in chunk order whatever order they finish in. A
:class:`SurrogateLevel` is the Runner of a fitted PCE used as a multi-fidelity method's level.
"""

from __future__ import annotations

import logging
import math
import time
import weakref
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .run_folder import RunStore
from ..errors import MethodError, ModelError
from .chunk_pieces import Pieces, at_once, goes_in_pieces
from .execution import (
    ChunkJob, ChunkResult, Containment, Executor, ModelHandle, Task, Timing, common_grid,
    evaluate_batch, join_pieces,
)
from .execution.guard import guarded_batch
from .execution.shared_rows import SharedRows
from ..core.inputs import InputSpace
from .interrupts import raise_swallowed
from ..methods.base import ChunkFold, ChunkReducer, Chunks, Method
from ..models import kernels
from ..models.base import Model
from ..core.types import GeneratedRows, ModelOutput
from ..pce.surrogate import Surrogate
from .progress import Progress
from ..results.result import MethodRun

log = logging.getLogger(__name__)

#: Models whose compiled kernel this process has loaded (or compiled) for a process pool.
_LOADED: weakref.WeakSet[Model] = weakref.WeakSet()
#: Each model's model seconds per run of its latest piece (:class:`Pieces`): a later stage of a
#: model known to be fast goes in calls of the batch size at once.
_SPEED: weakref.WeakKeyDictionary[Model, list[float]] = weakref.WeakKeyDictionary()


class Counted:
    """A :class:`~uqguide.methods.base.Runner`'s counts, those of its ``timing``."""

    timing: Timing

    @property
    def cpu_seconds(self) -> float:
        return self.timing.cpu_seconds

    @property
    def n_runs(self) -> int:
        return self.timing.n_runs


class _Runs:
    """The per-sample values of reduced chunks, copied into arrays allocated once for the
    stage (joining chunk arrays at the end would hold every value twice); with a process pool
    the scalar arrays are the shared ones the workers fill (:mod:`.execution.shared_rows`)."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.failed = np.zeros(n, dtype=bool)
        # a reason is only copied for a failed run: copying empty strings chunk by chunk is slow
        self.reasons = np.full(n, "", dtype=object)
        self.scalars: dict[str, np.ndarray] = {}
        self.time: np.ndarray | None = None
        self.shared: SharedRows | None = None

    def add(self, r: ChunkResult) -> None:
        rows = slice(r.task.start, r.task.stop)
        self.failed[rows] = r.failed
        if r.failed.any():
            self.reasons[r.task.start + np.flatnonzero(r.failed)] = r.reasons[r.failed]
        written = {key for part, key, _ in r.in_place if part == "scalars"}
        for k, v in r.scalars.items():
            if k not in self.scalars:
                shared = self.shared.scalar_array(k) if self.shared is not None else None
                self.scalars[k] = shared if shared is not None else \
                    np.empty((self.n, *v.shape[1:]), dtype=v.dtype)
            if k not in written:  # (what a worker wrote in place is there already)
                self.scalars[k][rows] = v
        if r.time.size:
            if self.time is None:
                self.time = r.time
            elif r.time.shape != self.time.shape or not np.array_equal(r.time, self.time):
                raise ModelError("chunks of one run must share the time grid")

    def output(self, n: int | None = None) -> ModelOutput:
        """The runs' outputs, of the first ``n`` rows only when given (views, not copies)."""
        rows = slice(None if n is None else n)
        return ModelOutput(time=self.time if self.time is not None else np.zeros(0),
                           scalars={k: v[rows] for k, v in self.scalars.items()},
                           failed=self.failed[rows], reasons=self.reasons[rows])


class StageRunner(Counted):
    """The :class:`~uqguide.methods.base.Runner` of one method on one model (or one of its
    fidelity levels): each call of :meth:`run` evaluates a design stage chunk by chunk and folds
    it in order. Every runner made from it (:meth:`at_fidelity`, :meth:`surrogate_of`) adds its
    counts to ``timings``, which the driver sums into the method's."""

    def __init__(self, method: Method, model: Model, space: InputSpace, outputs: tuple[str, ...],
                 executor: Executor, batch_size: int, store: RunStore | None,
                 progress: Progress, timeout_s: float | None = None,
                 containment: Containment | None = None,
                 earlier: Sequence[MethodRun] = (), timings: list[Timing] | None = None
                 ) -> None:
        self.method, self.model, self.space, self.outputs = method, model, space, outputs
        self.executor, self.batch_size, self.store = executor, batch_size, store
        self.progress, self.timeout_s = progress, timeout_s
        self.containment = containment or Containment()
        #: The runs of the methods listed before this one (whose surrogates may be levels).
        self.earlier = earlier
        self.timing = Timing()
        self.timings = timings if timings is not None else []
        self.timings.append(self.timing)

    def _job(self, stage: int, reducer: Any) -> ChunkJob:
        """What every chunk of ``stage`` shares, with the run's containment, the rows known to
        crash and where to record new ones."""
        c, store, label = self.containment, self.store, self.method.label
        guarded = c.isolate and getattr(self.executor, "in_process", False)
        on_isolated = None
        if store is not None:
            def on_isolated(row: int, reason: str) -> None:
                store.record_isolated(label, stage, row, reason)
        return ChunkJob(ModelHandle(self.model), tuple(self.space.names), self.outputs,
                        self.batch_size, reducer, timeout_s=self.timeout_s, guarded=guarded,
                        guard_fallback=guarded and not c.asked, memory_limit=c.memory_limit,
                        known=store.known_isolated(label, stage) if store else {},
                        on_isolated=on_isolated)

    def _compile_here_first(self, job: ChunkJob, x: np.ndarray | GeneratedRows,
                            task: Task) -> None:
        """Evaluate one design row here before a local pool starts, so that a kernel missing from
        the cache compiles once, here, and the workers load it (its outputs dropped)."""
        model = self.model
        if model in _LOADED or model.kernel_choice() != "numba":
            return
        before = kernels.compile_seconds()
        row = x.rows(task.start, task.start + 1) if isinstance(x, GeneratedRows) else \
            x[task.start:task.start + 1]
        if job.timeout_s is not None or job.guarded:
            guarded_batch(job.model, row, job.names, job.outputs, job.timeout_s,
                          job.memory_limit)
        else:
            evaluate_batch(model, row, job.names, job.outputs)
        _LOADED.add(model)
        self.timing.compile_seconds += kernels.compile_seconds() - before

    def _evaluate(self, x: np.ndarray | GeneratedRows, stage: int, tasks: list[Task],
                  reducer: Any, fold: ChunkFold | None = None,
                  stop: Callable[[ModelOutput], bool] | None = None
                  ) -> tuple[ModelOutput, Any]:
        """Outputs of the rows ``x`` (scalars only when reduced) and the summaries folded by
        ``fold`` (given with ``reducer``), up to the fold after which ``stop`` said so."""
        label = self.method.label
        job = self._job(stage, reducer)
        parts: list[ModelOutput] = []
        kept = _Runs(x.shape[0]) if reducer is not None else None
        per_run = getattr(reducer, "per_run", None)
        share = kept is not None and per_run is not None and \
            getattr(self.executor, "shares_memory", False)
        pending: dict[int, ChunkResult] = {}
        acc = None
        nxt = 0
        stopped_at: int | None = None  # the rows folded when ``stop`` said so

        def arrived(r: ChunkResult) -> ChunkResult:
            # The first result back (restored or evaluated) shapes the shared arrays; the
            # chunks submitted from then on write their per-run values there.
            nonlocal share
            if kept is None:
                return r
            if share and per_run is not None:
                share = False
                kept.shared = SharedRows.for_result(r, x.shape[0], per_run)
                if kept.shared is not None:
                    job.shared = kept.shared.layout
            return kept.shared.adopt(r) if kept.shared is not None else r

        def fold_ready() -> None:
            nonlocal nxt, acc, stopped_at
            while nxt in pending and stopped_at is None:
                r = pending.pop(nxt)
                self.timing.model_seconds += r.model_seconds
                self.timing.compile_seconds += r.compile_seconds
                self.timing.cpu_seconds += r.cpu_seconds
                self.timing.n_runs += r.task.n
                if kept is not None:
                    assert fold is not None  # (a reducer comes with its fold)
                    acc = fold(acc, r.summary)
                    kept.add(r)
                    if stop is not None and stop(kept.output(r.task.stop)):
                        stopped_at = r.task.stop
                else:
                    parts.append(r.output())
                nxt += 1

        def done(r: ChunkResult) -> None:
            r = arrived(r)
            if self.store is not None:
                self.store.save(label, stage, r)
            pending[r.task.index] = r
            fold_ready()

        results: Any = iter(())
        try:
            for t in tasks:
                r = self.store.load(label, stage, t) if self.store else None
                if r is not None:
                    pending[t.index] = arrived(r)
                    self.progress.restored(t.n, r.n_failed)
            todo = [t for t in tasks if t.index not in pending]
            if len(pending):
                log.info("%s: %d of %d chunks restored from the checkpoint", label,
                         len(pending), len(tasks))
            fold_ready()
            if stopped_at is not None:
                todo = []
            pieces = self._pieces(stage, todo)
            if pieces is not None:
                share = False  # (the workers send pieces whole, never write in place)
                for t in todo:  # a chunk whose every piece was kept
                    whole = pieces.whole(t.index)
                    if whole is not None:
                        self.progress.restored(0, 0)
                        done(join_pieces(job, t, whole))
                todo = pieces.todo()
            if todo and getattr(self.executor, "shares_memory", False):
                self._compile_here_first(job, x, todo[0])
            if todo:
                results = self.executor.map_chunks(job, todo, x) if pieces is None else \
                    self._in_pieces(job, pieces, x)
            for r in results:
                if pieces is None:
                    self.progress.advance(r.task.n, r.n_failed)
                    done(r)
                else:
                    whole = pieces.add(r)
                    if self.store is not None:
                        for p in pieces.due():
                            self.store.save(label, stage, p, piece=True)
                    self.progress.advance(r.task.n, r.n_failed, int(whole is not None))
                    if whole is not None:
                        done(join_pieces(job, pieces.chunks[r.task.index], whole))
                raise_swallowed()
                if stopped_at is not None:
                    log.info("%s: stopped after %d runs (%s)", label, stopped_at,
                             "every requirement decided")
                    break
        except BaseException:
            if self.store is not None:
                # what was saved before the stop is on disk when it is seen
                self.store.writer.drain()
            raise
        finally:
            close = getattr(results, "close", None)
            if close is not None:
                close()
            if kept is not None and kept.shared is not None:
                kept.shared.close()  # the files go; the views stay valid
        fold_ready()
        if self.store is not None:
            self.store.writer.flush()  # the stage's chunks on disk before the method goes on
        if kept is not None:
            return kept.output(stopped_at), acc
        return ModelOutput.concatenate(common_grid(parts)), acc

    def _in_pieces(self, job: ChunkJob, pieces: Pieces, x: np.ndarray | GeneratedRows
                   ) -> Any:
        """The pieces' results: first two per worker, then the rest sized at their speed
        (:meth:`Pieces.step`). A piece comes back unreduced: its chunk is reduced here."""
        job = replace(job, reducer=None, shared=None)
        first = pieces.todo()[:2 * at_once(self.executor)]
        yield from self.executor.map_chunks(job, first, x)
        rest = pieces.todo()
        if rest:
            yield from self.executor.map_chunks(job, rest, x)

    def _pieces(self, stage: int, todo: list[Task]) -> Pieces | None:
        """The pieces of the chunks ``todo`` (those kept restored and counted) when the stage
        is small or kept pieces of them; None: the chunks go whole."""
        label, store = self.method.label, self.store
        kept = [r for t in todo for r in store.load_pieces(label, stage, t)] \
            if store is not None else []
        if any(t.n == 0 for t in todo) or not self.method.runs_in_pieces or \
                not kept and not goes_in_pieces(len(todo), self.executor):
            return None
        pieces = Pieces(todo, self.batch_size, _SPEED.setdefault(self.model, [math.inf]))
        taken = [r for r in kept if pieces.restore(r)]
        for r in taken:
            self.progress.restored(r.task.n, r.n_failed, chunks=0)
        if taken:
            log.info("%s: %d runs of unfinished chunks restored from the checkpoint", label,
                     sum(r.task.n for r in taken))
        return pieces

    fixed_cpu_s = 0.0

    def run(self, x: np.ndarray | GeneratedRows, stage: int, chunks: Chunks, *,
            reduce: tuple[ChunkReducer, ChunkFold] | None = None,
            after: ModelOutput | None = None,
            stop: Callable[[ModelOutput], bool] | None = None) -> tuple[ModelOutput, Any]:
        tasks = [Task(i, a, b) for i, (a, b) in enumerate(chunks)]
        reducer, fold = reduce if reduce is not None else (None, None)
        out, acc = self._evaluate(x, stage, tasks, reducer, fold, stop)
        if after is not None:
            out = ModelOutput.concatenate(common_grid([after, out]))
        return out, acc

    def plan(self, chunks: Sequence[tuple[int, int]]) -> None:
        self.progress.plan(len(chunks), sum(b - a for a, b in chunks), self.method.label)

    def phase(self, text: str) -> None:
        self.progress.phase(text)

    def at_fidelity(self, changes: Mapping[str, Any]) -> StageRunner:
        return StageRunner(self.method, self.model.at_fidelity(changes), self.space,
                           self.outputs, self.executor, self.batch_size, self.store,
                           self.progress, self.timeout_s, self.containment, self.earlier,
                           self.timings)

    def surrogate_of(self, label: str) -> SurrogateLevel:
        level = surrogate_level(self.earlier, label, self.outputs)
        self.timings.append(level.timing)
        return level


@dataclass
class SurrogateLevel(Counted):
    """The surrogate of the PCE method ``label`` as a fidelity level of
    :mod:`uqguide.methods.mfmc` (``fidelities: [..., {surrogate: apce}]``): ``time (T,)``, its
    series' grid; ``fixed_cpu_s``: the PCE method's model and fit seconds (the surrogate's
    price); ``outputs``: those it predicts; ``timing``: its runs and CPU seconds so far.

    It runs here, in the driver's process, on the same rows as every other level: it costs
    microseconds per run, so workers would add pickling and nothing else. Its chunks are not
    checkpointed: a resumed run re-fits the PCE from its own method's checkpoint (the same
    bits). Why the estimate stays unbiased: ``docs/multifidelity.md``.
    """

    label: str
    surrogate: Surrogate
    time: np.ndarray
    fixed_cpu_s: float
    outputs: tuple[str, ...] = ()
    timing: Timing = field(default_factory=Timing)
    #: (a Runner's; the surrogate evaluates whatever rows it is given in one call)
    batch_size: int = 0

    def missing(self, outputs: Sequence[str]) -> list[str]:
        """The outputs it cannot predict (no expansion kept for them)."""
        return [o for o in outputs if o not in self.surrogate.names]

    def run(self, x: np.ndarray | GeneratedRows, stage: int, chunks: Chunks, *,
            reduce: tuple[ChunkReducer, ChunkFold] | None = None,
            after: ModelOutput | None = None,
            stop: Callable[[ModelOutput], bool] | None = None) -> tuple[ModelOutput, Any]:
        """Its values at the rows ``chunks`` of ``x`` in one call, joined after ``after``."""
        if reduce is not None or stop is not None:
            raise MethodError(f"the surrogate of {self.label!r} is evaluated whole, not reduced")
        start, end = chunks[0][0], chunks[-1][1]
        rows = x.rows(start, end) if isinstance(x, GeneratedRows) else np.asarray(x)[start:end]
        out = self.evaluate(np.asarray(rows))
        if after is not None:
            out = ModelOutput.concatenate(common_grid([after, out]))
        return out, None

    def evaluate(self, x: np.ndarray) -> ModelOutput:
        """Its values at the physical inputs ``x (n, d)``; the CPU seconds go to its timing."""
        t0 = time.process_time()
        w0 = time.perf_counter()
        values = self.surrogate(np.asarray(x, dtype=float), list(self.outputs))
        n = x.shape[0]
        series = {k: v for k, v in values.items() if v.ndim == 3}
        scalars = {k: v.reshape(n, -1) for k, v in values.items() if v.ndim != 3}
        self.timing.cpu_seconds += time.process_time() - t0
        self.timing.model_seconds += time.perf_counter() - w0
        self.timing.n_runs += n
        return ModelOutput(time=self.time, series=series,
                           scalars=scalars, failed=np.zeros(n, dtype=bool),
                           reasons=np.full(n, "", dtype=object))

    def plan(self, chunks: Chunks) -> None:
        """Nothing: its runs cost microseconds and are not shown as work."""

    def phase(self, text: str) -> None:
        """Nothing: the method's own runner shows its phases."""

    def at_fidelity(self, changes: Mapping[str, Any]) -> SurrogateLevel:
        raise MethodError(f"the surrogate of {self.label!r} has no fidelity levels")

    def surrogate_of(self, label: str) -> SurrogateLevel:
        raise MethodError(f"the surrogate of {self.label!r} has no surrogate levels")


def surrogate_level(earlier: Sequence[MethodRun], label: str,
                    outputs: Sequence[str]) -> SurrogateLevel:
    """The surrogate of the method ``label`` among the ``earlier`` runs; MethodError when there
    is none, or none of an output."""
    r = next((r for r in earlier if r.estimate.label == label), None)
    sg = None if r is None else r.estimate.surrogate
    if r is None or not r.success or sg is None:
        why = "did not run" if r is None else (r.message or "kept no surrogate")
        raise MethodError(f"there is no surrogate of {label!r} ({why})")
    level = SurrogateLevel(label=label, surrogate=sg, time=r.time,
                           fixed_cpu_s=float(r.model_seconds + r.fit_seconds),
                           outputs=tuple(outputs))
    missing = level.missing(outputs)
    if missing:
        raise MethodError(f"the surrogate of {label!r} predicts no {', '.join(missing)} (no "
                          f"expansion kept); leave {'it' if len(missing) == 1 else 'them'} out "
                          f"of outputs or the surrogate level out of fidelities")
    return level
