"""The method contract: how a propagation method turns model runs into statistics.

The driver calls one hook, :meth:`Method.propagate`, with a :class:`Runner` that evaluates rows
chunk by chunk. Its default is design, evaluate, refine until :meth:`Method.refine` returns
``None``, estimate; a :class:`StreamingMethod` (Monte Carlo) instead reduces each chunk where it
ran and folds the summaries in chunk order; a multi-fidelity method runs its own phases. A
method that cannot produce statistics raises :class:`~uqguide.errors.MethodError` (or one of
:data:`METHOD_FAILURES`): the run records it and completes the other methods.

Methods see the :class:`~uqguide.core.inputs.InputSpace`, the outputs, the :class:`Runner` and
the :class:`RunContext`, never the model. A new method is a ``Settings`` class and a
:class:`Method` subclass, registered under the entry point group ``uqguide.methods``;
:func:`uqguide.testing.check_method` checks it (``docs/architecture.md``).
"""
from __future__ import annotations

import logging
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from types import MappingProxyType
from typing import Any, ClassVar, Literal, Protocol

import numpy as np
from pydantic import ConfigDict, Field, field_validator

from ..core.names import check_plain_name
from ..core.strict import StrictModel

from ..core.events import EventSpec
from ..core.requirements import RequirementSpec
from ..core.inputs import InputSpace
from ..core.types import DerivedOutput, Estimate, GeneratedRows, ModelOutput
from ..errors import MethodError
from ..stats.moments import quiet_overflow

log = logging.getLogger(__name__)

#: Refinement rounds after which a method that keeps asking for runs is stopped (a guard
#: against a method bug; real methods stop by their own budget long before).
MAX_REFINEMENTS = 100

#: What a method may raise and still leave the run to the other methods: a MethodError (it
#: cannot produce statistics from these runs) or a numerical failure of its fit. A ModelError
#: (a model breaking its contract) and a ConfigError stop the run; so does Ctrl-C.
METHOD_FAILURES = (MethodError, ArithmeticError, ValueError, np.linalg.LinAlgError)

#: Bounds ``[start, stop)`` of consecutive chunks of rows.
Chunks = Sequence[tuple[int, int]]


class MethodSettings(StrictModel):
    """Settings of a method from the config (``methods:`` list entry, less ``name``); a
    method's own settings subclass it."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    label: str | None = Field(default=None,
                              description="name of the method's rows in the tables and of its "
                                          "group in the result file (default: the method's name)")

    # a label names an HDF5 group and files
    _plain_label = field_validator("label")(check_plain_name)


@dataclass
class Design:
    """The runs a method asks for: ``x (n, d)`` in physical units, columns in
    ``InputSpace.names`` order (generated per chunk when the method can: :class:`GeneratedRows`),
    and ``data``, whatever ``estimate`` needs (unit-cube points, quadrature weights, ...)."""

    x: np.ndarray | GeneratedRows
    data: dict[str, Any] = field(default_factory=dict)

    @property
    def n_runs(self) -> int:
        return int(self.x.shape[0])


@dataclass(frozen=True)
class RunPlan:
    """A method's size before it runs: ``runs`` (at most, for a sequential design; None when
    only the design knows), ``chunk`` (rows evaluated and held together; None: the executor's
    ``batch_size``), ``terms`` (basis terms of a surrogate fitted on all runs) and ``exact``
    (else ``runs`` and ``terms`` are upper bounds)."""

    runs: int | None
    chunk: int | None = None
    terms: int = 0
    exact: bool = True


@dataclass(frozen=True, eq=False)
class GivenRows:
    """A design the method does not choose: the rows of a data file (config ``data:``),
    compared by identity (never element by element).

    ``x (n, d)``: the rows' inputs (SI units, ``InputSpace.names`` order); ``source``: the
    file's name for messages; ``failed (n,)``: the rows whose outputs are NaN (a method may
    leave them out of a held-out set, not out of its counts).
    """

    x: np.ndarray
    source: str
    failed: np.ndarray


@dataclass(frozen=True)
class RunContext:
    """What a method is told about the run it is part of, given when it is built
    (:meth:`Method.with_context` makes a new method for a new context).

    ``report_times`` [s]: where a method that must economise concentrates its effort;
    ``failure_policy``: the config's ``pce_failure_policy`` for a design that needs every run
    (``"fail"``: MethodError; ``"regression"``: fit the survivors); ``quantile_levels`` (None:
    none), ``events``, ``requirements``, ``outputs`` (empty: whatever the runs hold) and
    ``groups`` (inputs with a Sobol' index of their own) are the config's; ``components``
    names every output's components; ``derived`` holds the model's derivations of outputs
    from carriers (for a method with :attr:`Method.uses_derivations`).
    """

    report_times: tuple[float, ...] | None = None
    failure_policy: Literal["fail", "regression"] = "fail"
    quantile_levels: tuple[float, ...] | None = None
    events: tuple[EventSpec, ...] = ()
    #: The config's requirements (their success events are among ``events``).
    requirements: tuple[RequirementSpec, ...] = ()
    components: Mapping[str, tuple[str, ...]] = field(
        default_factory=lambda: MappingProxyType({}))
    outputs: tuple[str, ...] = ()
    derived: Mapping[str, DerivedOutput] = field(default_factory=lambda: MappingProxyType({}))
    groups: tuple[tuple[str, tuple[int, ...]], ...] = ()
    #: The data file's rows (config ``data:``): then the design (methods with an empty
    #: :attr:`Method.own_design` only).
    rows: GivenRows | None = None


#: Reduces one chunk where it ran: ``f(out, chunk_index) -> dict of arrays`` (picklable, so
#: that a pool worker can run it).
ChunkReducer = Callable[[ModelOutput, int], dict[str, np.ndarray]]
#: Merges one chunk's summary into the accumulator (None at the start), in chunk order.
ChunkFold = Callable[[Any, dict[str, np.ndarray]], Any]


class Runner(Protocol):
    """How a method's :meth:`~Method.propagate` evaluates rows, lent by the driver: chunks run
    on its executor, are checkpointed, and are folded or joined in chunk order."""

    #: Rows per chunk for a method that does not cut its own (:meth:`Method.chunks`).
    batch_size: int

    @property
    def cpu_seconds(self) -> float:
        """Model CPU seconds of the runs made through this runner so far (where they ran)."""

    @property
    def n_runs(self) -> int:
        """Runs made through this runner so far (restored from a checkpoint included)."""

    @property
    def fixed_cpu_s(self) -> float:
        """CPU seconds spent before the first run (a surrogate level's fit; 0 for a model)."""

    def run(self, x: np.ndarray | GeneratedRows, stage: int, chunks: Chunks, *,
            reduce: tuple[ChunkReducer, ChunkFold] | None = None,
            after: ModelOutput | None = None,
            stop: Callable[[ModelOutput], bool] | None = None) -> tuple[ModelOutput, Any]:
        """Evaluate the rows ``chunks`` of ``x`` as checkpoint stage ``stage``.

        With ``reduce`` (reducer, fold) each chunk is reduced where it ran and folded in chunk
        order: the outputs then hold the scalars, failures and grid only, and the accumulator
        is returned beside them (else None). ``after``: earlier rows' outputs, joined in front.
        ``stop`` (with ``reduce``): asked after each fold with the outputs folded so far; True
        ends the stage there, its outputs cut to those rows (the chunks after are dropped).
        """

    def plan(self, chunks: Chunks) -> None:
        """Count ``chunks`` as work to do (a refinement's, a level's) in the progress display."""

    def phase(self, text: str) -> None:
        """Say what the method does besides running chunks ("" when it runs them)."""

    def at_fidelity(self, changes: Mapping[str, Any]) -> Runner:
        """A runner of the model with these fidelity parameters changed (its own counts)."""

    def surrogate_of(self, label: str) -> Runner:
        """A runner of the surrogate that the method ``label``, listed before this one, fitted;
        MethodError saying why when it has none."""


@dataclass
class Propagated:
    """What a method's propagation ends with (:meth:`Method.propagate`).

    ``x (n, d)``: the inputs of the runs the result keeps, ``outputs`` theirs (None: lost to a
    failure); ``fit_seconds``: the time spent outside the model; ``failure``: why the method
    produced no statistics ("" when it did).
    """

    estimate: Estimate
    x: np.ndarray | GeneratedRows
    outputs: ModelOutput | None
    fit_seconds: float = 0.0
    failure: str = ""

    @classmethod
    def failed(cls, method: Method, exc: Exception, x: np.ndarray | GeneratedRows,
               outputs: ModelOutput | None, fit_seconds: float = 0.0) -> Propagated:
        """A method failure (:data:`METHOD_FAILURES`) recorded with the runs made."""
        return cls(Estimate(method=method.name, label=method.label, stats={}), x, outputs,
                   fit_seconds, why_failed(method, exc))


def why_failed(method: Method, exc: Exception) -> str:
    """One line saying why ``method`` failed (the traceback at debug level, ``-vv``)."""
    if isinstance(exc, MethodError):
        return str(exc)
    log.debug("%s failed", method.label, exc_info=exc)
    return f"{method.label}: {type(exc).__name__}: {exc} (the traceback: uqguide -vv run CONFIG)"


class Method(ABC):
    """A propagation method. ``__init__`` only stores the validated settings and the run
    context; work happens in :meth:`design` and :meth:`propagate` (by default through
    :meth:`refine` and :meth:`estimate`)."""

    name: ClassVar[str]
    summary: ClassVar[str]
    Settings: ClassVar[type[MethodSettings]] = MethodSettings
    #: Derived outputs are computed from surrogates of their carriers (``context.derived``),
    #: so the carriers are evaluated too.
    uses_derivations: ClassVar[bool] = False
    #: A small stage may run in pieces (:mod:`uqguide.driver.chunk_pieces`): model calls
    #: smaller than its chunks, the same numbers.
    runs_in_pieces: ClassVar[bool] = True
    #: The estimate keeps a fitted surrogate (``Estimate.surrogate``), which a multi-fidelity
    #: method may take as a level (``fidelities: [..., {surrogate: LABEL}]``).
    fits_surrogate: ClassVar[bool] = False
    #: The design is drawn from the seed (a quadrature grid is not).
    random_design: ClassVar[bool] = True
    #: Why the method cannot take a data file's rows as its design (config ``data:``), named
    #: in the refusal; empty for a method whose :meth:`design` returns ``context.rows``.
    own_design: ClassVar[str] = "it chooses its own design points"
    #: Every run's outputs stay in memory until the estimate (False for a
    #: :class:`StreamingMethod`); the memory budget and the conformance suite go by it.
    holds_runs: ClassVar[bool] = True
    #: Settings of a small design of several chunks, for :func:`uqguide.testing.check_method`.
    example_settings: ClassVar[Mapping[str, Any]] = {}
    #: Settings whose default is a rule, not a number: ``(setting, rule and why)`` pairs that
    #: ``uqguide methods NAME`` prints (:meth:`default_sizes` gives the rule's numbers).
    default_rules: ClassVar[tuple[tuple[str, str], ...]] = ()

    @classmethod
    def default_sizes(cls, d: int) -> dict[str, int]:
        """The run counts the default rules give for ``d`` inputs (empty: none depend on
        ``d``)."""
        return {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        # a plugin still setting the retired flag would be estimated from whole runs silently
        if cls.__dict__.get("reduces_chunks") and not issubclass(cls, StreamingMethod):
            raise TypeError(f"{cls.__name__}: 'reduces_chunks' is retired; subclass "
                            f"uqguide.methods.base.StreamingMethod instead")

    def __init__(self, settings: MethodSettings | dict[str, Any] | None = None,
                 context: RunContext | None = None) -> None:
        if settings is None:
            settings = self.Settings()
        elif not isinstance(settings, MethodSettings):
            settings = self.Settings(**settings)
        self.settings = settings
        self.context = context or RunContext()
        self._listener: Callable[[str], None] | None = None

    def with_context(self, context: RunContext) -> Method:
        """The same method (same settings) in another run context."""
        return type(self)(self.settings, context)

    @property
    def label(self) -> str:
        return self.settings.label or self.name

    @property
    def derived_outputs(self) -> Mapping[str, DerivedOutput]:
        """The derivations this method computes from carriers (none unless it
        :attr:`uses_derivations`)."""
        return self.context.derived if self.uses_derivations else MappingProxyType({})

    @contextmanager
    def phases_to(self, listener: Callable[[str], None]) -> Iterator[None]:
        """Within the block, tell ``listener`` what a long fit is doing (:meth:`note`)."""
        self._listener = listener
        try:
            yield
        finally:
            self._listener = None

    def note(self, text: str) -> None:
        """Say what the fit is doing now ("fitting zem (2/7)"), for the progress display."""
        if self._listener is not None:
            self._listener(text)

    def check(self, index: int) -> None:
        """Checks of the settings against the rest of the config (events, outputs); raise
        ConfigError naming ``methods[index].<field>``. Default: none."""
        return None

    def check_model(self, model: Any, index: int) -> None:
        """Checks of the settings against the run's model (a multi-fidelity method's levels);
        raise ConfigError naming ``methods[index].<field>``. Default: none."""
        return None

    def check_order(self, methods: Sequence[Method], index: int) -> None:
        """Checks against the config's other methods, this one at ``methods[index]`` (a
        surrogate level names a method listed before it); raise ConfigError. Default: none."""
        return None

    def min_rows(self, d: int) -> int:
        """Least successful rows of a data file (config ``data:``) the method needs for ``d``
        inputs. Default 1."""
        return 1

    def sensitivity_for(self, space: InputSpace, n_runs: int) -> bool:
        """Whether a run of ``n_runs`` estimates given-data Sobol' indices from its own runs
        (the memory budget counts what they keep). Default: no."""
        return False

    def plan(self, space: InputSpace) -> RunPlan:
        """What the method will ask for, before any design is built (for the budgets).
        Default: unknown."""
        return RunPlan(runs=None)

    @abstractmethod
    def design(self, space: InputSpace, seed: int) -> Design:
        """The initial runs to make; ``seed`` is the run's root seed, from which the method
        derives its own streams."""

    def refine(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Design | None:
        """An enlarged design after seeing ``outputs`` of ``design`` (default: none).

        Returns ``None`` when no more runs are needed, or a new Design whose ``x`` is
        ``design.x`` with the new runs appended; the driver evaluates those and calls
        ``refine`` again with all the outputs.
        """
        return None

    @abstractmethod
    def estimate(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Estimate:
        """Statistics of every output in ``outputs`` from the runs of ``design``."""

    def chunks(self, n_runs: int, batch_size: int) -> list[tuple[int, int]]:
        """Consecutive chunks ``[start, stop)`` covering ``[0, n_runs)`` (one empty chunk when
        ``n_runs`` is 0). Default: slices of ``batch_size``."""
        return [(s, min(n_runs, s + batch_size)) for s in range(0, max(n_runs, 1), batch_size)]

    def planned_chunks(self, design: Design, batch_size: int) -> list[tuple[int, int]] | None:
        """The chunks of ``design`` known before it runs (for the progress display); None when
        the method plans its runs as it goes."""
        return self.chunks(design.n_runs, batch_size)

    def propagate(self, space: InputSpace, design: Design, runner: Runner) -> Propagated:
        """Run ``design`` through ``runner`` and estimate: the hook the driver calls.

        Default: evaluate the design, :meth:`refine` until it returns None (at most
        :data:`MAX_REFINEMENTS` times), :meth:`estimate`. A failure of either
        (:data:`METHOD_FAILURES`) is returned with the runs made.
        """
        out, _ = runner.run(design.x, 0, self.chunks(design.n_runs, runner.batch_size))
        fit_seconds = 0.0
        for k in range(1, MAX_REFINEMENTS + 1):
            t0 = time.perf_counter()
            # no ETA paces what follows: say what the method does until it says more itself
            runner.phase("refining the design")
            try:
                with quiet_overflow():  # fits only: the model ran before
                    bigger = self.refine(space, design, out)
            except METHOD_FAILURES as exc:
                fit_seconds += time.perf_counter() - t0
                return Propagated.failed(self, exc, design.x, out, fit_seconds)
            fit_seconds += time.perf_counter() - t0
            if bigger is None:
                break
            new_x = _appended_rows(design, bigger)
            log.info("%s: %d more runs (sequential design)", self.label, new_x.shape[0])
            chunks = self.chunks(new_x.shape[0], runner.batch_size)
            runner.plan(chunks)
            runner.phase("")  # planned first: the line it shows counts the new runs
            out, _ = runner.run(new_x, k, chunks, after=out)
            design = bigger
        else:
            log.warning("%s: stopped after %d refinements", self.label, MAX_REFINEMENTS)
        return self.estimated(lambda: self.estimate(space, design, out), design.x, out,
                              runner, fit_seconds)

    def estimated(self, estimate: Callable[[], Estimate], x: np.ndarray | GeneratedRows,
                  outputs: ModelOutput, runner: Runner, fit_seconds: float = 0.0) -> Propagated:
        """``estimate()`` timed (added to ``fit_seconds``), its failure recorded with the runs."""
        t0 = time.perf_counter()
        runner.phase("estimating")
        try:
            with quiet_overflow():  # statistics only (driver.propagate.say_overflow)
                done = Propagated(estimate(), x, outputs)
        except METHOD_FAILURES as exc:
            done = Propagated.failed(self, exc, x, outputs)
        runner.phase("")
        done.fit_seconds = fit_seconds + time.perf_counter() - t0
        return done


class StreamingMethod(Method):
    """A method estimated from chunks reduced where they ran, folded in chunk order: the split
    is the method's (:meth:`chunk_bounds`), never the executor's. It does not refine.
    :meth:`estimate` reduces and folds in-memory outputs as the driver does, bit for bit.
    """

    holds_runs = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.refine is not Method.refine:
            raise TypeError(f"{cls.__name__}: a streaming method cannot refine (its runs are "
                            f"folded into summaries, never seen whole)")

    @abstractmethod
    def chunk_bounds(self, n_runs: int) -> list[tuple[int, int]]:
        """The chunks ``[start, stop)`` of the design: the unit of reduction and checkpoints."""

    @abstractmethod
    def reducer(self, space: InputSpace, design: Design) -> ChunkReducer:
        """The reduction of one chunk of ``design``, run where the chunk ran."""

    @abstractmethod
    def fold(self, acc: Any, summary: dict[str, np.ndarray]) -> Any:
        """Merge one chunk's summary into the accumulator (``acc`` is None at the start); the
        driver folds in chunk order."""

    @abstractmethod
    def estimate_reduced(self, space: InputSpace, design: Design, runs: ModelOutput,
                         acc: Any) -> Estimate:
        """Statistics from the folded summaries; ``runs`` holds the scalars, failures and grid."""

    def chunks(self, n_runs: int, batch_size: int) -> list[tuple[int, int]]:
        """The method's own split (:meth:`chunk_bounds`): ``batch_size`` does not apply."""
        return self.chunk_bounds(n_runs)

    def propagate(self, space: InputSpace, design: Design, runner: Runner) -> Propagated:
        """Each chunk reduced where it ran and folded in chunk order, then
        :meth:`estimate_reduced`."""
        out, acc = runner.run(design.x, 0, self.chunks(design.n_runs, runner.batch_size),
                              reduce=(self.reducer(space, design), self.fold))
        return self.estimated(lambda: self.estimate_reduced(space, design, out, acc),
                              design.x, out, runner)

    def estimate(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Estimate:
        reduce = self.reducer(space, design)
        acc = None
        for i, (a, b) in enumerate(self.chunk_bounds(outputs.n)):
            acc = self.fold(acc, reduce(outputs.subset(np.arange(a, b)), i))
        runs = ModelOutput(time=outputs.time, scalars=outputs.scalars, failed=outputs.failed,
                           reasons=outputs.reasons)
        return self.estimate_reduced(space, design, runs, acc)


def _appended_rows(old: Design, new: Design) -> np.ndarray:
    """The rows a refined design appends to ``old`` (whose rows it must keep first)."""
    n_old = old.x.shape[0]
    if new.x.shape[0] <= n_old or not np.array_equal(new.x[:n_old], old.x):
        raise RuntimeError("a refined design must keep the old runs first and append new ones")
    return new.x[n_old:]
