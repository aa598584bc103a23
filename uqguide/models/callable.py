"""A user's own vectorised Python function as a model (``model: {name: callable, function:
"package.module:function", inputs: [...], outputs: [...]}``).

The function is called as ``f(x)`` with ``x (n, d)`` in the order of ``inputs`` (inputs the
config does not make uncertain at ``nominal``) and returns one array ``(n,)`` / ``(n, m)`` when
every output is a scalar, or a dict of scalars ``(n, k)`` and series ``(n, T, k)`` with
``"time": (T,)``. A sample with a non-finite output value fails; a call that raises is split
until the raising samples fail alone. The module is looked up beside the config, then in the
current folder, then on ``sys.path``; the folder it was found in is kept as ``module_dir``.

The guide, with the shapes a function may return and where its module is found:
docs/your-model.md.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import (BaseModel, ConfigDict, Field, ValidationInfo, field_serializer,
                      field_validator, model_validator)

from ..core.names import PLAIN_NAME_RULE, check_plain_name, is_plain_name
from ..errors import ModelError
from .base import InputInfo, Model, ModelParams, OutputInfo, failure_reasons
from ..core.types import ModelOutput


class CallableOutput(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str = Field(min_length=1)
    kind: Literal["scalar", "series"] = "scalar"

    _plain_name = field_validator("name")(check_plain_name)
    components: int = Field(default=1, ge=1)
    unit: str = "1"
    description: str = ""
    component_names: list[str] | None = None

    @model_validator(mode="after")
    def _names(self) -> CallableOutput:
        if self.component_names is not None and len(self.component_names) != self.components:
            raise ValueError(f"component_names must have {self.components} names, one per "
                             f"component (got {self.component_names})")
        return self


def check_output_names(v: Any) -> Any:
    """``v`` unchanged when its output names (strings or mappings with ``name``) are plain and
    unique; ValueError naming the name and the rule otherwise.

    It checks the ``outputs`` list before the ``str | CallableOutput`` union is validated: the
    union's error for a bad name in the mapping form would be "Input should be a valid string",
    which names neither the name nor the rule.
    """
    if isinstance(v, list):
        names = [o.get("name") if isinstance(o, Mapping) else
                 o.name if isinstance(o, CallableOutput) else o for o in v]
        for name in names:
            if isinstance(name, str) and not is_plain_name(name):
                raise ValueError(f"output name {name!r} must be {PLAIN_NAME_RULE}")
        if len(set(map(str, names))) != len(names):
            raise ValueError("output names must be unique")
    return v


def find_module_dir(spec: str, folders: list[Path]) -> str | None:
    """The first of ``folders`` (resolved) holding the top-level module of ``"pkg.module:function"``
    as ``pkg.py`` or ``pkg/__init__.py``; None when none does."""
    top = spec.partition(":")[0].split(".")[0]
    if not top:
        return None
    for d in folders:
        if (d / f"{top}.py").is_file() or (d / top / "__init__.py").is_file():
            return str(d.resolve())
    return None


def import_function(spec: str, module_dir: str | None = None) -> Callable[[np.ndarray], object]:
    """The callable ``f(x (n, d))`` named ``"package.module:function"`` (the function may be a
    dotted attribute path), imported from ``module_dir`` first when given; ValueError saying what
    went wrong."""
    module, sep, attr = spec.partition(":")
    if not sep or not module or not attr:
        raise ValueError(f"must be 'package.module:function', got {spec!r}")
    try:
        if module_dir and module not in sys.modules:
            sys.path.insert(0, module_dir)
            try:
                obj: object = importlib.import_module(module)
            finally:
                sys.path.remove(module_dir)
        else:
            obj = importlib.import_module(module)
    except Exception as exc:  # noqa: BLE001 - any import failure is the user's to fix
        where = ("; looked in the config's folder and the current folder, then sys.path"
                 if isinstance(exc, ModuleNotFoundError) and not module_dir else "")
        raise ValueError(f"cannot import module {module!r} ({type(exc).__name__}: "
                         f"{exc}){where}") from None
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise ValueError(f"module {module!r} has no attribute {attr!r}")
        obj = getattr(obj, part)
    if not callable(obj):
        raise ValueError(f"{spec!r} is not callable")
    return obj


class DeclaredParams(ModelParams):
    """The rules of every model whose config declares its ``inputs`` (names, in column order),
    their ``nominal`` values (one per input, or None) and its ``outputs``."""

    @field_validator("outputs", mode="before", check_fields=False)
    @classmethod
    def _plain_output_names(cls, v: Any) -> Any:
        return check_output_names(v)

    @model_validator(mode="after")
    def _one_nominal_per_input(self) -> DeclaredParams:
        inputs, nominal = self.inputs, self.nominal  # type: ignore[attr-defined]
        if len(set(inputs)) != len(inputs):
            raise ValueError(f"inputs must be unique names, got {inputs}")
        if nominal is not None and len(nominal) != len(inputs):
            raise ValueError(f"nominal must have {len(inputs)} values, one per input")
        return self


class CallableParams(DeclaredParams):
    module_dir: str | None = Field(
        default=None, description="folder the module was found in (set by uqguide: the "
                                  "config's folder or the current folder)")
    function: str | Callable[..., Any] = Field(
        default="uqguide.models.callable:_example",
        description="'module:function' taking x (n, d) (a function object from Python)")
    inputs: list[str] = Field(default=["x1", "x2"], min_length=1,
                              description="names of the columns of x, in order")
    nominal: list[float] | None = Field(default=None,
                                        description="values of inputs not made uncertain")
    outputs: list[str | CallableOutput] = Field(default=["y"], min_length=1)

    @model_validator(mode="before")
    @classmethod
    def _locate(cls, data: Any, info: ValidationInfo) -> Any:
        if isinstance(data, Mapping) and isinstance(data.get("function"), str) \
                and data.get("module_dir") is None:
            folders = [Path(p) for p in ((info.context or {}).get("config_dir"),) if p]
            found = find_module_dir(data["function"], [*folders, Path.cwd()])
            if found:
                data = {**data, "module_dir": found}
        return data

    @field_serializer("function")
    def _spec(self, v: str | Callable[..., Any]) -> str:
        return v if isinstance(v, str) else f"{v.__module__}:{v.__qualname__}"

    def spec(self) -> str:
        """``"module:function"``, also for a function object."""
        return self._spec(self.function)

    def resolve(self) -> Callable[..., Any]:
        """The function itself (imported when given by name)."""
        if callable(self.function):
            return self.function
        return import_function(self.function, self.module_dir)

    @field_validator("function")
    @classmethod
    def _importable(cls, v: str | Callable[..., Any], info: ValidationInfo
                    ) -> str | Callable[..., Any]:
        if isinstance(v, str):
            import_function(v, info.data.get("module_dir"))
        return v


def non_finite(arrays: Iterable[np.ndarray], n: int) -> np.ndarray:
    """The samples ``(n,)`` with a NaN or an infinity in any of ``arrays`` (each ``(n, ...)``)."""
    bad = np.zeros(n, dtype=bool)
    for a in arrays:
        bad |= ~np.isfinite(a).all(axis=tuple(range(1, a.ndim)))
    return bad


def _example(x: np.ndarray) -> np.ndarray:
    """The default function: ``y = x1 + x2^2`` (shows the expected signature)."""
    return x[:, 0] + x[:, 1] ** 2


class DeclaredModel(Model):
    """A model whose inputs and outputs its config declares, not its code: a user's Python
    function (``callable``) or program (``command``). ``params`` has ``inputs`` (names, in
    column order), ``nominal`` (their values when not uncertain) and ``outputs`` (names, or
    :class:`CallableOutput` mappings)."""

    #: How input ``j`` reaches the user's code, for ``uqguide models``.
    input_column = "column {j} of x"

    def _source(self) -> str:
        """What computes the outputs, for their default descriptions."""
        return self.name

    def _specs(self) -> list[CallableOutput]:
        return [CallableOutput(name=o) if isinstance(o, str) else o
                for o in self.params.outputs]  # type: ignore[attr-defined]

    def inputs(self) -> tuple[InputInfo, ...]:
        names = self.params.inputs  # type: ignore[attr-defined]
        nominal = self.params.nominal or [0.0] * len(names)  # type: ignore[attr-defined]
        return tuple(InputInfo(n, "", self.input_column.format(j=j), v)
                     for j, (n, v) in enumerate(zip(names, nominal)))

    def outputs(self) -> tuple[OutputInfo, ...]:
        source = self._source()
        return tuple(
            OutputInfo(s.name, s.kind, s.unit, s.description or f"{s.kind} output of {source}",
                       tuple(s.component_names) if s.component_names else
                       tuple(f"{s.name}{j}" for j in range(s.components))
                       if s.components > 1 else ("",))
            for s in self._specs())


class CallableModel(DeclaredModel):
    """Any vectorised Python function ``f(x (n, d))`` as a uqguide model."""

    name = "callable"
    summary = "a user's vectorised Python function 'package.module:function' of x (n, d)"
    Params = CallableParams
    may_crash = True  # a user's function may segfault (C extensions), leak or os._exit
    declares_inputs = True
    params: CallableParams
    #: Fidelity levels of a user's model are other functions of the same inputs and outputs
    #: (``fidelities: [{function: "sim:fine"}, {function: "sim:coarse"}]``).
    fidelity_params = ("function",)
    example_params = {"function": "uqguide.models.callable:example_function",
                      "inputs": ["a", "b"], "nominal": [1.0, 0.5],
                      "outputs": ["y", {"name": "path", "kind": "series"}]}

    @classmethod
    def named_code(cls, section: Mapping[str, Any]) -> str:
        where = section.get("module_dir")
        return f"the Python function {section.get('function')!r} " + (
            f"from the folder {where!r}" if where else "from the Python path")

    def _source(self) -> str:
        return self.params.spec()

    def _evaluate(self, values: Mapping[str, np.ndarray], n: int,
                  outputs: frozenset[str]) -> ModelOutput:
        fn = self.params.resolve()
        x = np.column_stack([values[name] for name in self.params.inputs])
        raw = fn(x)
        specs = self._specs()
        if isinstance(raw, Mapping):
            data = dict(raw)
        else:
            arr = np.asarray(raw, dtype=float)
            if any(s.kind == "series" for s in specs):
                raise ModelError("a function with series outputs must return a dict")
            arr = arr.reshape(n, -1)
            widths = [s.components for s in specs]
            if arr.shape[1] != sum(widths):
                raise ModelError(f"{self.params.spec()} returned {arr.shape[1]} columns, "
                                 f"the config's outputs need {sum(widths)}")
            splits = np.split(arr, np.cumsum(widths)[:-1], axis=1)
            data = {s.name: a for s, a in zip(specs, splits)}
        time_grid = np.asarray(data.get("time", np.zeros(0)), dtype=float)
        got = {}
        for s in specs:
            if s.name not in data:
                raise ModelError(self._missing(s.name, data, n, time_grid.shape[0]))
            shape = (n, time_grid.shape[0], s.components) if s.kind == "series" else \
                (n, s.components)
            got[s.name] = np.asarray(data[s.name], dtype=float).reshape(shape)
        bad = non_finite(got.values(), n)
        return ModelOutput(time=time_grid, failed=bad,
                           series={s.name: got[s.name] for s in specs if s.kind == "series"},
                           scalars={s.name: got[s.name] for s in specs if s.kind == "scalar"},
                           reasons=failure_reasons(bad, "non-finite output value"))

    def _missing(self, name: str, data: Mapping[str, object], n: int, steps: int) -> str:
        """What a function that returns other outputs than its config lists is told: what it
        returned, and the ``outputs`` entry that would declare each (a series where its shape
        is ``(n, T, ...)`` on the returned time grid)."""
        returned = sorted(k for k in data if k != "time")

        def entry(k: str) -> str:
            try:
                shape = np.shape(np.asarray(data[k]))
            except (TypeError, ValueError):  # a ragged value: no shape to read a kind from
                shape = ()
            series = steps > 0 and len(shape) >= 2 and shape[0] == n and shape[1] == steps
            return f"{{name: {k}, kind: series}}" if series else k

        hint = f"outputs: [{', '.join(entry(k) for k in returned)}]" if returned else ""
        return (f"{self.params.spec()} did not return output {name!r}: it returned "
                f"{', '.join(map(repr, returned)) or 'no output'}. The model's 'outputs' lists "
                f"what the function returns (default [y])" + (f"; for these: {hint}" if hint
                                                             else ""))


def example_function(x: np.ndarray) -> dict[str, np.ndarray]:
    """A callable model's example (its conformance check) of ``x`` (n, 2) with columns ``a``,
    ``b``: ``y = sin a + b^2`` (n,) and the series ``path = t y`` (n, 5) on the 5 points ``time``
    of [0, 1]."""
    y = np.sin(x[:, 0]) + x[:, 1] ** 2
    t = np.linspace(0.0, 1.0, 5)
    return {"y": y, "path": y[:, None] * t[None, :], "time": t}
