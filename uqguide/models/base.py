"""The model contract (uq-methods.md section 1).

A model maps a batch of input samples to named outputs, all at once:

- input: ``x`` of shape ``(n, d)`` in SI units, one column per uncertain input named in the
  config; inputs the config does not name keep their nominal values;
- output: a :class:`ModelOutput` with a time grid ``(T,)`` shared by the whole batch, time
  series ``(n, T, k)``, scalars ``(n, k)`` and a failure mask ``(n,)`` with a reason per
  failed sample.

Methods see models only through :meth:`Model.evaluate`, so any model (a built-in simulator, an
analytic benchmark, a user's Python callable) can be propagated by any method.

A new simulator is a subclass with ``name``, ``summary``, a ``Params`` class, ``inputs()``,
``outputs()`` and ``_evaluate``; registering it is one line in :mod:`uqguide.registry`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, model_validator

from ..strict import no_bool_numbers

from ..errors import ModelError
from .roundoff import apply_env

OutputKind = Literal["series", "scalar"]


class ModelParams(BaseModel):
    """Fixed (non-random) parameters of a model, SI units, validated from the config.

    Subclasses declare their fields with defaults; unknown keys are rejected so a typo in a
    config is an error, not a silently ignored setting.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    _no_bool_numbers = model_validator(mode="before")(classmethod(no_bool_numbers))


@dataclass(frozen=True)
class InputInfo:
    """An input a model accepts as uncertain.

    Attributes
    ----------
    name : str
        Name used in the config's ``inputs`` list.
    unit : str
        SI unit of the value (e.g. ``"m"``, ``"rad/s"``).
    description : str
        One line saying what the input is and how it enters the model.
    nominal : float
        Value used when the config does not make this input uncertain.
    """

    name: str
    unit: str
    description: str
    nominal: float = 0.0


@dataclass(frozen=True)
class OutputInfo:
    """An output a model produces.

    Attributes
    ----------
    name : str
        Name used in the config's ``outputs`` list and in results.
    kind : {"series", "scalar"}
        ``"series"``: array ``(n, T, k)`` on the model's time grid; ``"scalar"``: ``(n, k)``.
    unit : str
        SI unit.
    description : str
        One line, with the paper's equation number where there is one.
    components : tuple of str
        Names of the k components (``("",)`` for a single component).
    default : bool
        Whether the output is reported when the config does not list outputs.
    """

    name: str
    kind: OutputKind
    unit: str
    description: str
    components: tuple[str, ...] = ("",)
    default: bool = True

    @property
    def k(self) -> int:
        return len(self.components)


@dataclass(frozen=True)
class StepCount:
    """How much one run of a time-stepping model computes, from its parameters alone (the
    budgets of :mod:`uqguide.budget` are checked with it before anything runs).

    Attributes
    ----------
    steps : float
        Integration steps of one run (sub-steps included).
    grid : float
        Points of the output time grid of one run.
    field : str
        The parameter that sets the step (named in a refusal), e.g. ``"dt"``.
    formula : str
        How ``steps`` follows from the parameters, e.g. ``"t_max / dt"``.
    """

    steps: float
    grid: float
    field: str
    formula: str


@dataclass
class ModelOutput:
    """What a model returns for a batch of ``n`` samples.

    Attributes
    ----------
    time : ndarray, shape (T,)
        Time grid [s] shared by the whole batch (empty for models without time series).
    series : dict of str to ndarray, shape (n, T, k)
        Time-series outputs. A sample that stops early keeps its last value on the rest of
        the grid.
    scalars : dict of str to ndarray, shape (n, k)
        Scalar outputs.
    failed : ndarray of bool, shape (n,)
        True where the sample's evaluation failed; its output values are not to be used.
    reasons : ndarray of object, shape (n,)
        Why each failed sample failed (``""`` where it did not).
    """

    time: np.ndarray
    series: dict[str, np.ndarray] = field(default_factory=dict)
    scalars: dict[str, np.ndarray] = field(default_factory=dict)
    failed: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    reasons: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=object))

    @property
    def n(self) -> int:
        return int(self.failed.shape[0])

    def subset(self, index: np.ndarray) -> ModelOutput:
        """The outputs of the samples selected by ``index`` (boolean mask or integer array)."""
        return ModelOutput(
            time=self.time,
            series={k: v[index] for k, v in self.series.items()},
            scalars={k: v[index] for k, v in self.scalars.items()},
            failed=self.failed[index],
            reasons=self.reasons[index],
        )

    @staticmethod
    def concatenate(parts: Sequence[ModelOutput]) -> ModelOutput:
        """Join the outputs of consecutive chunks of one batch, in order (a single part is
        returned as it is, not copied)."""
        if not parts:
            raise ModelError("cannot concatenate an empty list of model outputs")
        first = parts[0]
        if len(parts) == 1:
            # one part (a chunk evaluated in one model call, the usual case): nothing to join,
            # and np.concatenate would copy every series of the chunk
            return first
        for p in parts[1:]:
            if p.time.shape != first.time.shape or not np.array_equal(p.time, first.time):
                raise ModelError("chunks of one run must share the time grid")
        return ModelOutput(
            time=first.time,
            series={k: np.concatenate([p.series[k] for p in parts]) for k in first.series},
            scalars={k: np.concatenate([p.scalars[k] for p in parts]) for k in first.scalars},
            failed=np.concatenate([p.failed for p in parts]),
            reasons=np.concatenate([p.reasons for p in parts]),
        )


@dataclass(frozen=True)
class DerivedOutput:
    """How a model computes a non-smooth output from smooth ones (its *carriers*).

    A miss distance is the norm of a miss vector: the vector is smooth in the inputs, its norm
    has a cone where the vector passes through zero, on which a polynomial surrogate converges
    badly. A surrogate method may fit the carriers instead and apply ``function`` to draws of
    their surrogates (:mod:`uqguide.pce.derived`); sampling methods just use the model's value.

    Attributes
    ----------
    carriers : tuple of str
        The (smooth) outputs it is computed from; the model must offer them.
    function : callable
        ``function(carriers, inputs) -> y``: ``carriers`` maps each carrier's name to its values
        ``(n, k_c)`` (scalar) or ``(n, T, k_c)`` (series), ``inputs`` maps each uncertain
        input's name to its physical values ``(n,)``; ``y`` is ``(n, k)`` or ``(n, T, k)``.
    kind : {"scalar", "series"}
    """

    carriers: tuple[str, ...]
    function: Callable[[Mapping[str, np.ndarray], Mapping[str, np.ndarray]], np.ndarray]
    kind: str = "scalar"


@dataclass(frozen=True)
class ReportRow:
    """One line of a nominal run's report: the model's figure beside the paper's.

    Attributes
    ----------
    quantity : str
        What is reported, e.g. ``"time to 50 m"`` (prefix a group such as a controller name
        with ``"GMM-NTSMC: "`` where one model reports several cases).
    unit : str
    value : float or str
        The model's figure (a string for yes/no or categorical outcomes).
    paper : float or str or None
        The paper's figure, where it gives one.
    tolerance : str
        The acceptance tolerance from the spec (``"1%"``, ``"15 s"``, ``"not asserted"``...).
    ok : bool or None
        Whether ``value`` is within ``tolerance`` of ``paper`` (None: not checked).
    note : str
        Why a figure is not reproduced, or how it was computed.
    kind : {"reproducible", "chaotic", "timing"}
        *reproducible*: the figure moves by less than its tolerance when the inputs move by
        round-off. *chaotic*: it does not (a final-window maximum of a chattering loop, a
        diverged state), so ``value`` is a robust statistic named in ``statistic``, and ``ok``
        judges that statistic (:mod:`uqguide.models.roundoff`). *timing*: a measurement of the
        machine (wall time), never checked.
    statistic : str
        For a chaotic row, what ``value`` is, e.g. ``"median of 5 runs under 1e-12 input
        perturbations; range [a, b]"``.
    """

    quantity: str
    unit: str
    value: float | str
    paper: float | str | None = None
    tolerance: str = ""
    ok: bool | None = None
    note: str = ""
    kind: Literal["reproducible", "chaotic", "timing"] = "reproducible"
    statistic: str = ""


class Model(ABC):
    """A deterministic model vectorised over a batch of samples.

    Subclasses set the class attributes and implement :meth:`inputs`, :meth:`outputs` and
    :meth:`_evaluate`. ``__init__`` only stores the validated parameters; work happens in
    :meth:`evaluate`.
    """

    name: ClassVar[str]
    summary: ClassVar[str]
    Params: ClassVar[type[ModelParams]] = ModelParams

    def __init__(self, params: ModelParams | Mapping[str, object] | None = None) -> None:
        if params is None:
            params = self.Params()
        elif not isinstance(params, ModelParams):
            params = self.Params(**dict(params))
        self.params = params

    @abstractmethod
    def inputs(self) -> tuple[InputInfo, ...]:
        """The inputs this model accepts as uncertain."""

    @abstractmethod
    def outputs(self) -> tuple[OutputInfo, ...]:
        """The outputs this model can produce."""

    @abstractmethod
    def _evaluate(
        self, values: Mapping[str, np.ndarray], n: int, outputs: frozenset[str]
    ) -> ModelOutput:
        """Evaluate the batch.

        Parameters
        ----------
        values : mapping of str to ndarray, shape (n,)
            Every input of :meth:`inputs` by name, nominal where not uncertain.
        n : int
            Batch size.
        outputs : frozenset of str
            Names of the outputs asked for; others may be left out (saves memory and time).
        """

    def nominal_report(self) -> list[ReportRow]:
        """Run the nominal (deterministic) scenario and report its headline figures beside the
        paper's (``uqguide simulate``). Models without a paper scenario do not override this."""
        raise NotImplementedError(f"model '{self.name}' has no nominal scenario to report")

    def derived_outputs(self) -> Mapping[str, DerivedOutput]:
        """Outputs this model computes from smoother carrier outputs (default: none)."""
        return {}

    def nominal_figures(self, out_dir: str) -> list[str]:
        """Write the nominal scenario's figures (PNG) into ``out_dir``; return their paths."""
        return []

    def sample_figures(self, out: ModelOutput, values: Mapping[str, float], out_dir: str,
                       stem: str) -> list[str]:
        """Figures of one sample's run (``uqguide replay``) beyond the generic time histories:
        its trajectory, with the scene's geometry where the model has one. ``out`` holds every
        output of the sample, ``values`` every input (nominal where not uncertain). Default:
        none."""
        return []

    def full_values(self, x: np.ndarray, input_names: Sequence[str]) -> dict[str, float]:
        """Every input's value for one sample ``x (d,)`` (nominal where not given)."""
        vals = {i.name: float(i.nominal) for i in self.inputs()}
        vals.update({nm: float(v) for nm, v in zip(input_names, x)})
        return vals

    # ------------------------------------------------------------------ public API
    def input_names(self) -> tuple[str, ...]:
        return tuple(i.name for i in self.inputs())

    def step_count(self) -> StepCount | None:
        """Steps and output grid points of one run (None: the model does not time-step)."""
        return None

    def output_info(self, name: str) -> OutputInfo:
        for o in self.outputs():
            if o.name == name:
                return o
        raise ModelError(
            f"model '{self.name}' has no output '{name}'; "
            f"it has: {', '.join(o.name for o in self.outputs())}"
        )

    def nominal_values(self, n: int = 1) -> dict[str, np.ndarray]:
        """Every input at its nominal value, arrays of length ``n`` (moved by round-off when
        ``UQGUIDE_PERTURB`` asks, as :meth:`evaluate` does; see :mod:`.roundoff`)."""
        return apply_env({i.name: np.full(n, i.nominal) for i in self.inputs()})

    def default_outputs(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.outputs() if o.default)

    def evaluate(
        self,
        x: np.ndarray,
        input_names: Sequence[str],
        outputs: Collection[str] | None = None,
    ) -> ModelOutput:
        """Evaluate the model on a batch.

        Parameters
        ----------
        x : array_like, shape (n, d)
            Input samples in SI units; column ``j`` is the input ``input_names[j]``.
        input_names : sequence of str, length d
            Names of the uncertain inputs, each one of :meth:`inputs`.
        outputs : collection of str, optional
            Outputs to compute (default: :meth:`default_outputs`).

        Returns
        -------
        ModelOutput
            Holds at least the requested outputs, with a failure mask; samples that fail are
            flagged, never raised.
        """
        x = np.asarray(x, dtype=float)
        if x.ndim != 2 or x.shape[1] != len(input_names):
            raise ModelError(
                f"model '{self.name}' expects x of shape (n, {len(input_names)}), got {x.shape}"
            )
        known = {i.name: i for i in self.inputs()}
        unknown = [nm for nm in input_names if nm not in known]
        if unknown:
            raise ModelError(
                f"model '{self.name}' has no input {unknown[0]!r}; it accepts: {', '.join(known)}"
            )
        if len(set(input_names)) != len(input_names):
            raise ModelError(f"input names must be unique, got {list(input_names)}")
        wanted = frozenset(self.default_outputs() if outputs is None else outputs)
        for name in wanted:
            self.output_info(name)
        n = x.shape[0]
        values = {nm: np.full(n, info.nominal) for nm, info in known.items()}
        for j, nm in enumerate(input_names):
            values[nm] = x[:, j]
        out = self._evaluate(apply_env(values), n, wanted)
        self._check_output(out, n, wanted)
        return out

    def _check_output(self, out: ModelOutput, n: int, wanted: frozenset[str]) -> None:
        # A model that breaks its own contract is a programming error: say which array is off.
        T = out.time.shape[0]
        for name in wanted:
            info = self.output_info(name)
            store = out.series if info.kind == "series" else out.scalars
            if name not in store:
                raise ModelError(f"model '{self.name}' did not return output '{name}'")
            want = (n, T, info.k) if info.kind == "series" else (n, info.k)
            if store[name].shape != want:
                raise ModelError(
                    f"model '{self.name}' output '{name}' has shape {store[name].shape}, "
                    f"expected {want}"
                )
        if out.failed.shape != (n,) or out.reasons.shape != (n,):
            raise ModelError(f"model '{self.name}' returned a failure mask of the wrong shape")


def failure_reasons(failed: np.ndarray, reason: str) -> np.ndarray:
    """An object array of reasons: ``reason`` where ``failed``, ``""`` elsewhere."""
    out = np.full(failed.shape, "", dtype=object)
    out[failed] = reason
    return out
