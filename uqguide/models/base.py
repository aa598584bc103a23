"""The model contract: a batch of input samples ``x (n, d)`` (SI, one column per uncertain
input; the others at their nominal values) to a :class:`ModelOutput` (a time grid shared by the
batch, series ``(n, T, k)``, scalars ``(n, k)``, a failure mask with a reason per failed
sample), all at once.

Methods see models only through :meth:`Model.evaluate`, so any model can be propagated by any
method. A new simulator is a subclass with ``name``, ``summary``, a ``Params`` class,
``example_params``, ``inputs()``, ``outputs()`` and ``_evaluate``, plus one line in
:mod:`uqguide.config.registry`; :func:`uqguide.testing.check_model` then checks it.

The contract in full: docs/architecture.md#the-model-contract.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import ConfigDict

from ..core.strict import StrictModel

from ..errors import ModelError
from ..core.types import DerivedOutput, ModelOutput
from .roundoff import apply_env

__all__ = ["DerivedOutput", "InputInfo", "Model", "ModelOutput", "ModelParams", "OutputInfo",
           "StepCount", "failure_reasons"]

OutputKind = Literal["series", "scalar"]


class ModelParams(StrictModel):
    """Fixed (non-random) parameters of a model, SI units, validated from the config.

    Subclasses declare their fields with defaults; unknown keys are rejected so a typo in a
    config is an error, not a silently ignored setting.
    """

    # NaN or infinity in a parameter is a config error, never a run that fails on every sample
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


@dataclass(frozen=True)
class InputInfo:
    """An input a model accepts as uncertain: its config ``name``, SI ``unit`` (``"m"``,
    ``"rad/s"``), a one-line ``description`` and the ``nominal`` value used when the config
    does not make it uncertain."""

    name: str
    unit: str
    description: str
    nominal: float = 0.0


@dataclass(frozen=True)
class OutputInfo:
    """An output a model produces: its config and result ``name``, ``kind`` (``"series"``:
    ``(n, T, k)`` on the model's time grid; ``"scalar"``: ``(n, k)``), SI ``unit``, a one-line
    ``description``, the names of its k ``components`` (``("",)`` for one) and whether it is
    reported by ``default`` when the config lists no outputs."""

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
    """How much one run of a time-stepping model computes, from its parameters alone (checked
    against the budgets of :mod:`uqguide.config.budget` before anything runs): integration
    ``steps`` (sub-steps included), output ``grid`` points, the ``field`` that sets the step
    (``"dt"``) and the ``formula`` of ``steps`` (``"t_max / dt"``)."""

    steps: float
    grid: float
    field: str
    formula: str


class Model(ABC):
    """A deterministic model vectorised over a batch of samples.

    Subclasses set the class attributes and implement :meth:`inputs`, :meth:`outputs` and
    :meth:`_evaluate`. ``__init__`` only stores the validated parameters; work happens in
    :meth:`evaluate`.
    """

    name: ClassVar[str]
    summary: ClassVar[str]
    Params: ClassVar[type[ModelParams]] = ModelParams
    #: Whether an evaluation can take its process down (a user's Python code, which may call
    #: into C): a run without workers then makes the model's calls in a child process (the
    #: config's ``model.isolate`` overrides it). The built-in simulators are vectorised NumPy
    #: and numba code over validated inputs, and keep the fast path in the driver.
    may_crash: ClassVar[bool] = False
    #: A small, cheap configuration (a short horizon) that still runs every part of the model:
    #: what the conformance suite (:func:`uqguide.testing.check_model`) builds it with.
    example_params: ClassVar[Mapping[str, Any]] = {}
    #: The parameters that set the model's fidelity (an integration step: ``dt``, ``step``):
    #: the only ones a multi-fidelity method's ``fidelities`` may change
    #: (:meth:`at_fidelity`). Empty: the model has a single fidelity.
    fidelity_params: ClassVar[tuple[str, ...]] = ()
    #: Whether the config names the model's inputs (``model.inputs``, a user's function or
    #: program) rather than the model's code: an unknown input is then told where to declare it.
    declares_inputs: ClassVar[bool] = False

    @classmethod
    def named_code(cls, section: Mapping[str, Any]) -> str:
        """The code the model ``section`` (as stored, perhaps from elsewhere: only read, never
        validated or imported) names beyond uqguide's own (a Python function, a program, an
        FMU's binary), in one line; ``""`` for uqguide's code only. A result file naming such
        code is code too (``uqguide replay --run-code``)."""
        return ""

    def __init__(self, params: ModelParams | Mapping[str, object] | None = None) -> None:
        if params is None:
            params = self.Params()
        elif not isinstance(params, ModelParams):
            params = self.Params(**dict(params))
        self.params = params

    def at_fidelity(self, changes: Mapping[str, object]) -> Model:
        """The same model with some of :attr:`fidelity_params` changed to ``changes``
        (validated like the config's; empty: this model). ValueError for a parameter that does
        not set the fidelity, or a value its field refuses."""
        if not changes:
            return self
        other = [k for k in changes if k not in self.fidelity_params]
        if other:
            allowed = ", ".join(self.fidelity_params) or "none (a single fidelity)"
            raise ValueError(f"'{other[0]}' does not set the fidelity of model '{self.name}'; "
                             f"its fidelity parameters: {allowed}")
        # Through the Params class, so a step the model refuses is refused here too; the
        # field values themselves (not their JSON) so that a callable's function survives.
        fields = {k: getattr(self.params, k) for k in type(self.params).model_fields}
        return type(self)(self.Params(**{**fields, **changes}))

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
        """Evaluate a batch of ``n``: ``values`` holds every input of :meth:`inputs` by name,
        ``(n,)`` each (nominal where not uncertain); the ``outputs`` asked for must be returned
        (others may be left out). Returns the grid ``(T,)`` [s], series ``(n, T, k)``, scalars
        ``(n, k)``, failure mask and reasons ``(n,)``: a sample that fails is flagged with its
        reason, never raised."""

    def derived_outputs(self) -> Mapping[str, DerivedOutput]:
        """Outputs this model computes from smoother carrier outputs, by name (default: none)."""
        return {}

    def full_values(self, x: np.ndarray, input_names: Sequence[str]) -> dict[str, float]:
        """Every input's value for one sample ``x (d,)`` [SI] of ``input_names`` (nominal where
        not given)."""
        vals = {i.name: float(i.nominal) for i in self.inputs()}
        vals.update({nm: float(v) for nm, v in zip(input_names, x)})
        return vals

    # ------------------------------------------------------------------ public API
    def input_names(self) -> tuple[str, ...]:
        """Names of :meth:`inputs`, in order."""
        return tuple(i.name for i in self.inputs())

    def kernel_choice(self) -> Literal["numba"] | None:
        """``"numba"`` when the evaluations run a compiled kernel (a model with a ``kernel``
        parameter), else None (nothing for the driver to load before its timed runs)."""
        return None if getattr(self.params, "kernel", None) is None else "numba"

    def step_count(self) -> StepCount | None:
        """Steps and output grid points of one run, from the parameters alone (None: the model
        does not time-step)."""
        return None

    def output_info(self, name: str) -> OutputInfo:
        """The metadata of output ``name``; ModelError, listing the outputs, when there is
        none."""
        for o in self.outputs():
            if o.name == name:
                return o
        raise ModelError(
            f"model '{self.name}' has no output '{name}'; "
            f"it has: {', '.join(o.name for o in self.outputs())}"
        )

    def nominal_values(self, n: int = 1) -> dict[str, np.ndarray]:
        """Every input at its nominal value [SI], arrays of length ``n`` (moved by round-off
        when ``UQGUIDE_PERTURB`` asks, as :meth:`evaluate` does; see :mod:`.roundoff`)."""
        return apply_env({i.name: np.full(n, i.nominal) for i in self.inputs()})

    def default_outputs(self) -> tuple[str, ...]:
        """The outputs reported when the config lists none."""
        return tuple(o.name for o in self.outputs() if o.default)

    def evaluate(
        self,
        x: np.ndarray,
        input_names: Sequence[str],
        outputs: Collection[str] | None = None,
    ) -> ModelOutput:
        """Evaluate the model on a batch ``x (n, d)`` [SI] whose column ``j`` is the input
        ``input_names[j]`` (each one of :meth:`inputs`), computing ``outputs`` (default:
        :meth:`default_outputs`). The result holds at least those, with a failure mask: samples
        that fail are flagged, never raised."""
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
        # a model that loops over the set of wanted outputs fills its dicts in the order of
        # Python's string hashes, which change per process: put them in the declared order, so
        # that what follows (bootstrap seeds handed out by position) never depends on it
        order = {o.name: i for i, o in enumerate(self.outputs())}
        out.series = dict(sorted(out.series.items(), key=lambda kv: order.get(kv[0], -1)))
        out.scalars = dict(sorted(out.scalars.items(), key=lambda kv: order.get(kv[0], -1)))
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
    """An object array ``(n,)`` of reasons: ``reason`` where ``failed (n,)``, ``""`` elsewhere."""
    out = np.full(failed.shape, "", dtype=object)
    out[failed] = reason
    return out
