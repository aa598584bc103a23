"""The unit of work: a chunk of a design's rows, what every chunk of one design shares (with
where a worker writes per-run values in shared memory), and what comes back from one."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from ...core.types import ModelOutput
from .transport import ModelHandle

#: Samples per model call when neither the config nor the executor says otherwise.
DEFAULT_BATCH_SIZE = 10_000


@dataclass
class Timing:
    """Worker-seconds spent in the model and, apart, compiling its kernel, summed over chunks;
    the number of runs; the CPU seconds of the model calls (a multi-fidelity method's costs)."""

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

    ``time (T,)`` (empty when every sample failed); ``scalars (m, k)``; ``series (m, T, k)`` or
    the method's ``summary`` when reduced; the wall and CPU seconds of the model calls, each
    less ``compile_seconds`` (the CPU measured in the process that made the calls:
    :func:`.isolation.timed_batch`); ``in_place``: per-run values the worker wrote into shared
    memory instead (:mod:`.shared_rows`), as ``(scalars or summary, key, n runs)``.
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
    """How a run contains a model that may crash or leak: ``isolate`` its calls in a guard
    process when there are no workers; ``asked`` by the config (a model that cannot be built in a
    guard then stops the run, else it runs here with a warning); ``memory_limit``: bytes of
    address space of each child process."""

    isolate: bool = False
    asked: bool = False
    memory_limit: int | None = None


@dataclass(frozen=True)
class Slot:
    """One array in shared memory (:mod:`.shared_rows`): ``part`` (``scalars`` or ``summary``)
    and ``key`` name the value in a :class:`ChunkResult`; ``runs_axis``: the axis along which
    the runs lie (0: a row per run; 1: lane-major, a column per good run)."""

    part: str
    key: str
    path: str
    shape: tuple[int, ...]
    dtype: str
    runs_axis: int

    def open(self) -> np.memmap:
        return np.memmap(self.path, dtype=np.dtype(self.dtype), mode="r+", shape=self.shape)


#: Where a chunk's per-run values go (picklable: it travels with every chunk).
RowsLayout = tuple[Slot, ...]


@dataclass
class ChunkJob:
    """What every chunk of one design shares (sent along with each chunk; small)."""

    model: ModelHandle
    names: tuple[str, ...]
    outputs: tuple[str, ...]
    batch_size: int
    reducer: Reducer | None = None
    #: Seconds a model call may take; set, every call runs in a guard process.
    timeout_s: float | None = None
    #: Run the calls in a guard process even without a timeout (crash isolation).
    guarded: bool = False
    #: When the guard cannot start or cannot build the model, evaluate in this process
    #: instead of stopping (the isolation a callable gets by default, not one asked for).
    guard_fallback: bool = False
    #: Bytes of address space each child process may use (None: no limit).
    memory_limit: int | None = None
    #: Design rows known to crash or hang their process, with the reason: they fail unrun.
    known: Mapping[int, str] = field(default_factory=dict)
    #: Told ``(design row, reason)`` for each row isolated by a crash or a timeout (the driver
    #: records it; never sent to a worker).
    on_isolated: Callable[[int, str], None] | None = None
    #: Where a worker writes a reduced chunk's per-run values in place, once the first chunk
    #: back has shown their shapes (:mod:`.shared_rows`).
    shared: RowsLayout | None = None

    def __getstate__(self) -> dict[str, Any]:
        # the driver's callback (it writes the run folder) stays with the driver
        return {**self.__dict__, "on_isolated": None}
