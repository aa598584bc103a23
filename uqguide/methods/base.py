"""The method contract: how a propagation method turns model runs into statistics.

A method works in phases, so a design can be stored, run elsewhere and resumed:

1. :meth:`Method.design` gives the runs to make (inputs ``x (n, d)`` plus whatever the method
   needs later, e.g. quadrature weights);
2. the driver (:func:`uqguide.driver.propagate.propagate`) evaluates the model on the design;
3. :meth:`Method.refine` may ask for more runs (a sequential design); the driver evaluates them
   and calls it again until it returns ``None``;
4. :meth:`Method.estimate` gives the statistics and diagnostics. A method that cannot produce
   statistics raises :class:`~uqguide.errors.MethodError`: the run records it and completes
   the other methods.

A :class:`StreamingMethod` (Monte Carlo) is estimated instead from chunks reduced where they
ran: the driver applies its :meth:`~StreamingMethod.reducer` to each chunk of its
:meth:`~StreamingMethod.chunk_bounds`, merges the summaries in chunk order with
:meth:`~StreamingMethod.fold` and ends with :meth:`~StreamingMethod.estimate_reduced`, so time
series never travel or stay. Such a method does not refine: it never sees whole runs.

Methods never know which model they run: they see the :class:`~uqguide.core.inputs.InputSpace`,
the :class:`~uqguide.core.types.ModelOutput` and the :class:`RunContext` they were built with
(``self.context``: report times, events, quantile levels, failure policy, outputs).

A new method is one module with a ``Settings`` class and a subclass of :class:`Method` (or of
:class:`StreamingMethod`) with its ``example_settings``, plus one line in
:mod:`uqguide.config.registry`; the conformance suite (:func:`uqguide.testing.check_method`)
then checks it with no test code. What the driver may do with a method follows from its class;
the class flags left (:attr:`Method.uses_derivations`, :attr:`Method.random_design`) are
choices a class makes, not protocols.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from types import MappingProxyType
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import ConfigDict, Field, field_validator

from ..core.names import check_plain_name
from ..core.strict import StrictModel

from ..core.events import EventSpec
from ..core.inputs import InputSpace
from ..core.types import DerivedOutput, Estimate, GeneratedRows, ModelOutput


class MethodSettings(StrictModel):
    """Settings of a method from the config (``methods:`` list entry, less ``name``).

    ``label`` names the method's row in tables and its group in the result file; it defaults to
    the method's name and must be unique within a config.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    label: str | None = Field(default=None,
                              description="name of the method's rows in the tables and of its "
                                          "group in the result file (default: the method's name)")

    # a label names an HDF5 group and files: "." and ".." passed the old character pattern
    _plain_label = field_validator("label")(check_plain_name)


@dataclass
class Design:
    """The runs a method asks for.

    Attributes
    ----------
    x : ndarray or GeneratedRows, shape (n, d)
        Inputs in physical units, columns in the order of ``InputSpace.names`` (generated per
        chunk when the method can: :class:`GeneratedRows`).
    data : dict
        Whatever the method needs in ``estimate`` (unit-cube points, quadrature weights, ...).
    """

    x: np.ndarray | GeneratedRows
    data: dict[str, Any] = field(default_factory=dict)

    @property
    def n_runs(self) -> int:
        return int(self.x.shape[0])


@dataclass(frozen=True)
class RunPlan:
    """A method's size before it runs.

    Attributes
    ----------
    runs : int or None
        Model runs (at most, for a sequential design); None when only the design knows.
    chunk : int or None
        Rows evaluated and held together (Monte Carlo: ``chunk_size``); None: the executor's
        ``batch_size``.
    terms : int
        Basis terms of a surrogate fitted on all runs (0: none).
    exact : bool
        Whether ``runs`` and ``terms`` are exact (else upper bounds).
    """

    runs: int | None
    chunk: int | None = None
    terms: int = 0
    exact: bool = True


@dataclass(frozen=True, eq=False)
class GivenRows:
    """A design the method does not choose: the rows of a data file (config ``data:``).

    Compared by identity (two contexts hold the same rows only when they share this object),
    so that comparing contexts never compares arrays element by element.

    Attributes
    ----------
    x : ndarray, shape (n, d)
        The rows' inputs, SI units, columns in ``InputSpace.names`` order.
    source : str
        The file, for messages.
    failed : ndarray of bool, shape (n,)
        Rows whose outputs are NaN (failed runs): a method may leave them out of a
        held-out set, not out of its counts.
    """

    x: np.ndarray
    source: str
    failed: np.ndarray


@dataclass(frozen=True)
class RunContext:
    """What a method is told about the run it is part of: given when it is built, never set on
    it afterwards (:meth:`Method.with_context` makes a new method for a new context).

    Attributes
    ----------
    report_times : tuple of float, optional
        The run's report times [s]: where a method that must economise (e.g. Monte Carlo
        bootstrap intervals of long series) concentrates its effort.
    failure_policy : {"fail", "regression"}
        What a method whose design needs every run (a quadrature grid) does when runs
        failed (the config's ``pce_failure_policy``): ``"fail"`` raises MethodError naming the
        failed runs; ``"regression"`` fits by least squares on the surviving runs, logs a
        warning and says so in the diagnostics.
    quantile_levels : tuple of float, optional
        The config's quantile levels (None: no quantiles).
    events : tuple of EventSpec
        The config's events.
    components : mapping of str to tuple of str
        Component names of every output the method may see (for events on multi-component
        outputs).
    outputs : tuple of str
        The outputs the result reports (empty: whatever the runs hold).
    derived : mapping of str to DerivedOutput
        The model's derivations of reported outputs from smoother carriers; a method with
        :attr:`Method.uses_derivations` fits the carriers and derives the output from their
        surrogates, the others use the model's own values.
    groups : tuple of (str, tuple of int)
        Groups of inputs (name, input columns) that get a Sobol' index of their own: the
        config's ``groups``, or by default each correlated group.
    """

    report_times: tuple[float, ...] | None = None
    failure_policy: Literal["fail", "regression"] = "fail"
    quantile_levels: tuple[float, ...] | None = None
    events: tuple[EventSpec, ...] = ()
    components: Mapping[str, tuple[str, ...]] = field(
        default_factory=lambda: MappingProxyType({}))
    outputs: tuple[str, ...] = ()
    derived: Mapping[str, DerivedOutput] = field(default_factory=lambda: MappingProxyType({}))
    groups: tuple[tuple[str, tuple[int, ...]], ...] = ()
    #: The data file's rows when the config gives ``data:``: the method's design is then
    #: these rows, not points it draws (only methods with an empty :attr:`Method.own_design`).
    rows: GivenRows | None = None


class Method(ABC):
    """A propagation method. ``__init__`` only stores the validated settings and the run
    context; work happens in :meth:`design`, :meth:`refine` and :meth:`estimate`."""

    name: ClassVar[str]
    summary: ClassVar[str]
    Settings: ClassVar[type[MethodSettings]] = MethodSettings
    #: Derived outputs are computed from surrogates of their carriers (``context.derived``),
    #: so the carriers are evaluated too.
    uses_derivations: ClassVar[bool] = False
    #: The estimate keeps a fitted surrogate (``Estimate.surrogate``), which a multi-fidelity
    #: method may take as a level (``fidelities: [..., {surrogate: LABEL}]``).
    fits_surrogate: ClassVar[bool] = False
    #: The design is drawn from the seed (another seed, another design); a quadrature grid is
    #: not.
    random_design: ClassVar[bool] = True
    #: Why the method cannot take a data file's rows as its design (config ``data:``), named
    #: in the refusal; empty for a method whose :meth:`design` returns ``context.rows``.
    own_design: ClassVar[str] = "it chooses its own design points"
    #: Settings of a small design that still exercises the method (several chunks): what the
    #: conformance suite (:func:`uqguide.testing.check_method`) runs it with.
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
        # The flag that used to ask for the streaming protocol would now be ignored, and the
        # method estimated from whole runs: refuse it where the class is written.
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
        """Within the block, tell ``listener`` what a long fit is doing ("fitting zem (2/7)"),
        for the progress display."""
        self._listener = listener
        try:
            yield
        finally:
            self._listener = None

    def note(self, text: str) -> None:
        """Say what the fit is doing now (see :meth:`phases_to`)."""
        if self._listener is not None:
            self._listener(text)

    def check(self, index: int) -> None:
        """Checks of the settings against the rest of the config (events, outputs), after
        those are set; raise ConfigError naming ``methods[index].<field>``. Default: none.

        A hook that methods override when they have such checks, not an abstract method: most
        have none.
        """
        return None

    def plan(self, space: InputSpace) -> RunPlan:
        """What the method will ask for, known before any design is built (for the budgets
        of :mod:`uqguide.config.budget`). Default: unknown until the design is built."""
        return RunPlan(runs=None)

    @abstractmethod
    def design(self, space: InputSpace, seed: int) -> Design:
        """The initial runs to make.

        Parameters
        ----------
        space : InputSpace
        seed : int
            Root seed of the run; the method derives its own streams from it.
        """

    def refine(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Design | None:
        """An enlarged design after seeing ``outputs`` of ``design`` (default: none).

        Returns ``None`` when no more runs are needed, or a new Design whose ``x`` starts with
        the rows of ``design.x`` unchanged and appends the new runs; the driver evaluates only
        the appended rows and calls ``refine`` again with the concatenated outputs.
        """
        return None

    @abstractmethod
    def estimate(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Estimate:
        """Statistics of every output in ``outputs`` from the runs of ``design``."""


#: Reduces one chunk where it ran: ``f(out, chunk_index) -> dict of arrays`` (picklable, so
#: that a pool worker can run it).
ChunkReducer = Callable[[ModelOutput, int], dict[str, np.ndarray]]


class StreamingMethod(Method):
    """A method estimated from chunks reduced where they ran (module docstring): its
    statistics depend on how the design splits into chunks, so the split is the method's
    (:meth:`chunk_bounds`), never the executor's. It does not refine.

    :meth:`estimate` is given: it reduces and folds in-memory outputs chunk by chunk exactly
    as the driver does, so it gives the numbers of a streamed run bit for bit.
    """

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.refine is not Method.refine:
            raise TypeError(f"{cls.__name__}: a streaming method cannot refine (its runs are "
                            f"folded into summaries, never seen whole)")

    @abstractmethod
    def chunk_bounds(self, n_runs: int) -> list[tuple[int, int]]:
        """How the ``n_runs`` rows of the design split into chunks ``[start, stop)``, the unit
        of reduction, of the executors' work and of checkpoints."""

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
        """Statistics from the folded summaries; ``runs`` has the per-sample scalars, the
        failure mask and the time grid, but no series."""

    def estimate(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Estimate:
        reduce = self.reducer(space, design)
        acc = None
        for i, (a, b) in enumerate(self.chunk_bounds(outputs.n)):
            acc = self.fold(acc, reduce(outputs.subset(np.arange(a, b)), i))
        runs = ModelOutput(time=outputs.time, scalars=outputs.scalars, failed=outputs.failed,
                           reasons=outputs.reasons)
        return self.estimate_reduced(space, design, runs, acc)


def chunk_bounds(method: Method, n_runs: int, batch_size: int) -> list[tuple[int, int]]:
    """How ``n_runs`` new rows of ``method``'s design split into chunks ``[start, stop)``: a
    streaming method's own split, else slices of ``batch_size``.

    Parameters
    ----------
    method : Method
    n_runs : int
        Rows to evaluate (a refinement's appended rows, or the whole design).
    batch_size : int
        Rows per chunk for a method that does not stream.

    Returns
    -------
    list of (int, int)
        Consecutive bounds covering ``[0, n_runs)`` (one empty chunk when ``n_runs`` is 0).
    """
    if isinstance(method, StreamingMethod):
        return method.chunk_bounds(n_runs)
    return [(s, min(n_runs, s + batch_size)) for s in range(0, max(n_runs, 1), batch_size)]
