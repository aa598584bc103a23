"""The driver: every method of a config, each through its own :meth:`Method.propagate` hook.

``run(load_config(path))`` is the whole of ``uqguide run`` less the printing and the writing.
A method's hook decides its phases; the driver lends it a :class:`~.stage.StageRunner`, which
evaluates chunks through an executor, checkpoints them in a :class:`~.run_folder.RunStore`, and
folds them **in chunk order**, so the numbers do not depend on the executor, the worker count
or interruptions.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import replace
from types import MappingProxyType

import numpy as np

from .run_folder import RunInterrupted, RunStore
from .stage import StageRunner
from ..config.run_config import RunConfig
from ..errors import ClusterLost, MethodError, MethodsFailed, UqguideError
from .execution import DEFAULT_BATCH_SIZE, Containment, Executor, SerialExecutor
from ..core.inputs import InputSpace
from ..core.failures import reason_summary
from ..methods.base import Design, Method
from ..models.base import Model
from .progress import Progress
from ..results.result import MethodRun, Result, provenance
from ..results.statistics import result_statistics
from ..stats.verdicts import method_verdicts

log = logging.getLogger(__name__)


def propagate(method: Method, model: Model, space: InputSpace, outputs: tuple[str, ...],
              seed: int, executor: Executor | None = None, *, batch_size: int | None = None,
              store: RunStore | None = None, progress: Progress | None = None,
              design: Design | None = None, timeout_s: float | None = None,
              containment: Containment | None = None,
              earlier: Sequence[MethodRun] = ()) -> MethodRun:
    """Run one method on one model: its estimate, the runs' inputs, scalar outputs and failure
    mask, and the wall times.

    ``batch_size``: samples per model call when the executor does not set it; ``store``: where
    finished chunks are saved and found; ``design``: the initial design when already made;
    ``timeout_s``: seconds a model call may take; ``earlier``: the runs of the methods listed
    before (a multi-fidelity method's surrogate levels).
    """
    executor = executor or SerialExecutor()
    requested = outputs
    method, outputs = _in_context(method, model, outputs)
    bs = executor.batch_size or batch_size or DEFAULT_BATCH_SIZE
    progress = progress or Progress()
    t_start = time.perf_counter()
    if design is None:
        design = method.design(space, seed)
    planned = method.planned_chunks(design, bs)
    if planned is not None:
        if not progress.chunks_total:  # called alone, not from run()
            progress.plan(len(planned), design.n_runs, method.label)
        log.info("%s: %d runs in the initial design (%d chunks)", method.label,
                 design.n_runs, len(planned))
    progress.start(method.label)
    runner = StageRunner(method, model, space, outputs, executor, bs, store, progress,
                         timeout_s, containment, earlier)
    with method.phases_to(progress.phase):
        done = method.propagate(space, design, runner)
    if done.outputs is None:  # a failure that lost its runs (a multi-fidelity method's)
        return MethodRun(estimate=done.estimate, x=np.zeros((0, space.dim)), scalars={},
                         failed=np.zeros(0, bool), reasons=np.zeros(0, dtype=object),
                         time=np.zeros(0), n_runs=0, model_seconds=0.0, fit_seconds=0.0,
                         wall_seconds=time.perf_counter() - t_start, success=False,
                         message=done.failure)
    # One clock for the fit: the method's (refinements' fits plus the final estimate).
    estimate = done.estimate
    estimate.diagnostics["fit_seconds"] = done.fit_seconds
    # carriers evaluated only for a derivation are not part of the result
    estimate.restrict(requested)
    out, timings = done.outputs, runner.timings
    ctx = method.context
    return MethodRun(
        estimate=estimate,
        x=done.x,
        scalars={k: v for k, v in out.scalars.items() if k in requested},
        failed=out.failed,
        reasons=out.reasons,
        time=out.time,
        n_runs=int(sum(t.n_runs for t in timings)),
        model_seconds=float(sum(t.model_seconds for t in timings)),
        fit_seconds=done.fit_seconds,
        compile_seconds=float(sum(t.compile_seconds for t in timings)),
        wall_seconds=time.perf_counter() - t_start,
        success=not done.failure,
        message=done.failure,
        verdicts=method_verdicts(method.label, ctx.requirements, estimate.events, ctx.events,
                                 estimate.diagnostics.get("stop_when") == "decided"),
    )


def say_failures(result: Result) -> list[str]:
    """Log (and return) one warning per method with statistics whose runs failed: the line of
    :func:`uqguide.core.failures.failed_runs_line` (a method without statistics says its
    failures in its message)."""
    from ..core.failures import failed_runs_line

    lines = [failed_runs_line(r.label, r.estimate.method, r.n_runs, r.n_failed,
                              r.estimate.diagnostics)
             + f"; reasons: {reason_summary(r.reasons[r.failed], limit=3)}"
             for r in result.runs if r.success and r.n_failed]
    for line in lines:
        log.warning("%s", line)
    return lines


def say_overflow(result: Result) -> list[str]:
    """Log (and return) one warning per output whose moments overflowed, naming the methods."""
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


def run(config: RunConfig, executor: Executor | None = None, *, store: RunStore | None = None,
        progress: Progress | None = None) -> Result:
    """Run every method of a validated config; the Result holds all their statistics.

    One MethodRun per method, in config order (a failed one with ``success=False``);
    ``store``: the run folder. RunInterrupted on Ctrl-C, ClusterLost for a Dask cluster without
    workers or scheduler, both with the count of chunks done. When no method produced
    statistics: MethodsFailed holding the Result of their runs when some succeeded, else
    MethodError.
    """
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
            planned = method.planned_chunks(design,
                                            executor.batch_size or config.raw.batch_size)
            if planned is not None:  # (else it plans its runs as it goes)
                progress.plan(len(planned), design.n_runs, method.label)
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
        raise RunInterrupted(_chunks_kept(store, progress), progress.chunks_total,
                             store.n_in_pieces if store is not None else 0) from None
    except ClusterLost as exc:
        # stopped like an interrupt, with its reason: the chunks done are kept for --resume
        raise ClusterLost(str(exc), _chunks_kept(store, progress),
                          progress.chunks_total) from None
    finally:
        progress.close()
    failed = bool(runs) and not any(r.success for r in runs)
    if failed and not any(r.n_runs > r.n_failed for r in runs):
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
    say_failures(result)
    if failed:  # a fit that failed after its runs: the runs are kept in the result
        raise MethodsFailed("\n".join(r.message for r in runs), result)
    say_overflow(result)
    return result


def _chunks_kept(store: RunStore | None, progress: Progress) -> int:
    """The chunks done when a run stops early: the store's count once the chunks queued for
    writing are on disk (a chunk saved just before the stop may not be counted yet)."""
    if store is None:
        return progress.chunks_done
    try:
        store.close()
    except Exception as err:  # noqa: BLE001 - why the run stopped is what the user sees
        log.warning("checkpoint: the last chunks could not be written (%s)", err)
    return store.n_done


def containment_of(config: RunConfig) -> Containment:
    """How a run of ``config`` contains its model: isolated when the model may crash (or the
    config says ``model.isolate``), child processes capped at ``max_memory``."""
    return Containment(isolate=config.isolate, asked=config.isolate_asked,
                       memory_limit=config.max_memory)


def check_methods(result: Result) -> None:
    """Raise UqguideError (exit 1) naming each method that produced no statistics."""
    failed = [r.message for r in result.runs if not r.success]
    if failed:
        raise UqguideError("; ".join(failed))


def check_failure_budget(result: Result, max_failed_fraction: float) -> None:
    """Raise UqguideError (exit 1) when a method's share of failed runs exceeds
    ``max_failed_fraction`` (in ``[0, 1]``), naming each such method, its counts and its most
    common reasons."""
    over = []
    for r in result.runs:
        if r.n_runs and r.n_failed / r.n_runs > max_failed_fraction:
            why = reason_summary(r.reasons[r.failed], limit=2)
            over.append(f"{r.label}: {r.n_failed} of {r.n_runs} runs failed "
                        f"({100 * r.n_failed / r.n_runs:.3g}%: {why})")
    if over:
        raise UqguideError(f"{'; '.join(over)}; above max_failed_fraction = "
                           f"{max_failed_fraction:g}")
