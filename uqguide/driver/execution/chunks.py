"""The unit of work: a chunk of a design's rows, what every chunk of one design shares, and
what comes back from one."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from ...core.types import ModelOutput
from .row_layout import RowsLayout
from .transport import ModelHandle

#: Samples per model call when neither the config nor the executor says otherwise.
DEFAULT_BATCH_SIZE = 10_000


@dataclass
class Timing:
    """Seconds spent in the model, summed over chunks (worker-seconds: with ``w`` workers busy
    this grows ``w`` times faster than the wall clock), seconds spent compiling its kernel
    (never in ``model_seconds``), the number of runs, and the CPU seconds of the model calls
    (``cpu_seconds``: what a multi-fidelity method's costs are measured in)."""

    model_seconds: float = 0.0
    n_runs: int = 0
    compile_seconds: float = 0.0
    cpu_seconds: float = 0.0


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
    """What comes back from one chunk of ``m`` runs.

    ``time (T,)``: the model's grid (may be empty when every sample failed); ``scalars``
    ``(m, k)``; ``series`` ``(m, T, k)``, empty when the chunk was reduced; ``summary``: the
    method's reduction (empty when not reduced); ``model_seconds``: wall seconds of the model
    calls less ``compile_seconds`` (compiling a kernel in those calls, a first run on a fresh
    install: :func:`uqguide.models.kernels.compile_seconds`); ``cpu_seconds``: CPU seconds of
    the chunk's process in those calls (``time.process_time``, all its threads) less
    ``compile_seconds``, not inflated by other processes on a busy machine; ``in_place``: per-run
    values the worker wrote into the driver's shared arrays instead of sending them
    (:mod:`uqguide.driver.execution.shared_rows`), as ``(scalars or summary, key, n runs)``.
    """

    task: Task
    failed: np.ndarray
    reasons: np.ndarray
    time: np.ndarray
    scalars: dict[str, np.ndarray]
    series: dict[str, np.ndarray] = field(default_factory=dict)
    summary: dict[str, np.ndarray] = field(default_factory=dict)
    model_seconds: float = 0.0
    compile_seconds: float = 0.0
    cpu_seconds: float = 0.0
    in_place: tuple[tuple[str, str, int], ...] = ()

    @property
    def n_failed(self) -> int:
        return int(np.sum(self.failed))

    def output(self) -> ModelOutput:
        """The chunk's runs as a model output (its series, if any were kept)."""
        return ModelOutput(time=self.time, series=self.series, scalars=self.scalars,
                           failed=self.failed, reasons=self.reasons)


@dataclass(frozen=True)
class Containment:
    """How a run contains a model that may crash or leak.

    ``isolate``: without workers, make the model calls in a guard process (a crash then costs
    the samples that crash, found by bisection); ``asked``: the config asked for it
    (``model.isolate: true``), so a model that cannot be built in a guard process stops the run,
    where otherwise (a callable's default) the run falls back to its own process with a warning;
    ``memory_limit``: bytes of address space of each child process (guards, pool workers).
    """

    isolate: bool = False
    asked: bool = False
    memory_limit: int | None = None


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
    #: When the guard cannot start or cannot build the model, evaluate in this process
    #: instead of stopping (the isolation a callable gets by default, not one asked for).
    guard_fallback: bool = False
    #: Bytes of address space each child process may use (guard processes, pool workers):
    #: the run's ``max_memory``; None: no limit.
    memory_limit: int | None = None
    #: Rows of the stage (design row numbers) known to crash or hang their process, with the
    #: reason recorded when they did: they fail again without being run.
    known: Mapping[int, str] = field(default_factory=dict)
    #: Told ``(design row, reason)`` for each row isolated by a crash or a timeout, in the
    #: process that found it; never sent to a worker (the driver records the rows).
    on_isolated: Callable[[int, str], None] | None = None
    #: Where the worker writes the per-run values of a reduced chunk in place (shared memory,
    #: :mod:`uqguide.driver.execution.shared_rows`); set by the driver once the first chunk back has
    #: shown their shapes, so the chunks sent before it bring theirs through the pipe.
    shared: RowsLayout | None = None

    def __getstate__(self) -> dict[str, Any]:
        # the driver's callback (it writes the run folder) stays with the driver
        return {**self.__dict__, "on_isolated": None}
