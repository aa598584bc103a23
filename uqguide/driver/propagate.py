"""The driver: design -> evaluate -> refine -> estimate, for every method of a config.

``run(load_config(path))`` is the whole of ``uqguide run`` less the printing and the writing.

Evaluation goes chunk by chunk through an executor (:mod:`uqguide.driver.execution`); finished
chunks are checkpointed as they arrive when a :class:`~uqguide.driver.checkpoint.RunStore` is given
(and taken from it on resume), and folded **in chunk order** whatever order they finish in, so the
numbers do not depend on the executor, the worker count or interruptions. A
:class:`~uqguide.methods.base.StreamingMethod` (Monte Carlo) is folded chunk by chunk into
summaries (bounded memory); the others get every output of every run and may refine their
design.
"""

from __future__ import annotations

import logging
import time
import weakref
from collections import Counter
from dataclasses import replace
from types import MappingProxyType
from typing import Any

import numpy as np

from .checkpoint import RunInterrupted, RunStore
from ..config.run_config import RunConfig
from ..errors import MethodError, ModelError, UqguideError
from .execution import (
    DEFAULT_BATCH_SIZE, ChunkJob, ChunkResult, Containment, Executor, ModelHandle, SerialExecutor,
    Task, Timing, common_grid, evaluate_batch,
)
from .execution.guard import guarded_batch
from .execution.shared_rows import SharedRows
from ..core.inputs import InputSpace
from .interrupts import raise_swallowed
from ..methods.base import Design, Method, StreamingMethod, chunk_bounds
from ..models import kernels
from ..models.base import Model
from ..core.types import Estimate, GeneratedRows, ModelOutput
from .progress import Progress
from ..config.report_times import check_config_report_times
from ..results.result import MethodRun, Result, provenance

log = logging.getLogger(__name__)

#: Models whose compiled kernel this process has loaded (or compiled) for a process pool.
_LOADED: weakref.WeakSet[Model] = weakref.WeakSet()

#: Refinement rounds after which a method that keeps asking for runs is stopped (a guard
#: against a method bug; real methods stop by their own budget long before).
MAX_REFINEMENTS = 100


class _Runs:
    """The per-sample values of reduced chunks (scalars, failure flags, reasons), copied into
    arrays allocated once for the whole stage: joining a list of chunk arrays at the end would
    hold every value twice (1 GB at 1e7 samples). With a process pool the scalar arrays are
    the stage's shared ones (:mod:`uqguide.driver.execution.shared_rows`), which the workers
    fill."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.failed = np.zeros(n, dtype=bool)
        # a failure's reason is only kept for a failed run: copying a million empty strings
        # chunk by chunk cost the driver 0.2 s of a 1e6-run study
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

    def output(self) -> ModelOutput:
        return ModelOutput(time=self.time if self.time is not None else np.zeros(0),
                           scalars=self.scalars, failed=self.failed, reasons=self.reasons)


class _Stage:
    """Evaluates the rows of one design stage chunk by chunk and folds them in order."""

    def __init__(self, method: Method, model: Model, space: InputSpace, outputs: tuple[str, ...],
                 executor: Executor, batch_size: int, store: RunStore | None,
                 progress: Progress, timing: Timing, timeout_s: float | None = None,
                 containment: Containment | None = None) -> None:
        self.method, self.model, self.space, self.outputs = method, model, space, outputs
        self.executor, self.batch_size, self.store = executor, batch_size, store
        self.progress, self.timing, self.timeout_s = progress, timing, timeout_s
        self.containment = containment or Containment()

    def _job(self, stage: int, reducer: Any) -> ChunkJob:
        """What every chunk of ``stage`` shares: with the containment of the run (a guard
        process for a model that can crash, when the chunks run in this process), the rows
        already known to crash, and where to record new ones."""
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
        """Load the model's compiled kernel before a local pool's workers start.

        One row of the design is evaluated here when the model runs a compiled kernel, so that
        a kernel missing from the cache compiles once, in this process (its phase shown by this
        progress display), and the workers load it from the cache instead of each compiling it
        at the same time. Once per model and process; the row's outputs are dropped (a worker
        evaluates it again with its chunk), its compile seconds kept. With a timeout the row
        runs in a guard process like every call (its compile then is not timed here).
        """
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

    def tasks(self, n: int) -> list[Task]:
        return [Task(i, a, b) for i, (a, b) in
                enumerate(chunk_bounds(self.method, n, self.batch_size))]

    def run(self, x: np.ndarray | GeneratedRows, stage: int, tasks: list[Task], reducer: Any
            ) -> tuple[ModelOutput, Any]:
        """Outputs of the rows ``x`` (scalars only when reduced) and the folded summaries."""
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
            nonlocal nxt, acc
            while nxt in pending:
                r = pending.pop(nxt)
                self.timing.model_seconds += r.model_seconds
                self.timing.compile_seconds += r.compile_seconds
                self.timing.n_runs += r.task.n
                if kept is not None:
                    assert isinstance(self.method, StreamingMethod)  # (only those reduce)
                    acc = self.method.fold(acc, r.summary)
                    kept.add(r)
                else:
                    parts.append(r.output())
                nxt += 1

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
            if todo and getattr(self.executor, "shares_memory", False):
                self._compile_here_first(job, x, todo[0])
            if todo:
                results = self.executor.map_chunks(job, todo, x)
            for r in results:
                r = arrived(r)
                if self.store is not None:
                    self.store.save(label, stage, r)
                self.progress.advance(r.task.n, r.n_failed)
                pending[r.task.index] = r
                fold_ready()
                raise_swallowed()
        except BaseException:
            if self.store is not None:
                self.store.drain()  # what was saved before the stop is on disk when it is seen
            raise
        finally:
            close = getattr(results, "close", None)
            if close is not None:
                close()
            if kept is not None and kept.shared is not None:
                kept.shared.close()  # the files go; the views stay valid
        fold_ready()
        if self.store is not None:
            self.store.flush()  # the stage's chunks on disk before the method goes on
        if kept is not None:
            return kept.output(), acc
        return ModelOutput.concatenate(common_grid(parts)), acc


def propagate(method: Method, model: Model, space: InputSpace, outputs: tuple[str, ...],
              seed: int, executor: Executor | None = None, *, batch_size: int | None = None,
              store: RunStore | None = None, progress: Progress | None = None,
              design: Design | None = None, timeout_s: float | None = None,
              containment: Containment | None = None) -> MethodRun:
    """Run one method on one model.

    Parameters
    ----------
    executor : Executor, optional
        Where chunks run (default: this process).
    batch_size : int, optional
        Samples per model call when the executor does not set it (default 10000).
    store : RunStore, optional
        Checkpoint: finished chunks are saved there, and chunks found there are not re-run.
    progress : Progress, optional
        Counters (and display) of the whole run.
    design : Design, optional
        The method's initial design when already made (``run`` makes them all first, to
        know the total work).
    timeout_s : float, optional
        Seconds a model call may take (:mod:`uqguide.guard`); default no limit.
    containment : Containment, optional
        Guard processes and memory limits for a model that may crash or leak (default: none).

    Returns
    -------
    MethodRun
        The estimate, the runs' inputs, scalar outputs and failure mask, and the wall times.
    """
    executor = executor or SerialExecutor()
    requested = outputs
    method, outputs = _in_context(method, model, outputs)
    bs = executor.batch_size or batch_size or DEFAULT_BATCH_SIZE
    progress = progress or Progress()
    timing = Timing()
    t_start = time.perf_counter()
    if design is None:
        design = method.design(space, seed)
    stage = _Stage(method, model, space, outputs, executor, bs, store, progress, timing,
                   timeout_s, containment)
    tasks = stage.tasks(design.n_runs)
    if not progress.chunks_total:  # called alone, not from run()
        progress.plan(len(tasks), design.n_runs, method.label)
    progress.start(method.label)
    log.info("%s: %d runs in the initial design (%d chunks)", method.label, design.n_runs,
             len(tasks))
    reducer = method.reducer(space, design) if isinstance(method, StreamingMethod) else None
    with method.phases_to(progress.phase):
        estimate, design, out, fit_seconds, failure = _evaluate_and_estimate(
            method, space, design, stage, tasks, reducer, progress, timing)
    # One clock for the fit: the driver's (refinements' fits plus the final estimate).
    estimate.diagnostics["fit_seconds"] = fit_seconds
    # carriers evaluated only for a derivation are not part of the result
    estimate.restrict(requested)
    return MethodRun(
        estimate=estimate,
        x=design.x,
        scalars={k: v for k, v in out.scalars.items() if k in requested},
        failed=out.failed,
        reasons=out.reasons,
        time=out.time,
        n_runs=timing.n_runs,
        model_seconds=timing.model_seconds,
        fit_seconds=fit_seconds,
        compile_seconds=timing.compile_seconds,
        wall_seconds=time.perf_counter() - t_start,
        success=not failure,
        message=failure,
    )


def _evaluate_and_estimate(method: Method, space: InputSpace, design: Design, stage: _Stage,
                           tasks: list[Task], reducer: Any, progress: Progress, timing: Timing
                           ) -> tuple[Estimate, Design, ModelOutput, float, str]:
    """Evaluate the design (and its refinements), then estimate.

    Returns the estimate, the final design, the runs' outputs, the seconds spent fitting (in
    ``refine`` and ``estimate``, outside the model) and why the method failed ("" when it did
    not): a method that cannot produce statistics is recorded with its runs, so the other
    methods of the run still complete.
    """
    out, acc = stage.run(design.x, 0, tasks, reducer)
    fit_seconds = 0.0
    if not isinstance(method, StreamingMethod):  # (that one never sees whole runs to refine)
        for k in range(1, MAX_REFINEMENTS + 1):
            t0 = time.perf_counter()
            # the runs so far are done, and no ETA paces what follows: say what the method
            # does, until it says more itself ("fitting zem (2/7, 300 runs)")
            progress.phase("refining the design")
            try:
                bigger = method.refine(space, design, out)
            except _METHOD_FAILURES as exc:
                fit_seconds += time.perf_counter() - t0
                return _no_estimate(method), design, out, fit_seconds, _why(method, exc)
            fit_seconds += time.perf_counter() - t0
            if bigger is None:
                break
            new_x = _appended_rows(design, bigger)
            log.info("%s: %d more runs (sequential design)", method.label, new_x.shape[0])
            more_tasks = stage.tasks(new_x.shape[0])
            progress.plan(len(more_tasks), new_x.shape[0], method.label)
            progress.phase("")  # planned first: the line it shows counts the new runs
            more, _ = stage.run(new_x, k, more_tasks, None)
            design, out = bigger, ModelOutput.concatenate(common_grid([out, more]))
        else:
            log.warning("%s: stopped after %d refinements", method.label, MAX_REFINEMENTS)
    t0 = time.perf_counter()
    progress.phase("estimating")
    failure = ""
    try:
        if isinstance(method, StreamingMethod):
            estimate = method.estimate_reduced(space, design, out, acc)
        else:
            estimate = method.estimate(space, design, out)
    except _METHOD_FAILURES as exc:
        estimate, failure = _no_estimate(method), _why(method, exc)
    progress.phase("")
    return estimate, design, out, fit_seconds + time.perf_counter() - t0, failure


#: What a method may raise and still leave the run to the other methods: a MethodError (it
#: cannot produce statistics from these runs) or a numerical failure of its fit. A ModelError
#: (a model breaking its contract) and a ConfigError stop the run; so does Ctrl-C.
_METHOD_FAILURES = (MethodError, ArithmeticError, ValueError, np.linalg.LinAlgError)


def _no_estimate(method: Method) -> Estimate:
    return Estimate(method=method.name, label=method.label, stats={})


def _why(method: Method, exc: Exception) -> str:
    if isinstance(exc, MethodError):
        return str(exc)
    log.debug("%s failed", method.label, exc_info=exc)
    return f"{method.label}: {type(exc).__name__}: {exc} (run with -vv for the traceback)"


def _in_context(method: Method, model: Model, outputs: tuple[str, ...]
                ) -> tuple[Method, tuple[str, ...]]:
    """The method in the context of this propagation (its outputs and the model's
    derivations of them), and the outputs to evaluate: a method that
    :attr:`~uqguide.methods.base.Method.uses_derivations` needs their carriers too."""
    derived = {k: d for k, d in model.derived_outputs().items() if k in outputs}
    context = replace(method.context, outputs=outputs, derived=MappingProxyType(derived))
    if context != method.context:
        method = method.with_context(context)
    if not method.uses_derivations:
        return method, outputs
    carriers = [c for d in derived.values() for c in d.carriers if c not in outputs]
    return method, outputs + tuple(dict.fromkeys(carriers))


def _appended_rows(old: Design, new: Design) -> np.ndarray:
    n_old = old.x.shape[0]
    if new.x.shape[0] <= n_old or not np.array_equal(new.x[:n_old], old.x):
        raise RuntimeError("a refined design must keep the old runs first and append new ones")
    return new.x[n_old:]


def run(config: RunConfig, executor: Executor | None = None, *, store: RunStore | None = None,
        progress: Progress | None = None) -> Result:
    """Run every method of a validated config; the Result holds all their statistics.

    Parameters
    ----------
    config : RunConfig
    executor : Executor, optional
        Default: this process, in calls of the config's ``batch_size``.
    store : RunStore, optional
        Checkpoint folder (see :mod:`uqguide.driver.checkpoint`).
    progress : Progress, optional
        Where progress is shown (default: counted, not shown).

    Returns
    -------
    Result
        One MethodRun per method, in config order; a method that failed is recorded with its
        runs and ``success=False`` (see :func:`check_methods`).

    Raises
    ------
    RunInterrupted
        On Ctrl-C (KeyboardInterrupt): chunks in flight are dropped; those done are in
        ``store``.
    """
    check_config_report_times(config)
    executor = executor or SerialExecutor(config.raw.batch_size)
    progress = progress or Progress()
    t0 = time.perf_counter()
    runs = []
    try:
        designs = []
        for method in config.methods:
            t_design = time.perf_counter()
            design = method.design(config.space, config.seed)
            designs.append((design, time.perf_counter() - t_design))
            bs = executor.batch_size or config.raw.batch_size
            progress.plan(len(chunk_bounds(method, design.n_runs, bs)), design.n_runs,
                          method.label)
        for method, (design, design_seconds) in zip(config.methods, designs):
            r = propagate(method, config.model, config.space, config.outputs, config.seed,
                          executor, batch_size=config.raw.batch_size, store=store,
                          progress=progress, design=design, timeout_s=config.raw.timeout_s,
                          containment=containment_of(config))
            r.wall_seconds += design_seconds
            runs.append(r)
    except KeyboardInterrupt as exc:
        executor.abort()
        if isinstance(exc, RunInterrupted):
            raise
        # The store's count, once the chunks queued for writing are on disk: a chunk saved
        # just before the interrupt may not be counted yet.
        if store is not None:
            try:
                store.close()
            except Exception as err:  # noqa: BLE001 - the interrupt is what the user sees
                log.warning("checkpoint: the last chunks could not be written (%s)", err)
        done = store.n_done if store is not None else progress.chunks_done
        raise RunInterrupted(done, progress.chunks_total) from None
    finally:
        progress.close()
    if runs and not any(r.success for r in runs):
        # nothing to report: no result file, the reasons instead
        raise MethodError("\n".join(r.message for r in runs))
    time_grid = next((r.time for r in runs if r.time.size), np.zeros(0))
    return Result(
        name=config.name,
        model=config.model.name,
        input_names=list(config.space.names),
        outputs=[config.model.output_info(o) for o in config.outputs],
        time=time_grid,
        runs=runs,
        reference=config.reference,
        report_times=list(config.report_times) if config.report_times else None,
        config=config.resolved(),
        provenance={**provenance(), "wall_seconds": time.perf_counter() - t0},
    )


def containment_of(config: RunConfig) -> Containment:
    """How a run of ``config`` contains its model: isolated when the model may crash (or the
    config says ``model.isolate``), child processes capped at ``max_memory``.

    Parameters
    ----------
    config : RunConfig

    Returns
    -------
    Containment
    """
    return Containment(isolate=config.isolate, asked=config.isolate_asked,
                       memory_limit=config.max_memory)


def check_methods(result: Result) -> None:
    """Raise UqguideError (exit 1) naming each method that produced no statistics (the others
    are in the result and its tables).

    Parameters
    ----------
    result : Result
    """
    failed = [r.message for r in result.runs if not r.success]
    if failed:
        raise UqguideError("; ".join(failed))


def check_failure_budget(result: Result, max_failed_fraction: float) -> None:
    """Raise UqguideError (exit 1) when a method's share of failed runs exceeds the budget.

    The message names each method over budget, its counts and its most common reasons.

    Parameters
    ----------
    result : Result
    max_failed_fraction : float
        Largest share of failed runs allowed per method, in ``[0, 1]``.
    """
    over = []
    for r in result.runs:
        if r.n_runs and r.n_failed / r.n_runs > max_failed_fraction:
            reasons = Counter(str(v) for v in r.reasons[r.failed]).most_common(2)
            why = "; ".join(f"{k} ({c})" for k, c in reasons)
            over.append(f"{r.label}: {r.n_failed} of {r.n_runs} runs failed "
                        f"({100 * r.n_failed / r.n_runs:.3g}%: {why})")
    if over:
        raise UqguideError(f"{'; '.join(over)}; above max_failed_fraction = "
                           f"{max_failed_fraction:g}")
