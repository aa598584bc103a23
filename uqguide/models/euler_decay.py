"""Exponential decay integrated by explicit Euler: a benchmark with a fidelity parameter.

``y' = -k y``, ``y(0) = y0``, stepped with ``dt`` over ``[0, t_end]``: ``y_n = y0 (1 - k
dt)^n``. The step sets the fidelity (its error is ``O(dt)``, its cost ``1/dt`` steps), so a
multi-fidelity method can be checked on it in milliseconds; as ``dt -> 0`` it tends to the
closed form ``y0 exp(-k t)``, whose moments are known for independent ``k`` and ``y0``
(:meth:`EulerDecay.exact_mean`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from pydantic import Field, model_validator

from .base import InputInfo, Model, ModelParams, OutputInfo
from .benchmarks import clean_output
from ..core.types import ModelOutput


class EulerDecayParams(ModelParams):
    dt: float = Field(default=0.01, gt=0.0, le=1.0, description="Euler step [s]")
    t_end: float = Field(default=2.0, gt=0.0, le=100.0, description="horizon [s]")
    output_interval: float = Field(default=0.25, gt=0.0, description="series grid step [s]")

    @model_validator(mode="after")
    def _grid(self) -> EulerDecayParams:
        if self.t_end / self.dt > 1e6:
            raise ValueError(f"t_end / dt must be at most 1e6 steps, got {self.t_end / self.dt:g}")
        return self


class EulerDecay(Model):
    """``y' = -k y`` by explicit Euler with step ``dt``; inputs ``k`` [1/s] and ``y0``."""

    name = "euler_decay"
    summary = "y' = -k y by explicit Euler: a benchmark whose step dt sets the fidelity"
    Params = EulerDecayParams
    params: EulerDecayParams
    fidelity_params = ("dt",)

    def inputs(self) -> tuple[InputInfo, ...]:
        return (InputInfo("k", "1/s", "decay rate", 1.0), InputInfo("y0", "1", "y(0)", 1.0))

    def outputs(self) -> tuple[OutputInfo, ...]:
        return (OutputInfo("y_end", "scalar", "1", "y at t_end"),
                OutputInfo("y", "series", "1", "y on the output grid"))

    def exact_mean(self, k_low: float, k_high: float, y0_mean: float, t: float) -> float:
        """``E[y0 exp(-k t)]`` for ``k ~ U(k_low, k_high)`` independent of ``y0`` (the
        ``dt -> 0`` limit)."""
        if t == 0:
            return y0_mean
        return y0_mean * (np.exp(-k_low * t) - np.exp(-k_high * t)) / ((k_high - k_low) * t)

    def _evaluate(self, values: Mapping[str, np.ndarray], n: int,
                  outputs: frozenset[str]) -> ModelOutput:
        p = self.params
        k, y = values["k"], values["y0"].astype(float).copy()
        n_steps = int(round(p.t_end / p.dt))
        grid = np.arange(0.0, p.t_end + 1e-9 * p.t_end, p.output_interval)
        # the output grid is sampled at the nearest step: a coarse level's grid is the fine
        # level's to within dt / 2, which is what a multi-fidelity comparison interpolates
        record = np.minimum(np.rint(grid / p.dt).astype(np.int64), n_steps)
        series = np.empty((n, grid.size, 1))
        j = 0
        for step in range(n_steps + 1):
            while j < grid.size and record[j] == step:
                series[:, j, 0] = y
                j += 1
            if step < n_steps:
                y = y - p.dt * k * y
        return clean_output(n, grid, {"y_end": y[:, None]},
                            {"y": series} if "y" in outputs else {})
