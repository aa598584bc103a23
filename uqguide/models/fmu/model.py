"""An FMU as a model: the batch interface (the parameters are in :mod:`.params`).

Everything about the file is checked when the config is loaded (FMPy, a binary for this
machine, every variable named present and of the right kind); what goes wrong in a simulation
fails that sample with its reason (:mod:`.simulate`). The config, what an input may set, how
outputs are sampled, and the trust an FMU's binary needs: docs/your-simulator.md, "The fmu
model's config in detail".
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...errors import ModelError
from ..base import InputInfo, Model, OutputInfo, StepCount
from ...core.types import ModelOutput
from . import archive
from .params import FmuParams
from .simulate import Instance, Setup, pick


class FmuModel(Model):
    """An FMU (FMI 1.0, 2.0 or 3.0; co-simulation, or model exchange with FMPy's solver),
    simulated by FMPy, as a uqguide model."""

    name = "fmu"
    summary = "an FMU (Modelica, Simulink, ... export) simulated with FMPy (uqguide[fmu])"
    # An FMU is native code: a crash or a leak in its binary must cost its samples, not the run.
    may_crash = True
    Params = FmuParams
    params: FmuParams
    # example_params stays empty: no FMU ships with uqguide, so the conformance test builds
    # one (tests/fmu_decay.py) and `uqguide models fmu` lists the parameters only

    @classmethod
    def named_code(cls, section: Mapping[str, Any]) -> str:
        return (f"the compiled model of the FMU {section.get('path')!r} (relative to "
                f"{section.get('config_dir')!r})")

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
