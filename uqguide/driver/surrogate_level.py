"""A fitted PCE of the study as a fidelity level of :mod:`uqguide.methods.mfmc`
(``fidelities: [..., {surrogate: apce}]``): a :class:`~uqguide.methods.base.Runner`.

The surrogate is evaluated here, in the driver's process, on the same rows as every other
level: it costs microseconds per run, so workers would add pickling and nothing else. Its
chunks are not checkpointed: a resumed run re-fits the PCE from its own method's checkpoint
(the same bits). Why the estimate stays unbiased: ``docs/multifidelity.md``.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.types import GeneratedRows, ModelOutput
from ..errors import MethodError
from ..methods.base import ChunkFold, ChunkReducer, Chunks
from ..pce.surrogate import Surrogate
from ..results.result import MethodRun
from .execution import Timing, common_grid


class Counted:
    """A :class:`~uqguide.methods.base.Runner`'s counts, those of its ``timing``."""

    timing: Timing

    @property
    def cpu_seconds(self) -> float:
        return self.timing.cpu_seconds

    @property
    def n_runs(self) -> int:
        return self.timing.n_runs


@dataclass
class SurrogateLevel(Counted):
    """The surrogate of the PCE method ``label`` as a level: ``time (T,)``, its series' grid;
    ``fixed_cpu_s``: the PCE method's model and fit seconds (the surrogate's price);
    ``outputs``: those it predicts; ``timing``: its runs and CPU seconds so far."""

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
            after: ModelOutput | None = None) -> tuple[ModelOutput, Any]:
        """Its values at the rows ``chunks`` of ``x`` in one call, joined after ``after``."""
        if reduce is not None:
            raise MethodError(f"the surrogate of {self.label!r} is evaluated whole, not reduced")
        start, stop = chunks[0][0], chunks[-1][1]
        rows = x.rows(start, stop) if isinstance(x, GeneratedRows) else np.asarray(x)[start:stop]
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
