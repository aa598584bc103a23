"""A user's own vectorised Python function as a model.

Config::

    model:
      name: callable
      function: "mypackage.mymodule:my_function"
      inputs: [a, b, c]                # column names of x, in order
      outputs: [y]                     # scalar outputs; or {name: y, kind: series, components: 3}

The function is called as ``f(x)`` with ``x`` of shape ``(n, d)`` (the inputs in the order of
``inputs``; inputs the uqguide config does not make uncertain are passed at ``nominal``) and
returns either

- an array ``(n,)`` or ``(n, m)`` when every output is a scalar (the columns are the outputs'
  components, in order), or
- a dict ``{name: array}`` with scalars ``(n,)``/``(n, k)`` and series ``(n, T)``/``(n, T, k)``,
  plus ``"time": (T,)`` when there are series.

A sample with a non-finite output value is flagged as failed, not raised.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from ..errors import ModelError
from .base import InputInfo, Model, ModelOutput, ModelParams, OutputInfo


class CallableOutput(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str = Field(min_length=1)
    kind: Literal["scalar", "series"] = "scalar"
    components: int = Field(default=1, ge=1)
    unit: str = "1"


def import_function(spec: str) -> Callable[[np.ndarray], object]:
    """The callable named ``"package.module:function"``; ValueError saying what went wrong."""
    module, sep, attr = spec.partition(":")
    if not sep or not module or not attr:
        raise ValueError(f"must be 'package.module:function', got {spec!r}")
    try:
        obj: object = importlib.import_module(module)
    except Exception as exc:  # noqa: BLE001 - any import failure is the user's to fix
        raise ValueError(f"cannot import module {module!r} ({type(exc).__name__}: {exc})") from None
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise ValueError(f"module {module!r} has no attribute {attr!r}")
        obj = getattr(obj, part)
    if not callable(obj):
        raise ValueError(f"{spec!r} is not callable")
    return obj  # type: ignore[return-value]


class CallableParams(ModelParams):
    function: str = Field(default="uqguide.models.callable:_example",
                          description="'package.module:function' taking x (n, d)")
    inputs: list[str] = Field(default=["x1", "x2"], min_length=1,
                              description="names of the columns of x, in order")
    nominal: list[float] | None = Field(default=None,
                                        description="values of inputs not made uncertain")
    outputs: list[str | CallableOutput] = Field(default=["y"], min_length=1)

    @field_validator("function")
    @classmethod
    def _importable(cls, v: str) -> str:
        import_function(v)
        return v

    @model_validator(mode="after")
    def _consistent(self) -> CallableParams:
        if len(set(self.inputs)) != len(self.inputs):
            raise ValueError(f"inputs must be unique names, got {self.inputs}")
        if self.nominal is not None and len(self.nominal) != len(self.inputs):
            raise ValueError(f"nominal must have {len(self.inputs)} values, one per input")
        return self


def _example(x: np.ndarray) -> np.ndarray:
    """The default function: ``y = x1 + x2^2`` (shows the expected signature)."""
    return x[:, 0] + x[:, 1] ** 2


class CallableModel(Model):
    """Any vectorised Python function ``f(x (n, d))`` as a uqguide model."""

    name = "callable"
    summary = "a user's vectorised Python function 'package.module:function' of x (n, d)"
    Params = CallableParams

    def _specs(self) -> list[CallableOutput]:
        return [CallableOutput(name=o) if isinstance(o, str) else o for o in self.params.outputs]

    def inputs(self) -> tuple[InputInfo, ...]:
        nominal = self.params.nominal or [0.0] * len(self.params.inputs)
        return tuple(InputInfo(n, "", f"column {j} of x", v)
                     for j, (n, v) in enumerate(zip(self.params.inputs, nominal)))

    def outputs(self) -> tuple[OutputInfo, ...]:
        return tuple(
            OutputInfo(s.name, s.kind, s.unit, f"{s.kind} output of {self.params.function}",
                       tuple(f"{s.name}{j}" for j in range(s.components))
                       if s.components > 1 else ("",))
            for s in self._specs())

    def _evaluate(self, values: Mapping[str, np.ndarray], n: int, outputs: frozenset[str]):
        fn = import_function(self.params.function)
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
                raise ModelError(f"{self.params.function} returned {arr.shape[1]} columns, "
                                 f"the config's outputs need {sum(widths)}")
            splits = np.split(arr, np.cumsum(widths)[:-1], axis=1)
            data = {s.name: a for s, a in zip(specs, splits)}
        time_grid = np.asarray(data.get("time", np.zeros(0)), dtype=float)
        series, scalars = {}, {}
        bad = np.zeros(n, dtype=bool)
        for s in specs:
            if s.name not in data:
                raise ModelError(f"{self.params.function} did not return output {s.name!r}")
            a = np.asarray(data[s.name], dtype=float)
            if s.kind == "series":
                a = a.reshape(n, time_grid.shape[0], s.components)
                series[s.name] = a
                bad |= ~np.isfinite(a).all(axis=(1, 2))
            else:
                a = a.reshape(n, s.components)
                scalars[s.name] = a
                bad |= ~np.isfinite(a).all(axis=1)
        reasons = np.where(bad, "non-finite output value", "").astype(object)
        return ModelOutput(time=time_grid, series=series, scalars=scalars, failed=bad,
                           reasons=reasons)
