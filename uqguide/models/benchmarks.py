"""Analytic benchmark models with closed-form statistics
(docs/performance.md#pce-accuracy-against-closed-forms).

They run through the same contract and CLI as the simulators, so every method can be checked
against exact values: ``linear_gaussian`` (any PCE of degree >= 1 is exact), ``lognormal``,
``ishigami`` (closed-form variance and Sobol' indices) and ``borehole`` (8 inputs, the standard
engineering test function of Harper & Gupta 1983).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from pydantic import Field, model_validator

from .base import InputInfo, Model, ModelParams, OutputInfo
from ..core.types import ModelOutput


def clean_output(n: int, time: np.ndarray, scalars: dict[str, np.ndarray],
                 series: dict[str, np.ndarray] | None = None) -> ModelOutput:
    """The outputs of a batch of ``n`` samples none of which can fail."""
    return ModelOutput(time=time, series=series or {}, scalars=scalars,
                       failed=np.zeros(n, dtype=bool), reasons=np.full(n, "", dtype=object))


def _x_inputs(d: int) -> tuple[InputInfo, ...]:
    return tuple(InputInfo(f"x{i + 1}", "1", f"input {i + 1}", 0.0) for i in range(d))


class LinearGaussianParams(ModelParams):
    coefficients: list[list[float]] = Field(
        default=[[1.0, 2.0, -0.5], [0.5, 0.0, 1.5]],
        description="matrix A (k x d) of y = b + A x",
    )
    offset: list[float] | None = Field(default=None, description="vector b (k,), default zeros")
    n_times: int = Field(default=11, ge=2, description="points of the ramp output's grid on [0, 1]")

    @model_validator(mode="after")
    def _shapes(self) -> LinearGaussianParams:
        widths = {len(r) for r in self.coefficients}
        if len(widths) != 1 or 0 in widths:
            raise ValueError("coefficients must be a non-empty rectangular matrix (k x d)")
        if self.offset is not None and len(self.offset) != len(self.coefficients):
            raise ValueError(
                f"offset must have {len(self.coefficients)} entries (one per row of coefficients)"
            )
        return self


class LinearGaussian(Model):
    """``y = b + A x``; with Gaussian ``x`` the output is Gaussian with known mean and covariance.

    Outputs: ``y`` (scalar, k components) and ``ramp`` (series ``t * y`` on ``t in [0, 1]``),
    so the time-series path of every method is checked against a closed form too.
    """

    name = "linear_gaussian"
    summary = "y = b + A x: exact mean and covariance, skewness 0, kurtosis 3 for Gaussian x"
    Params = LinearGaussianParams
    params: LinearGaussianParams

    def _A(self) -> np.ndarray:
        return np.asarray(self.params.coefficients, dtype=float)

    def _b(self) -> np.ndarray:
        A = self._A()
        offset = self.params.offset
        return np.zeros(A.shape[0]) if offset is None else np.asarray(offset)

    def inputs(self) -> tuple[InputInfo, ...]:
        return _x_inputs(self._A().shape[1])

    def outputs(self) -> tuple[OutputInfo, ...]:
        comps = tuple(f"y{i + 1}" for i in range(self._A().shape[0]))
        return (
            OutputInfo("y", "scalar", "1", "b + A x", comps),
            OutputInfo("ramp", "series", "1", "t (b + A x) on t in [0, 1]", comps),
        )

    def exact_mean_cov(self, mean: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean (k,) and covariance (k, k) of ``y`` for inputs of mean ``mean`` (d,) and covariance
        ``cov`` (d, d)."""
        A = self._A()
        return self._b() + A @ mean, A @ cov @ A.T

    def _evaluate(self, values: Mapping[str, np.ndarray], n: int,
                  outputs: frozenset[str]) -> ModelOutput:
        X = np.column_stack([values[i.name] for i in self.inputs()])
        y = self._b() + X @ self._A().T
        t = np.linspace(0.0, 1.0, self.params.n_times)
        return clean_output(n, t, {"y": y},
                            {"ramp": t[None, :, None] * y[:, None, :]} if "ramp" in outputs else {})


class LognormalParams(ModelParams):
    a: list[float] = Field(default=[0.3, 0.2, 0.1], min_length=1, description="weights a_i")


class Lognormal(Model):
    """``y = exp(sum a_i x_i)``; with ``x_i ~ N(0, 1)``, y is lognormal with ``s^2 = sum a_i^2``."""

    name = "lognormal"
    summary = "y = exp(sum a_i x_i): lognormal, closed-form mean, variance, skewness, kurtosis"
    Params = LognormalParams
    params: LognormalParams

    def inputs(self) -> tuple[InputInfo, ...]:
        return _x_inputs(len(self.params.a))

    def outputs(self) -> tuple[OutputInfo, ...]:
        return (OutputInfo("y", "scalar", "1", "exp(sum a_i x_i)"),)

    def exact_moments(self) -> dict[str, float]:
        """``mean``, ``std``, ``skewness``, ``kurtosis`` (non-excess) for standard normal inputs."""
        s2 = float(np.sum(np.square(self.params.a)))
        e = np.exp(s2)
        return {
            "mean": float(np.exp(s2 / 2)),
            "std": float(np.sqrt((e - 1) * e)),
            "skewness": float((e + 2) * np.sqrt(e - 1)),
            "kurtosis": float(np.exp(4 * s2) + 2 * np.exp(3 * s2) + 3 * np.exp(2 * s2) - 3),
        }

    def _evaluate(self, values: Mapping[str, np.ndarray], n: int,
                  outputs: frozenset[str]) -> ModelOutput:
        X = np.column_stack([values[i.name] for i in self.inputs()])
        return clean_output(n, np.zeros(0),
                            {"y": np.exp(X @ np.asarray(self.params.a))[:, None]})


class IshigamiParams(ModelParams):
    a: float = 7.0
    b: float = 0.1


class Ishigami(Model):
    """``y = sin x1 + a sin^2 x2 + b x3^4 sin x1`` (Ishigami & Homma 1990), ``x_i ~ U(-pi, pi)``."""

    name = "ishigami"
    summary = "Ishigami function: closed-form mean, variance and Sobol' indices for U(-pi, pi)"
    Params = IshigamiParams
    params: IshigamiParams

    def inputs(self) -> tuple[InputInfo, ...]:
        return _x_inputs(3)

    def outputs(self) -> tuple[OutputInfo, ...]:
        return (OutputInfo("y", "scalar", "1", "sin x1 + a sin^2 x2 + b x3^4 sin x1"),)

    def exact(self) -> dict[str, object]:
        """``mean``, ``variance``, first-order and total Sobol' indices (``first``, ``total``, each
        (3,)) for ``x_i ~ U(-pi, pi)``."""
        a, b, pi = self.params.a, self.params.b, np.pi
        v1 = 0.5 * (1 + b * pi**4 / 5) ** 2
        v2 = a**2 / 8
        v13 = b**2 * pi**8 * (1 / 18 - 1 / 50)
        var = v1 + v2 + v13
        return {
            "mean": a / 2,
            "variance": var,
            "first": np.array([v1, v2, 0.0]) / var,
            "total": np.array([v1 + v13, v2, v13]) / var,
        }

    def _evaluate(self, values: Mapping[str, np.ndarray], n: int,
                  outputs: frozenset[str]) -> ModelOutput:
        x1, x2, x3 = values["x1"], values["x2"], values["x3"]
        a, b = self.params.a, self.params.b
        y = np.sin(x1) + a * np.sin(x2) ** 2 + b * x3**4 * np.sin(x1)
        return clean_output(n, np.zeros(0), {"y": y[:, None]})


class Borehole(Model):
    """Water flow through a borehole [m^3/yr] (Harper & Gupta 1983), 8 inputs.

    The usual distributions: ``rw ~ N(0.10, 0.0161812)``, ``r ~ LogN(7.71, 1.0056)``,
    ``Tu ~ U(63070, 115600)``, ``Hu ~ U(990, 1110)``, ``Tl ~ U(63.1, 116)``,
    ``Hl ~ U(700, 820)``, ``L ~ U(1120, 1680)``, ``Kw ~ U(9855, 12045)``.
    """

    name = "borehole"
    summary = "borehole water-flow function: 8 inputs, smooth, dominated by rw"

    _INPUTS = (
        InputInfo("rw", "m", "radius of the borehole", 0.10),
        InputInfo("r", "m", "radius of influence", 3463.0),
        InputInfo("Tu", "m^2/yr", "transmissivity of the upper aquifer", 89335.0),
        InputInfo("Hu", "m", "potentiometric head of the upper aquifer", 1050.0),
        InputInfo("Tl", "m^2/yr", "transmissivity of the lower aquifer", 89.55),
        InputInfo("Hl", "m", "potentiometric head of the lower aquifer", 760.0),
        InputInfo("L", "m", "length of the borehole", 1400.0),
        InputInfo("Kw", "m/yr", "hydraulic conductivity of the borehole", 10950.0),
    )

    def inputs(self) -> tuple[InputInfo, ...]:
        return self._INPUTS

    def outputs(self) -> tuple[OutputInfo, ...]:
        return (OutputInfo("flow", "scalar", "m^3/yr", "2 pi Tu (Hu - Hl) / (ln(r/rw) (...))"),)

    def _evaluate(self, values: Mapping[str, np.ndarray], n: int,
                  outputs: frozenset[str]) -> ModelOutput:
        v = values
        log_r = np.log(v["r"] / v["rw"])
        denom = log_r * (1 + 2 * v["L"] * v["Tu"] / (log_r * v["rw"] ** 2 * v["Kw"])
                         + v["Tu"] / v["Tl"])
        flow = 2 * np.pi * v["Tu"] * (v["Hu"] - v["Hl"]) / denom
        failed = ~np.isfinite(flow)
        reasons = np.where(failed, "non-finite flow (r <= rw?)", "").astype(object)
        return ModelOutput(time=np.zeros(0), scalars={"flow": flow[:, None]}, failed=failed,
                           reasons=reasons)
