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
from collections import Counter
from collections.abc import Sequence
from dataclasses import replace
from types import MappingProxyType
from typing import Any

import numpy as np

from .checkpoint import RunInterrupted, RunStore
from .stage import Stage
from ..config.run_config import RunConfig
from ..errors import MethodError, UqguideError
from .execution import (
    DEFAULT_BATCH_SIZE, Containment, Executor, SerialExecutor,
    Task, Timing, common_grid,
)
from ..core.inputs import InputSpace
from ..methods.base import Design, Method, StreamingMethod, chunk_bounds
from ..methods.mfmc import MultiFidelityMC
from ..models.base import Model
from ..core.types import Estimate, ModelOutput
from .progress import Progress
from ..config.report_times import check_config_report_times
from ..results.result import MethodRun, Result, provenance
from ..results.statistics import result_statistics
from ..stats.moments import quiet_overflow

log = logging.getLogger(__name__)

#: Refinement rounds after which a method that keeps asking for runs is stopped (a guard
#: against a method bug; real methods stop by their own budget long before).
MAX_REFINEMENTS = 100


def propagate(method: Method, model: Model, space: InputSpace, outputs: tuple[str, ...],
              seed: int, executor: Executor | None = None, *, batch_size: int | None = None,
              store: RunStore | None = None, progress: Progress | None = None,
              design: Design | None = None, timeout_s: float | None = None,
              containment: Containment | None = None,
              earlier: Sequence[MethodRun] = ()) -> MethodRun:
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
    earlier : sequence of MethodRun
        The runs of the methods listed before this one (a multi-fidelity method's surrogate
        levels are their PCEs).

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
    if isinstance(method, MultiFidelityMC):
        return _levels(method, model, space, outputs, seed, executor, bs, store, progress,
                       design, timeout_s, containment, earlier)
    timing = Timing()
    t_start = time.perf_counter()
    if design is None:
        design = method.design(space, seed)
    stage = Stage(method, model, space, outputs, executor, bs, store, progress, timing,
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


def _levels(method: MultiFidelityMC, model: Model, space: InputSpace,
            outputs: tuple[str, ...], seed: int, executor: Executor, bs: int,
            store: RunStore | None, progress: Progress, design: Design | None,
            timeout_s: float | None, containment: Containment | None,
            earlier: Sequence[MethodRun]) -> MethodRun:
    """A multi-fidelity method (:mod:`.propagate_levels`); a method failure is recorded
    like any method's, the runs made before it are lost to the result (not to the
    checkpoint)."""
    from .propagate_levels import propagate_levels, surrogate_levels

    t0 = time.perf_counter()
    try:
        return propagate_levels(method, model, space, outputs, seed, executor, bs, store,
                                progress, design, timeout_s, containment,
                                surrogate_levels(method, earlier, outputs))
    except _METHOD_FAILURES as exc:
        return MethodRun(estimate=_no_estimate(method), x=np.zeros((0, space.dim)),
                         scalars={}, failed=np.zeros(0, bool),
                         reasons=np.zeros(0, dtype=object), time=np.zeros(0), n_runs=0,
                         model_seconds=0.0, fit_seconds=0.0,
                         wall_seconds=time.perf_counter() - t0, success=False,
                         message=_why(method, exc))


def _evaluate_and_estimate(method: Method, space: InputSpace, design: Design, stage: Stage,
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
                with quiet_overflow():  # fits only: the model ran before (say_overflow)
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
        with quiet_overflow():  # statistics only: the model ran before (say_overflow)
            if isinstance(method, StreamingMethod):
                estimate = method.estimate_reduced(space, design, out, acc)
            else:
                estimate = method.estimate(space, design, out)
    except _METHOD_FAILURES as exc:
        estimate, failure = _no_estimate(method), _why(method, exc)
    progress.phase("")
    return estimate, design, out, fit_seconds + time.perf_counter() - t0, failure


def say_overflow(result: Result) -> list[str]:
    """Log one warning per output whose moments overflowed double precision (outputs near
    1e300: :func:`uqguide.stats.moments.overflowed`), naming the methods; the tables show
    those moments as ``overflow``.

    Parameters
    ----------
    result : Result

    Returns
    -------
    list of str
        The lines logged.
    """
    by_output: dict[str, list[str]] = {}
    for label, described in result_statistics(result).items():
        for name, v in described.items():
            if v.overflows:
                by_output.setdefault(name, []).append(label)
    lines = []
    for name, labels in by_output.items():
        lines.append(f"{', '.join(labels)}: {name}: its values are too large for double "
                     f"precision: the sums of their powers overflow (beyond 1.8e308), so its "
                     f"std, skewness or kurtosis are not finite and show as 'overflow'; "
                     f"give the output in a larger unit")
        log.warning("%s", lines[-1])
    return lines


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
    runs: list[MethodRun] = []
    try:
        designs = []
        for method in config.methods:
            t_design = time.perf_counter()
            design = method.design(config.space, config.seed)
            designs.append((design, time.perf_counter() - t_design))
            if isinstance(method, MultiFidelityMC):
                continue  # (its runs are planned stage by stage, once the pilot has run)
            bs = executor.batch_size or config.raw.batch_size
            progress.plan(len(chunk_bounds(method, design.n_runs, bs)), design.n_runs,
                          method.label)
        for method, (design, design_seconds) in zip(config.methods, designs):
            r = propagate(method, config.model, config.space, config.outputs, config.seed,
                          executor, batch_size=config.raw.batch_size, store=store,
                          progress=progress, design=design, timeout_s=config.raw.timeout_s,
                          containment=containment_of(config), earlier=tuple(runs))
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
    result = Result(
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
    say_overflow(result)
    return result


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
