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
    budgets of :mod:`uqguide.config.budget` are checked with it before anything runs).

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
        """The code a config's model section names for this model to run, beyond uqguide's own
        (a Python function, a program, an FMU's binary), in words: a result file naming it is
        code too (``uqguide replay --run-code``).

        Parameters
        ----------
        section : mapping
            The model section as stored (perhaps in a file from elsewhere): only read, never
            validated or imported.

        Returns
        -------
        str
            One line (values shown with ``repr``); ``""`` when the model runs uqguide's code
            only (the built-in simulators).
        """
        return ""

    def __init__(self, params: ModelParams | Mapping[str, object] | None = None) -> None:
        if params is None:
            params = self.Params()
        elif not isinstance(params, ModelParams):
            params = self.Params(**dict(params))
        self.params = params

    def at_fidelity(self, changes: Mapping[str, object]) -> Model:
        """The same model with its fidelity parameters changed (validated like the config's).

        Parameters
        ----------
        changes : mapping of str to value
            Values of some of :attr:`fidelity_params`; empty: this model.

        Returns
        -------
        Model

        Raises
        ------
        ValueError
            Naming a parameter that does not set the fidelity, or a value its field refuses.
        """
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
        """The inputs this model accepts as uncertain.

        Returns
        -------
        tuple of InputInfo
            Name, SI unit, meaning and nominal value of each.
        """

    @abstractmethod
    def outputs(self) -> tuple[OutputInfo, ...]:
        """The outputs this model can produce.

        Returns
        -------
        tuple of OutputInfo
            Name, kind (series or scalar), SI unit, meaning and components of each.
        """

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

        Returns
        -------
        ModelOutput
            Grid ``(T,)`` [s], series ``(n, T, k)``, scalars ``(n, k)``, failure mask and
            reasons ``(n,)``; a sample that fails is flagged with its reason, never raised.
        """

    def derived_outputs(self) -> Mapping[str, DerivedOutput]:
        """Outputs this model computes from smoother carrier outputs (default: none).

        Returns
        -------
        mapping of str to DerivedOutput
            By output name.
        """
        return {}

    def full_values(self, x: np.ndarray, input_names: Sequence[str]) -> dict[str, float]:
        """Every input's value for one sample (nominal where not given).

        Parameters
        ----------
        x : ndarray, shape (d,)
            The sample, SI units.
        input_names : sequence of str, length d

        Returns
        -------
        dict of str to float
            Every input of :meth:`inputs`.
        """
        vals = {i.name: float(i.nominal) for i in self.inputs()}
        vals.update({nm: float(v) for nm, v in zip(input_names, x)})
        return vals

    # ------------------------------------------------------------------ public API
    def input_names(self) -> tuple[str, ...]:
        """Names of :meth:`inputs`, in order.

        Returns
        -------
        tuple of str
        """
        return tuple(i.name for i in self.inputs())

    def kernel_choice(self) -> Literal["numba"] | None:
        """Whether the evaluations run a compiled kernel (a model with a ``kernel`` parameter).

        Returns
        -------
        "numba" or None
            None: nothing compiled for the driver to load before its timed runs.
        """
        return None if getattr(self.params, "kernel", None) is None else "numba"

    def step_count(self) -> StepCount | None:
        """Steps and output grid points of one run, from the parameters alone.

        Returns
        -------
        StepCount or None
            None: the model does not time-step.
        """
        return None

    def output_info(self, name: str) -> OutputInfo:
        """The metadata of one output.

        Parameters
        ----------
        name : str

        Returns
        -------
        OutputInfo
            ModelError, listing the outputs, when there is none of that name.
        """
        for o in self.outputs():
            if o.name == name:
                return o
        raise ModelError(
            f"model '{self.name}' has no output '{name}'; "
            f"it has: {', '.join(o.name for o in self.outputs())}"
        )

    def nominal_values(self, n: int = 1) -> dict[str, np.ndarray]:
        """Every input at its nominal value, arrays of length ``n`` (moved by round-off when
        ``UQGUIDE_PERTURB`` asks, as :meth:`evaluate` does; see :mod:`.roundoff`).

        Parameters
        ----------
        n : int
            Length of each array.

        Returns
        -------
        dict of str to ndarray, shape (n,)
            Every input, SI units.
        """
        return apply_env({i.name: np.full(n, i.nominal) for i in self.inputs()})

    def default_outputs(self) -> tuple[str, ...]:
        """The outputs reported when the config lists none.

        Returns
        -------
        tuple of str
        """
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
    """An object array of reasons: ``reason`` where ``failed``, ``""`` elsewhere.

    Parameters
    ----------
    failed : ndarray of bool, shape (n,)
    reason : str

    Returns
    -------
    ndarray of object, shape (n,)
    """
    out = np.full(failed.shape, "", dtype=object)
    out[failed] = reason
    return out
