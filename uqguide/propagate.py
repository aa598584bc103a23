"""The driver: design -> evaluate -> refine -> estimate, for every method of a config.

``run(load_config(path))`` is the whole of ``uqguide run`` less the printing and the writing.
"""

from __future__ import annotations

import logging
import time

import numpy as np

from .config import RunConfig
from .execution import SerialExecutor, Timing
from .inputs import InputSpace
from .methods.base import Design, Method
from .models.base import Model, ModelOutput
from .result import MethodRun, Result, provenance

log = logging.getLogger(__name__)

#: Refinement rounds after which a method that keeps asking for runs is stopped (a guard
#: against a method bug; real methods stop by their own budget long before).
MAX_REFINEMENTS = 100


def propagate(method: Method, model: Model, space: InputSpace, outputs: tuple[str, ...],
              seed: int, executor: SerialExecutor | None = None) -> MethodRun:
    """Run one method on one model.

    Returns
    -------
    MethodRun
        The estimate, the runs' inputs, scalar outputs and failure mask, and the wall times.
    """
    executor = executor or SerialExecutor()
    timing = Timing()
    t_start = time.perf_counter()
    design = method.design(space, seed)
    log.info("%s: %d runs in the initial design", method.label, design.n_runs)
    out = executor.evaluate(model, design.x, space.names, outputs, timing)
    for _ in range(MAX_REFINEMENTS):
        bigger = method.refine(space, design, out)
        if bigger is None:
            break
        new_x = _appended_rows(design, bigger)
        log.info("%s: %d more runs (sequential design)", method.label, new_x.shape[0])
        more = executor.evaluate(model, new_x, space.names, outputs, timing)
        design, out = bigger, ModelOutput.concatenate([out, more])
    else:
        log.warning("%s: stopped after %d refinements", method.label, MAX_REFINEMENTS)
    t_fit = time.perf_counter()
    estimate = method.estimate(space, design, out)
    fit_seconds = time.perf_counter() - t_fit
    return MethodRun(
        estimate=estimate,
        x=design.x,
        scalars=dict(out.scalars),
        failed=out.failed,
        reasons=out.reasons,
        time=out.time,
        n_runs=timing.n_runs,
        model_seconds=timing.model_seconds,
        fit_seconds=fit_seconds,
        wall_seconds=time.perf_counter() - t_start,
    )


def _appended_rows(old: Design, new: Design) -> np.ndarray:
    n_old = old.x.shape[0]
    if new.x.shape[0] <= n_old or not np.array_equal(new.x[:n_old], old.x):
        raise RuntimeError("a refined design must keep the old runs first and append new ones")
    return new.x[n_old:]


def run(config: RunConfig, executor: SerialExecutor | None = None) -> Result:
    """Run every method of a validated config; the Result holds all their statistics."""
    executor = executor or SerialExecutor(config.raw.batch_size)
    t0 = time.perf_counter()
    runs = []
    for method in config.methods:
        runs.append(propagate(method, config.model, config.space, config.outputs, config.seed,
                              executor))
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
