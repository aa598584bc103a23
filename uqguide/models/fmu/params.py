"""The ``fmu`` model's parameters, checked against the FMU when the config is loaded.

FMPy installed, the file an FMU whose members unzip within bounds (:func:`.archive.unzipped`)
with a binary for this machine, every variable named present and of the right kind: a failure
is a config error (exit 2) naming the field, the value and the FMU's variables, raised at the
field it is about.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import Field, field_validator, model_validator

from ...core.names import PLAIN_NAME_RULE, is_plain_name
from ..config_dir import ConfigDirParams
from ..callable import CallableOutput, check_output_names
from ..time_grid import whole_steps
from . import archive


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
        """The FMU variables of the components, in order."""
        if isinstance(self.variable, list):
            return list(self.variable)
        return [self.variable or self.name]


class FmuParams(ConfigDirParams):
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

    _plain_output_names = field_validator("outputs", mode="before")(check_output_names)

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
        """The FMU's path, relative paths taken from the config's folder."""
        return Path(self.config_dir or ".", os.path.expanduser(self.path))

    def program_file(self) -> Path | None:
        """The FMU file, for the model's code hash: a rebuilt FMU is another model, so a run
        is not resumed over it (None when the path is a folder)."""
        f = self.fmu_file()
        return f if f.is_file() else None

    def description(self) -> Any:
        """The FMU's parsed model description (cached per file version)."""
        return archive.description(self.fmu_file())

    def interval(self) -> float:
        """The communication step, and the interval of the series' grid [s].

        Without ``output_interval``, the span ``stop_time - start_time`` cut into whole steps
        of at most the FMU's default step (its ``DefaultExperiment`` ``stepSize``, else span /
        500): a co-simulation FMU that cannot take a shorter last step would otherwise stop
        short of ``stop_time``.
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
        """The outputs, each as an :class:`FmuOutput`."""
        return [FmuOutput(name=o) if isinstance(o, str) else o for o in self.outputs]

    def _check_fmu(self) -> None:
        """FMPy installed, the file an FMU this machine can run, every variable named in it."""
        try:
            archive.fmpy()
        except archive.FmuUnavailable as exc:
            self._refuse("name", str(exc), {"name": "fmu"})
        f = self.fmu_file()
        if not (f.is_file() or (f / "modelDescription.xml").is_file()):
            self._refuse("path", f"no FMU file {f} (a relative path is taken from the "
                                 f"config's folder)")
        try:
            # unzipped first: its members are checked before FMPy reads any of them, and a
            # damaged one is found now rather than by the run's first batch
            archive.unzipped(f)
            md = archive.description(f)
            problem = archive.platform_problem(f)
        except (OSError, ValueError) as exc:
            self._refuse("path", f"{f} {exc}")
        if problem:
            self._refuse("path", f"{f} {problem}")
        known = archive.variables(md)
        self._check_inputs(known, f.name)
        self._check_start_values(known, f.name)
        self._check_outputs(known, f.name)

    def _check_inputs(self, known: Mapping[str, Any], fmu: str) -> None:
        can = [k for k, x in known.items() if x.type in archive.REAL_TYPES and archive.settable(x)]
        for name, v in self.inputs.items():
            var = known.get(v)
            if var is None:
                what = "is not a variable of"
            elif var.type not in archive.REAL_TYPES:
                what = f"is a {var.type}, not a real number, in"
            elif not archive.settable(var):
                what = (f"cannot be set before a simulation ({var.causality}, "
                        f"{var.variability}) in")
            else:
                continue
            self._refuse("inputs", f"FMU variable {v!r} (input {name!r}) {what} {fmu}; its real "
                                   f"variables that can be set: {archive.listing(can)}",
                         dict(self.inputs))

    def _check_start_values(self, known: Mapping[str, Any], fmu: str) -> None:
        can = [k for k, x in known.items() if archive.settable(x)]
        for key in self.start_values:
            if key not in can:
                what = ("is not a variable of" if key not in known else
                        "cannot be set before a simulation in")
                self._refuse("start_values", f"FMU variable {key!r} {what} {fmu}; its "
                                             f"variables that can be set: {archive.listing(can)}",
                             dict(self.start_values))

    def _check_outputs(self, known: Mapping[str, Any], fmu: str) -> None:
        # an FMI 3.0 array variable has no single value to read as a component
        readable = [k for k, x in known.items()
                    if x.type in archive.NUMERIC_TYPES and not getattr(x, "dimensions", None)]
        for spec in self.output_specs():
            for v in spec.variables():
                if v in readable:
                    continue
                what = ("is not a variable of" if v not in known else
                        "is an array, not one number, in"
                        if known[v].type in archive.NUMERIC_TYPES else
                        f"is a {known[v].type}, not a number, in")
                self._refuse("outputs", f"FMU variable {v!r} (output {spec.name!r}) {what} "
                                        f"{fmu}; its numeric variables: "
                                        f"{archive.listing(readable)}",
                             {"outputs": [s.name for s in self.output_specs()]})
