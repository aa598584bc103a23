"""The method contract: how a propagation method turns model runs into statistics.

A method works in phases, so a design can be stored, run elsewhere and resumed:

1. :meth:`Method.design` gives the runs to make (inputs ``x (n, d)`` plus whatever the method
   needs later, e.g. quadrature weights);
2. the driver (:func:`uqguide.propagate.propagate`) evaluates the model on the design;
3. :meth:`Method.refine` may ask for more runs (sequential designs); the driver evaluates them
   and calls it again until it returns ``None``;
4. :meth:`Method.estimate` gives the statistics and diagnostics.

Methods never know which model they run: they see the :class:`~uqguide.inputs.InputSpace` and the
:class:`~uqguide.models.base.ModelOutput`.

A new method is one module with a ``Settings`` class and a ``Method`` subclass, plus one line in
:mod:`uqguide.registry`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from collections.abc import Callable
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from ..strict import no_bool_numbers

from ..events import EventSpec
from ..inputs import InputSpace
from ..types import Estimate, GeneratedRows, ModelOutput


class MethodSettings(BaseModel):
    """Settings of a method from the config (``methods:`` list entry, less ``name``).

    ``label`` names the method's row in tables and its group in the result file; it defaults to
    the method's name and must be unique within a config.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    label: str | None = Field(default=None, min_length=1, pattern=r"^[A-Za-z0-9_.\-]+$",
                              description="name of the method's rows in the tables and of its "
                                          "group in the result file (default: the method's name)")

    _no_bool_numbers = model_validator(mode="before")(classmethod(no_bool_numbers))


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
    reduced : bool
        Whether chunks are reduced where they ran (series never kept whole).
    terms : int
        Basis terms of a surrogate fitted on all runs (0: none).
    exact : bool
        Whether ``runs`` and ``terms`` are exact (else upper bounds).
    """

    runs: int | None
    chunk: int | None = None
    reduced: bool = False
    terms: int = 0
    exact: bool = True


class Method(ABC):
    """A propagation method. ``__init__`` only stores the validated settings."""

    name: ClassVar[str]
    summary: ClassVar[str]
    Settings: ClassVar[type[MethodSettings]] = MethodSettings
    #: The run's report times [s] (set from the config): where a method that must economise
    #: (e.g. Monte Carlo bootstrap intervals of long series) concentrates its effort.
    report_times: tuple[float, ...] | None = None
    #: What a method whose design needs every run (quadrature) does when runs failed (set from
    #: the config's ``pce_failure_policy``): ``"fail"`` raises MethodError naming the failed
    #: runs; ``"regression"`` fits the coefficients by least squares on the surviving nodes,
    #: logs a warning and says so in the diagnostics. Sampling methods ignore it.
    failure_policy: Literal["fail", "regression"] = "fail"
    #: The config's quantile levels (None: no quantiles) and events (set from the config).
    quantile_levels: tuple[float, ...] | None = None
    events: tuple[EventSpec, ...] = ()
    #: Components of every output the method may see (name -> component names; from the
    #: config), for the events on multi-component outputs.
    components: dict[str, tuple[str, ...]] = {}
    #: Told what a long fit is doing ("fitting zem (2/7)"), for the progress display; set by
    #: the driver (None: nobody listens).
    on_phase: Callable[[str], None] | None = None

    def __init__(self, settings: MethodSettings | dict[str, Any] | None = None) -> None:
        if settings is None:
            settings = self.Settings()
        elif not isinstance(settings, MethodSettings):
            settings = self.Settings(**settings)
        self.settings = settings

    @property
    def label(self) -> str:
        return self.settings.label or self.name

    def note(self, text: str) -> None:
        """Say what the fit is doing now (see ``on_phase``)."""
        if self.on_phase is not None:
            self.on_phase(text)

    def check(self, index: int) -> None:
        """Checks of the settings against the rest of the config (events, outputs), after
        those are set; raise ConfigError naming ``methods[index].<field>``. Default: none."""

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

    # ------------------------------------------------------------------ budgets
    def plan(self, space: InputSpace) -> RunPlan:
        """What the method will ask for, known before any design is built (for the budgets
        of :mod:`uqguide.budget`). Default: unknown until the design is built."""
        return RunPlan(runs=None)

    # ------------------------------------------------------------------ execution hooks
    def chunk_bounds(self, n_runs: int, batch_size: int) -> list[tuple[int, int]]:
        """How ``n_runs`` new rows of a design split into chunks ``[start, stop)``: the unit of
        work of the executors and of checkpoints (default: ``batch_size`` slices). A method
        that reduces chunks (:meth:`reducer`) splits where its statistics need it."""
        return [(s, min(n_runs, s + batch_size)) for s in range(0, max(n_runs, 1), batch_size)]

    def reducer(self, space: InputSpace, design: Design) -> Any:
        """A picklable ``f(out: ModelOutput, chunk_index) -> dict of arrays`` that reduces a
        chunk where it ran, or ``None`` (default) to bring back every output of every run.

        A method with a reducer does not refine, and is estimated by :meth:`fold` (driver, in
        chunk order) and :meth:`estimate_reduced`, so time series never travel or stay.
        """
        return None

    def fold(self, acc: Any, summary: dict[str, np.ndarray]) -> Any:
        """Merge one chunk's summary into the accumulator (``acc`` is None at the start)."""
        raise NotImplementedError(f"method '{self.name}' has no reducer")

    def estimate_reduced(self, space: InputSpace, design: Design, runs: ModelOutput,
                         acc: Any) -> Estimate:
        """Statistics from the folded summaries; ``runs`` has the per-sample scalars, the
        failure mask and the time grid, but no series."""
        raise NotImplementedError(f"method '{self.name}' has no reducer")
