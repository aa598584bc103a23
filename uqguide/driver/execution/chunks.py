"""The unit of work: a chunk of a design's rows, what every chunk of one design shares, and
what comes back from one."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

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
    (never in ``model_seconds``), and the number of runs."""

    model_seconds: float = 0.0
    n_runs: int = 0
    compile_seconds: float = 0.0


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
    """What comes back from one chunk.

    Attributes
    ----------
    task : Task
    failed : ndarray of bool, shape (m,)
    reasons : ndarray of object, shape (m,)
    time : ndarray, shape (T,)
        The model's grid (may be empty when every sample of the chunk failed).
    scalars : dict of str to ndarray, shape (m, k)
    series : dict of str to ndarray, shape (m, T, k)
        Empty when the chunk was reduced.
    summary : dict of str to ndarray
        The method's reduction of the chunk (empty when not reduced).
    model_seconds : float
        Wall seconds of the model calls of this chunk, less ``compile_seconds``.
    compile_seconds : float
        Seconds the chunk's process spent compiling a kernel during those calls (a first run
        on a fresh install; :func:`uqguide.models.kernels.compile_seconds`).
    in_place : tuple of (part, key, n)
        Per-run values the worker wrote into the driver's shared arrays instead of sending
        them (:mod:`uqguide.driver.execution.shared_rows`): ``scalars`` or ``summary``, the key, the
        number of runs.
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
    in_place: tuple[tuple[str, str, int], ...] = ()

    @property
    def n_failed(self) -> int:
        return int(np.sum(self.failed))

    def output(self) -> ModelOutput:
        """The chunk's runs as a model output (its series, if any were kept).

        Returns
        -------
        ModelOutput
            ``m`` samples: scalars ``(m, k)``, series ``(m, T, k)``, failures ``(m,)``.
        """
        return ModelOutput(time=self.time, series=self.series, scalars=self.scalars,
                           failed=self.failed, reasons=self.reasons)


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
    #: Where the worker writes the per-run values of a reduced chunk in place (shared memory,
    #: :mod:`uqguide.driver.execution.shared_rows`); set by the driver once the first chunk back has
    #: shown their shapes, so the chunks sent before it bring theirs through the pipe.
    shared: RowsLayout | None = None
