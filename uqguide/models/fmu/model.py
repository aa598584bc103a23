"""An FMU as a model: its parameters and the batch interface.

Config::

    model:
      name: fmu
      path: decay.fmu                  # a relative path is taken from the config's folder
      inputs: {x0: x0, rate: k}        # uqguide input name -> FMU variable (or a list: same names)
      outputs:
        - x                            # a scalar at stop_time, from the FMU variable x
        - {name: path, kind: series, variable: x}          # x on the output_interval grid
        - {name: pos, variable: [body.r[1], body.r[2]]}    # two components
      start_time: 0.0                  # [s]
      stop_time: 10.0                  # [s]
      output_interval: 0.1             # [s]: the series' grid and the communication step
                                       # (without it: the FMU's default step, fitted to the span)
      start_values: {controller.k: 2}  # other FMU variables, the same for every sample
      relative_tolerance: 1.0e-6       # passed to the FMU (and to CVode for model exchange)

An input sets its FMU variable's start value before each simulation; it must be a real-valued
parameter, input or variable with a start value (what FMI lets one set before initialising).
An input the config does not make uncertain keeps the FMU's own start value (or ``nominal``).
Outputs are read from any numeric FMU variable; their unit and description default to the
FMU's. A scalar is the value at ``stop_time``; a series is the value at ``start_time + i
output_interval`` up to ``stop_time``, which must be a whole number of intervals.

Everything about the file is checked when the config is loaded: FMPy installed, the file an
FMU with a binary for this machine, every variable named present and of the right kind. A
failure is then a config error naming the field, the value and the FMU's variables; what goes
wrong in a simulation fails that sample with its reason (see :mod:`.simulate`).

Trust: an FMU's binary runs in uqguide's process with the user's rights, like a ``callable``
model's function; a crash of the binary (a segmentation fault) ends that process. The config's
``timeout_s`` runs each batch in a guard process, which contains both a crash and a hang.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field, ValidationError, ValidationInfo, field_validator, model_validator
from pydantic_core import InitErrorDetails, PydanticCustomError

from ...core.names import PLAIN_NAME_RULE, is_plain_name
from ...errors import ModelError
from ..base import InputInfo, ModelOutput, ModelParams, OutputInfo, StepCount
from ..callable import CallableOutput, DeclaredModel, check_output_names
from ..time_grid import whole_steps
from . import archive
from .simulate import Instance, Setup, pick


class FmuOutput(CallableOutput):
    """An output read from FMU variables: ``variable`` (default: the output's name), or a
    list of them, one per component."""

    variable: str | list[str] | None = None
    unit: str = ""

    @model_validator(mode="before")
    @classmethod
    def _components(cls, data: Any) -> Any:
        if isinstance(data, Mapping) and isinstance(data.get("variable"), list) \
                and "components" not in data:
            data = {**data, "components": len(data["variable"])}
        return data

    @model_validator(mode="after")
    def _one_variable_a_component(self) -> FmuOutput:
        if isinstance(self.variable, list) and len(self.variable) != self.components:
            raise ValueError(f"output {self.name!r}: variable lists {len(self.variable)} FMU "
                             f"variables, components is {self.components}")
        if self.variable is None and self.components > 1:
            raise ValueError(f"output {self.name!r} has {self.components} components: give "
                             f"their FMU variables as variable: [...]")
        return self

    def variables(self) -> list[str]:
        """The FMU variables of the components, in order.

        Returns
        -------
        list of str
        """
        if isinstance(self.variable, list):
            return list(self.variable)
        return [self.variable or self.name]


class FmuParams(ModelParams):
    path: str = Field(min_length=1, description=(
        "the FMU file (.fmu, or a folder holding an unzipped FMU); a relative path is taken "
        "from the config's folder"))
    inputs: dict[str, str] = Field(min_length=1, description=(
        "uqguide input name -> the FMU variable it sets (a list: the same names)"))
    nominal: dict[str, float] = Field(default={}, description=(
        "values of inputs not made uncertain (default: the FMU variable's start value)"))
    outputs: list[str | FmuOutput] = Field(min_length=1, description=(
        "names of FMU variables, or {name, kind: scalar|series, variable, unit, description}"))
    start_time: float = Field(default=0.0, description="time the simulations start at [s]")
    stop_time: float = Field(description="time the simulations end at; scalars are read there "
                                         "[s]")
    output_interval: float | None = Field(default=None, gt=0.0, description=(
        "interval of the series' grid and of the co-simulation steps [s] (required with series "
        "outputs; default: the span in whole steps of at most the FMU's default step size, "
        "else of span / 500)"))
    start_values: dict[str, float | int | bool | str] = Field(default={}, description=(
        "other FMU variables, set to these values before every simulation"))
    relative_tolerance: float | None = Field(default=None, gt=0.0, lt=1.0, description=(
        "relative tolerance given to the FMU (and to CVode for a model-exchange FMU)"))
    config_dir: str | None = Field(default=None, description=(
        "folder a relative path is found in (set by uqguide: the config's folder or the "
        "current folder)"))

    @model_validator(mode="before")
    @classmethod
    def _locate(cls, data: Any, info: ValidationInfo) -> Any:
        if isinstance(data, Mapping) and data.get("config_dir") is None:
            where = (info.context or {}).get("config_dir") or os.getcwd()
            data = {**data, "config_dir": str(Path(where).resolve())}
        return data

    @field_validator("inputs", mode="before")
    @classmethod
    def _mapping(cls, v: Any) -> Any:
        if isinstance(v, list) and all(isinstance(n, str) for n in v):
            if len(set(v)) != len(v):
                raise ValueError(f"inputs must be unique names, got {v}")
            return {n: n for n in v}
        return v

    @field_validator("inputs")
    @classmethod
    def _plain_inputs(cls, v: dict[str, str]) -> dict[str, str]:
        for name, variable in v.items():
            if not is_plain_name(name):
                raise ValueError(f"input name {name!r} must be {PLAIN_NAME_RULE} (map it to "
                                 f"the FMU variable: {{x1: {variable!r}}})")
            if not variable:
                raise ValueError(f"input {name!r} names no FMU variable")
        twice = sorted({x for x in v.values() if list(v.values()).count(x) > 1})
        if twice:
            raise ValueError(f"FMU variable {twice[0]!r} is set by more than one input")
        return v

    @field_validator("outputs", mode="before")
    @classmethod
    def _plain_output_names(cls, v: Any) -> Any:
        return check_output_names(v)

    @model_validator(mode="after")
    def _consistent(self) -> FmuParams:
        if self.stop_time <= self.start_time:
            self._refuse("stop_time", f"must be after start_time = {self.start_time:g} s "
                                      f"(got {self.stop_time:g})")
        extra = sorted(set(self.nominal) - set(self.inputs))
        if extra:
            self._refuse("nominal", f"{extra[0]!r} is not one of the inputs "
                                    f"({', '.join(self.inputs)})")
        if self.output_interval is not None:
            try:
                whole_steps(self.stop_time - self.start_time, self.output_interval,
                            "stop_time - start_time", "output_interval")
            except ValueError as exc:
                self._refuse("output_interval", str(exc))
        elif any(s.kind == "series" for s in self.output_specs()):
            self._refuse("output_interval", "is required with series outputs (it sets their "
                                            "time grid)")
        self._check_fmu()
        return self

    # ------------------------------------------------------------------ the FMU file
    def fmu_file(self) -> Path:
        """The FMU's path, relative paths taken from the config's folder.

        Returns
        -------
        Path
        """
        return Path(self.config_dir or ".", os.path.expanduser(self.path))

    def program_file(self) -> Path | None:
        """The FMU file, for the model's code hash: a rebuilt FMU is another model, so a run
        is not resumed over it.

        Returns
        -------
        Path or None
            None when the path is a folder.
        """
        f = self.fmu_file()
        return f if f.is_file() else None

    def description(self) -> Any:
        """The FMU's parsed model description (cached per file version).

        Returns
        -------
        fmpy ModelDescription
        """
        return archive.description(self.fmu_file())

    def interval(self) -> float:
        """The communication step, and the interval of the series' grid [s].

        Without ``output_interval``, the span ``stop_time - start_time`` cut into whole steps
        of at most the FMU's default step (its ``DefaultExperiment`` ``stepSize``, else span /
        500): a co-simulation FMU that cannot take a shorter last step would otherwise stop
        short of ``stop_time``.

        Returns
        -------
        float
        """
        if self.output_interval is not None:
            return self.output_interval
        span = self.stop_time - self.start_time
        experiment = self.description().defaultExperiment
        try:
            step = float(experiment.stepSize)
        except (AttributeError, TypeError, ValueError):
            step = math.nan
        if not (math.isfinite(step) and step > 0):
            step = span / 500
        return span / max(1, math.ceil(span / step - 1e-9))

    def output_specs(self) -> list[FmuOutput]:
        """The outputs, each as an :class:`FmuOutput`.

        Returns
        -------
        list of FmuOutput
        """
        return [FmuOutput(name=o) if isinstance(o, str) else o for o in self.outputs]

    def _check_fmu(self) -> None:
        try:
            archive.fmpy()
        except archive.FmuUnavailable as exc:
            self._refuse("name", str(exc), {"name": "fmu"})
        f = self.fmu_file()
        if not (f.is_file() or (f / "modelDescription.xml").is_file()):
            self._refuse("path", f"no FMU file {f} (a relative path is taken from the "
                                 f"config's folder)")
        try:
            md = archive.description(f)
            problem = archive.platform_problem(f)
        except (OSError, ValueError) as exc:
            self._refuse("path", f"{f} {exc}")
        if problem:
            self._refuse("path", f"{f} {problem}")
        known = archive.variables(md)
        for name, v in self.inputs.items():
            var = known.get(v)
            can = [k for k, x in known.items()
                   if x.type in archive.REAL_TYPES and archive.settable(x)]
            if var is None or var.type not in archive.REAL_TYPES or not archive.settable(var):
                what = ("is not a variable of" if var is None else
                        f"is a {var.type}, not a real number, in" if var.type not in
                        archive.REAL_TYPES else
                        f"cannot be set before a simulation ({var.causality}, "
                        f"{var.variability}) in")
                self._refuse("inputs", f"FMU variable {v!r} (input {name!r}) {what} {f.name}; "
                                       f"its real variables that can be set: "
                                       f"{archive.listing(can)}", dict(self.inputs))
        for key in self.start_values:
            if key not in known or not archive.settable(known[key]):
                can = [k for k, x in known.items() if archive.settable(x)]
                self._refuse("start_values", f"FMU variable {key!r} "
                             f"{'is not a variable of' if key not in known else 'cannot be set before a simulation in'}"  # noqa: E501
                             f" {f.name}; its variables that can be set: {archive.listing(can)}",
                             dict(self.start_values))
        # an FMI 3.0 array variable has no single value to read as a component
        readable = [k for k, x in known.items()
                    if x.type in archive.NUMERIC_TYPES and not getattr(x, "dimensions", None)]
        for spec in self.output_specs():
            for v in spec.variables():
                if v not in readable:
                    what = ("is not a variable of" if v not in known else
                            "is an array, not one number, in"
                            if known[v].type in archive.NUMERIC_TYPES else
                            f"is a {known[v].type}, not a number, in")
                    self._refuse("outputs", f"FMU variable {v!r} (output {spec.name!r}) "
                                            f"{what} {f.name}; its numeric variables: "
                                            f"{archive.listing(readable)}",
                                 {"outputs": [s.name for s in self.output_specs()]})

    def _refuse(self, field: str, message: str, given: Any = None) -> None:
        # A check across fields, reported at the field it is about (a plain ValueError here
        # would be reported at "model", naming no field). A mapping as the input makes the
        # message stand alone (no "(got ...)" after it): those messages name the value.
        raise ValidationError.from_exception_data(type(self).__name__, [InitErrorDetails(
            type=PydanticCustomError("value_error", "{message}", {"message": message}),
            loc=(field,), input=getattr(self, field, None) if given is None else given)])


class FmuModel(DeclaredModel):
    """An FMU (FMI 1.0, 2.0 or 3.0; co-simulation, or model exchange with FMPy's solver),
    simulated by FMPy, as a uqguide model."""

    name = "fmu"
    summary = "an FMU (Modelica, Simulink, ... export) simulated with FMPy (uqguide[fmu])"
    Params = FmuParams
    params: FmuParams
    # example_params stays empty: no FMU ships with uqguide, so the conformance test builds
    # one (tests/fmu_decay.py) and `uqguide models fmu` lists the parameters only

    def _specs(self) -> list[CallableOutput]:
        return list(self.params.output_specs())

    def _source(self) -> str:
        return Path(self.params.path).name

    def inputs(self) -> tuple[InputInfo, ...]:
        known = archive.variables(self.params.description())
        infos = []
        for name, v in self.params.inputs.items():
            var = known[v]
            start = self.params.nominal.get(name, _start(var))
            infos.append(InputInfo(name, _unit(var), f"FMU {var.causality} {v!r}"
                                   + (f": {var.description}" if var.description else ""),
                                   start))
        return tuple(infos)

    def outputs(self) -> tuple[OutputInfo, ...]:
        known = archive.variables(self.params.description())
        infos = []
        for s in self.params.output_specs():
            first = known[s.variables()[0]]
            where = "at stop_time" if s.kind == "scalar" else "on the output_interval grid"
            infos.append(OutputInfo(
                s.name, s.kind, s.unit or _unit(first) or "1",
                s.description or (f"{first.description or 'FMU variable'} "
                                  f"({', '.join(s.variables())}) {where}"),
                tuple(s.component_names) if s.component_names else
                tuple(s.variables()) if s.components > 1 else ("",)))
        return tuple(infos)

    def step_count(self) -> StepCount:
        p = self.params
        steps = (p.stop_time - p.start_time) / p.interval()
        return StepCount(steps, steps + 1, "output_interval",
                         "(stop_time - start_time) / output_interval")

    def _setup(self, with_series: bool) -> Setup:
        p = self.params
        try:
            folder = archive.unzipped(p.fmu_file())
            md = self.params.description()
            step = p.interval()
        except (archive.FmuUnavailable, OSError, ValueError) as exc:
            # checked when the config was loaded: this process (a worker) differs
            raise ModelError(f"model.path: {p.fmu_file()}: {exc}") from None
        n = round((p.stop_time - p.start_time) / step)
        grid = p.start_time + step * np.arange(n + 1) if with_series else np.zeros(0)
        return Setup(folder, md, p.start_time, p.stop_time, step, grid,
                     p.relative_tolerance, dict(p.start_values))

    def _evaluate(self, values: Mapping[str, np.ndarray], n: int,
                  outputs: frozenset[str]) -> ModelOutput:
        specs = [s for s in self.params.output_specs() if s.name in outputs]
        scalars = {s.name: s.variables() for s in specs if s.kind == "scalar"}
        series = {s.name: s.variables() for s in specs if s.kind == "series"}
        setup = self._setup(bool(series))
        recorded = sorted({v for s in specs for v in s.variables()})
        T = setup.grid.size
        out_scalars = {k: np.full((n, len(v)), np.nan) for k, v in scalars.items()}
        out_series = {k: np.full((n, T, len(v)), np.nan) for k, v in series.items()}
        reasons = np.full(n, "", dtype=object)
        instance = Instance(setup)
        try:
            for i in range(n):
                start = {self.params.inputs[name]: float(values[name][i])
                         for name in self.params.inputs}
                got = instance.run(start, recorded)
                if isinstance(got, str):
                    reasons[i] = got
                    continue
                sc, se, reasons[i] = pick(got, setup, scalars, series)
                for k, a in sc.items():
                    out_scalars[k][i] = a
                for k, a in se.items():
                    out_series[k][i] = a
        except ModelError as exc:
            raise ModelError(f"{self.params.fmu_file()}: {exc}") from None
        finally:
            instance.close()
        failed = reasons != ""
        return ModelOutput(time=setup.grid, series=out_series, scalars=out_scalars,
                           failed=failed, reasons=reasons)


def _start(variable: Any) -> float:
    """A variable's start value as a float (0 when it has none, or none that is a number)."""
    try:
        value = float(variable.start)
    except (TypeError, ValueError):
        return 0.0
    return value if math.isfinite(value) else 0.0


def _unit(variable: Any) -> str:
    declared = getattr(variable, "declaredType", None)
    return variable.unit or (declared.unit if declared is not None else "") or ""
