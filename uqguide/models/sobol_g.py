"""The Sobol' G-function (Saltelli & Sobol' 1995), an analytic benchmark with exact moments.

``y = prod_i (|4 x_i - 2| + a_i) / (1 + a_i)`` with ``x_i ~ U(0, 1)``. Small ``a_i`` make an
input important and its factor non-smooth (a kink at ``x_i = 1/2``), so a polynomial chaos
converges slowly: the hard case of ``benchmarks/pce_peers.py``. Each factor's raw moments are
closed-form (``|4x - 2|`` is uniform on ``[0, 2]``) and the factors are independent, so every
raw moment of ``y``, hence its mean, std, skewness and kurtosis, is exact.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from pydantic import Field

from .base import InputInfo, Model, ModelParams, OutputInfo
from .benchmarks import clean_output
from ..core.types import ModelOutput


class SobolGParams(ModelParams):
    a: list[float] = Field(default=[0.0, 1.0, 4.5, 9.0, 99.0, 99.0, 99.0, 99.0], min_length=1,
                           description="importance a_i >= 0 of each input (small: important)")


class SobolG(Model):
    """``y = prod (|4 x_i - 2| + a_i) / (1 + a_i)``; give the inputs ``U(0, 1)``."""

    name = "sobol_g"
    summary = "Sobol' G-function: non-smooth product, exact moments for U(0, 1) inputs"
    Params = SobolGParams
    params: SobolGParams

    def inputs(self) -> tuple[InputInfo, ...]:
        return tuple(InputInfo(f"x{i + 1}", "1", f"input {i + 1}, U(0, 1)", 0.5)
                     for i in range(len(self.params.a)))

    def outputs(self) -> tuple[OutputInfo, ...]:
        return (OutputInfo("y", "scalar", "1", "prod (|4 x_i - 2| + a_i) / (1 + a_i)"),)

    def raw_moment(self, k: int) -> float:
        """``E[y^k]`` for ``x_i ~ U(0, 1)``: the product over inputs of
        ``((2 + a)^(k+1) - a^(k+1)) / (2 (k + 1) (1 + a)^k)``."""
        a = np.asarray(self.params.a, dtype=float)
        return float(np.prod(((2 + a) ** (k + 1) - a ** (k + 1)) / (2 * (k + 1) * (1 + a) ** k)))

    def exact_moments(self) -> dict[str, float]:
        """Mean, std, skewness and kurtosis (non-excess) of ``y``."""
        m1, m2, m3, m4 = (self.raw_moment(k) for k in (1, 2, 3, 4))
        var = m2 - m1**2
        mu3 = m3 - 3 * m1 * m2 + 2 * m1**3
        mu4 = m4 - 4 * m1 * m3 + 6 * m1**2 * m2 - 3 * m1**4
        return {"mean": m1, "std": float(np.sqrt(var)), "skewness": mu3 / var**1.5,
                "kurtosis": mu4 / var**2}

    def _evaluate(self, values: Mapping[str, np.ndarray], n: int, outputs: frozenset[str]
                  ) -> ModelOutput:
        a = np.asarray(self.params.a, dtype=float)
        X = np.column_stack([values[i.name] for i in self.inputs()])
        y = np.prod((np.abs(4 * X - 2) + a) / (1 + a), axis=1)
        return clean_output(n, np.zeros(0), {"y": y[:, None]})
