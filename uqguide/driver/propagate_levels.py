"""The driver of a multi-fidelity method (:mod:`uqguide.methods.mfmc`): pilot, allocation, main
runs, estimate, over several fidelity levels of one model.

Every level evaluates rows of the method's one input stream through the same chunked,
checkpointed machinery as any method (:class:`~uqguide.driver.stage.Stage`): level ``i``'s
pilot is checkpoint stage ``1 + 2 i`` (rows ``[0, n_pilot)``), its main runs stage ``2 + 2 i``
(rows ``[n_pilot, m_i)``), chunks cut at multiples of the method's ``chunk_size``. A resumed run
restores the pilot chunks with their measured seconds, so it makes the same allocation and
then restores the main chunks too. A surrogate level (``{surrogate: LABEL}``) is evaluated in
this process, not checkpointed (:mod:`.surrogate_level`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence

import numpy as np

from ..core.inputs import InputSpace
from ..core.types import ModelOutput
from ..errors import MethodError
from ..methods.base import Design
from ..methods.mfmc import MultiFidelityMC
from ..models.base import Model
from ..results.result import MethodRun
from ..stats.moments import quiet_overflow
from .surrogate_level import SurrogateLevel
from .checkpoint import RunStore
from .execution import Containment, Executor, Task, Timing, common_grid
from .progress import Progress
from .stage import Stage

log = logging.getLogger(__name__)


def propagate_levels(method: MultiFidelityMC, model: Model, space: InputSpace,
                     outputs: tuple[str, ...], seed: int, executor: Executor, batch_size: int,
                     store: RunStore | None, progress: Progress, design: Design | None,
                     timeout_s: float | None, containment: Containment | None,
                     surrogates: dict[int, SurrogateLevel] | None = None) -> MethodRun:
    """Run ``method`` on the fidelity levels of ``model`` (module docstring); the arguments
    are :func:`~uqguide.driver.propagate.propagate`'s, and ``surrogates`` the surrogate
    levels by level index (:func:`surrogate_levels`)."""
    t_start = time.perf_counter()
    s = method.settings
    design = design or method.design(space, seed)
    surrogates = surrogates or {}
    levels: list[Model | SurrogateLevel] = [
        surrogates[i] if i in surrogates else model.at_fidelity(f)
        for i, f in enumerate(s.fidelities)]
    timings = [Timing() for _ in levels]

    def run_rows(i: int, stage: int, start: int, stop: int) -> ModelOutput | None:
        chunks = method.row_chunks(start, stop)
        if not chunks:
            return None
        level = levels[i]
        if isinstance(level, SurrogateLevel):
            x = design.x.rows(start, stop) if hasattr(design.x, "rows") \
                else np.asarray(design.x)[start:stop]
            return level.run(np.asarray(x), outputs, timings[i])
        st = Stage(method, level, space, outputs, executor, batch_size, store,
                   progress, timings[i], timeout_s, containment)
        tasks = [Task(k, a, b) for k, (a, b) in enumerate(chunks)]
        progress.plan(len(tasks), stop - start, method.label)
        out, _ = st.run(design.x, stage, tasks, None)
        return out

    progress.start(method.label)
    with method.phases_to(progress.phase):
        pilot = []
        for i in range(len(levels)):
            progress.phase(f"pilot of level {i} ({s.n_pilot} runs)")
            out = run_rows(i, 1 + 2 * i, 0, s.n_pilot)
            assert out is not None  # (n_pilot >= 10)
            pilot.append(out)
        # CPU, not wall seconds: on a shared machine the wall clock counts the neighbours' load
        pilot_cost = [t.cpu_seconds / max(t.n_runs, 1) for t in timings]
        with quiet_overflow():  # (as propagate's fits: the model ran before)
            plan = method.allocate(pilot, pilot_cost)
        log.info("%s: levels %s, runs %s (estimated variance reduction %.3g)", method.label,
                 plan.levels, list(plan.sizes), 1.0 / plan.allocation.variance_ratio)
        runs = []
        for j, i in enumerate(plan.levels):
            progress.phase("")
            more = run_rows(i, 2 + 2 * i, s.n_pilot, int(plan.sizes[j]))
            runs.append(pilot[i] if more is None else
                        ModelOutput.concatenate(common_grid([pilot[i], more])))
        t_fit = time.perf_counter()
        progress.phase("estimating")
        with quiet_overflow():
            estimate = method.estimate_levels(
                runs, plan, design, [t.cpu_seconds for t in timings], pilot_cost,
                surrogate_cpu_s=sum(sg.fixed_cpu_s for sg in surrogates.values()))
        progress.phase("")
    fit_seconds = time.perf_counter() - t_fit
    estimate.diagnostics["fit_seconds"] = fit_seconds
    estimate.restrict(outputs)
    top = runs[0]
    return MethodRun(
        estimate=estimate,
        x=np.asarray(design.x.rows(0, top.n)) if hasattr(design.x, "rows")
        else np.asarray(design.x)[:top.n],
        scalars={k: v for k, v in top.scalars.items() if k in outputs},
        failed=top.failed, reasons=top.reasons, time=top.time,
        n_runs=int(sum(t.n_runs for t in timings)),
        model_seconds=float(sum(t.model_seconds for t in timings)),
        fit_seconds=fit_seconds,
        compile_seconds=float(sum(t.compile_seconds for t in timings)),
        wall_seconds=time.perf_counter() - t_start,
    )


def surrogate_levels(method: MultiFidelityMC, earlier: Sequence[MethodRun],
                     outputs: Sequence[str]) -> dict[int, SurrogateLevel]:
    """The surrogate levels of ``method`` from the runs of the methods before it.

    Raises
    ------
    MethodError
        When the PCE method named failed, kept no surrogate, or has none of an output.
    """
    by_label = {r.estimate.label: r for r in earlier}
    out = {}
    for j, label in method.surrogate_levels.items():
        r = by_label.get(label)
        sg = None if r is None else r.estimate.surrogate
        if r is None or not r.success or sg is None:
            why = "did not run" if r is None else (r.message or "kept no surrogate")
            raise MethodError(f"{method.label}: fidelities[{j}] is the surrogate of {label!r}, "
                              f"which has none ({why})")
        level = SurrogateLevel(label=label, surrogate=sg, time=r.time,
                               fixed_cpu_s=float(r.model_seconds + r.fit_seconds))
        missing = level.missing(outputs)
        if missing:
            raise MethodError(f"{method.label}: fidelities[{j}]: the surrogate of {label!r} "
                              f"predicts no {', '.join(missing)} (no expansion kept); leave "
                              f"{'it' if len(missing) == 1 else 'them'} out of outputs or "
                              f"the surrogate level out of fidelities")
        out[j] = level
    return out
