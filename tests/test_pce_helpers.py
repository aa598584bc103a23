"""Shared helpers of the PCE tests: run a method end to end without the driver, build spaces.

``run_method`` is the driver's loop (design -> evaluate -> refine -> estimate) in a few lines,
so the PCE methods are tested against closed forms on their own.
"""

from __future__ import annotations

import numpy as np

from uqguide.core.inputs import InputSpace, Normal, Uniform
from uqguide.methods.base import Method
from uqguide.core.types import Estimate, ModelOutput
from uqguide.models.base import Model


def run_method(method: Method, model: Model, space: InputSpace, seed: int = 1,
               outputs: tuple[str, ...] | None = None, max_rounds: int = 50
               ) -> tuple[Estimate, ModelOutput]:
    """Design, evaluate, refine until done, estimate; returns the estimate and all outputs."""
    design = method.design(space, seed)
    out = model.evaluate(design.x, space.names, outputs)
    for _ in range(max_rounds):
        bigger = method.refine(space, design, out)
        if bigger is None:
            break
        n_old = design.n_runs
        assert np.array_equal(bigger.x[:n_old], design.x), "refine must keep the old runs first"
        more = model.evaluate(bigger.x[n_old:], space.names, outputs)
        design, out = bigger, ModelOutput.concatenate([out, more])
    else:  # pragma: no cover - a method that never stops is a bug
        raise AssertionError("refine did not stop")
    return method.estimate(space, design, out), out


def normal_space(d: int, std: float = 1.0, mean: float = 0.0) -> InputSpace:
    """``x1..xd`` independent ``N(mean, std^2)``."""
    return InputSpace([Normal(name=f"x{i + 1}", dist="normal", mean=mean, std=std)
                       for i in range(d)])


def ishigami_space() -> InputSpace:
    return InputSpace([Uniform(name=f"x{i + 1}", dist="uniform", low=-np.pi, high=np.pi)
                       for i in range(3)])


def rel(a, b):
    """Relative error ``|a - b| / |b|`` (elementwise)."""
    return np.abs(np.asarray(a, float) - np.asarray(b, float)) / np.abs(np.asarray(b, float))
