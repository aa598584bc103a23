"""Uncertain inputs: marginal distributions, the joint distribution and the map from the unit cube.

Each input is independent unless the config gives a correlation matrix for a group of normal
inputs (docs/config.md). Designs are drawn on the unit hypercube and mapped to physical
values by the inverse CDF of each marginal; a correlated normal group is mapped through the
Cholesky factor of its correlation matrix (the Nataf map, exact for normals).

The chaospy joint distribution (``InputSpace.joint``) is what the PCE methods build their
orthogonal polynomials and quadrature on.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Annotated, Literal, TypeVar, Union

import numpy as np
from pydantic import Field, PositiveFloat, model_validator

from .strict import StrictModel

if TYPE_CHECKING:
    import chaospy


def _chaospy():
    # Imported when a PCE needs it: chaospy takes over a second to import, which every
    # command (and every Ctrl-C window at start-up) would otherwise pay.
    import chaospy

    return chaospy


class _Marginal(StrictModel):
    name: str = Field(min_length=1)
    if TYPE_CHECKING:
        # The discriminator tag: each concrete marginal declares it as its Literal field.
        # Declared for type checkers only, so pydantic's fields stay those of the subclasses.
        dist: str

    def to_chaospy(self) -> chaospy.Distribution:  # pragma: no cover - abstract
        """The same distribution in chaospy."""
        raise NotImplementedError

    def ppf(self, u: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        """The inverse CDF: probabilities ``(n,)`` in ``(0, 1)`` to values in the SI unit."""
        raise NotImplementedError

    def cdf(self, x: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        """The CDF (inverse of :meth:`ppf`): values in the input's SI unit to ``[0, 1]``."""
        raise NotImplementedError

    def support(self) -> tuple[float, float]:
        """The closed interval holding every value the input can take (SI unit, infinite ends
        allowed)."""
        return -np.inf, np.inf

    def describe(self) -> str:
        """The distribution as the config writes it, e.g. ``uniform(low=0, high=2)``."""
        fields = {k: v for k, v in self.model_dump().items() if k not in ("name", "dist")}
        return f"{self.dist}({', '.join(f'{k}={v:g}' for k, v in fields.items())})"

    def moments(self) -> tuple[float, float]:  # pragma: no cover - abstract
        """Mean and standard deviation, in the input's SI unit."""
        raise NotImplementedError


class Normal(_Marginal):
    """Normal ``N(mean, std^2)``."""

    dist: Literal["normal"]
    mean: float = 0.0
    std: PositiveFloat

    def to_chaospy(self) -> chaospy.Distribution:
        return _chaospy().Normal(self.mean, self.std)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        from scipy import special

        return self.mean + self.std * special.ndtri(u)

    def cdf(self, x: np.ndarray) -> np.ndarray:
        from scipy import special

        return special.ndtr((np.asarray(x, dtype=float) - self.mean) / self.std)

    def moments(self) -> tuple[float, float]:
        return self.mean, self.std


class Uniform(_Marginal):
    """Uniform on ``[low, high]``."""

    dist: Literal["uniform"]
    low: float
    high: float

    @model_validator(mode="after")
    def _ordered(self) -> Uniform:
        if not self.high > self.low:
            raise ValueError(f"high must be greater than low, got low={self.low}, high={self.high}")
        return self

    def to_chaospy(self) -> chaospy.Distribution:
        return _chaospy().Uniform(self.low, self.high)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        return self.low + (self.high - self.low) * u

    def cdf(self, x: np.ndarray) -> np.ndarray:
        return np.clip((np.asarray(x, dtype=float) - self.low) / (self.high - self.low), 0, 1)

    def support(self) -> tuple[float, float]:
        return self.low, self.high

    def moments(self) -> tuple[float, float]:
        return 0.5 * (self.low + self.high), (self.high - self.low) / np.sqrt(12.0)


class LogNormal(_Marginal):
    """Lognormal: ``exp(N(mu, sigma^2))``; ``mu`` and ``sigma`` are those of the logarithm."""

    dist: Literal["lognormal"]
    mu: float = 0.0
    sigma: PositiveFloat

    def to_chaospy(self) -> chaospy.Distribution:
        return _chaospy().LogNormal(self.mu, self.sigma)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        from scipy import special

        return np.exp(self.mu + self.sigma * special.ndtri(u))

    def cdf(self, x: np.ndarray) -> np.ndarray:
        from scipy import special

        x = np.asarray(x, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = (np.log(np.where(x > 0, x, 1.0)) - self.mu) / self.sigma
        return np.where(x > 0, special.ndtr(z), 0.0)

    def support(self) -> tuple[float, float]:
        # 0 itself has probability zero but is the limit: a value of exactly 0 is refused by
        # the strict check of the data's rows (exp never gives it)
        return 0.0, np.inf

    def moments(self) -> tuple[float, float]:
        m = np.exp(self.mu + self.sigma**2 / 2)
        return float(m), float(m * np.sqrt(np.expm1(self.sigma**2)))


class TruncNormal(_Marginal):
    """Normal ``N(mean, std^2)`` truncated to ``[low, high]``."""

    dist: Literal["truncnormal"]
    mean: float = 0.0
    std: PositiveFloat
    low: float
    high: float

    @model_validator(mode="after")
    def _ordered(self) -> TruncNormal:
        if not self.high > self.low:
            raise ValueError(f"high must be greater than low, got low={self.low}, high={self.high}")
        return self

    def _scipy(self):
        a, b = (self.low - self.mean) / self.std, (self.high - self.mean) / self.std
        from scipy import stats  # slow to import: only truncated normals need it

        return stats.truncnorm(a, b, loc=self.mean, scale=self.std)

    def to_chaospy(self) -> chaospy.Distribution:
        return _chaospy().TruncNormal(self.low, self.high, self.mean, self.std)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        return self._scipy().ppf(u)

    def cdf(self, x: np.ndarray) -> np.ndarray:
        return self._scipy().cdf(x)

    def support(self) -> tuple[float, float]:
        return self.low, self.high

    def moments(self) -> tuple[float, float]:
        d = self._scipy()
        return float(d.mean()), float(d.std())


Marginal = Annotated[Union[Normal, Uniform, LogNormal, TruncNormal], Field(discriminator="dist")]
DISTRIBUTIONS = ("normal", "uniform", "lognormal", "truncnormal")


_Input = TypeVar("_Input", int, str)


@dataclass(frozen=True)
class CorrelatedGroup:
    """Normal inputs (by index into the space) with a correlation matrix."""

    index: tuple[int, ...]
    matrix: np.ndarray  # (g, g), symmetric positive definite, unit diagonal


def split_groups(correlated: Sequence[Sequence[_Input]], cols: Sequence[_Input]
                 ) -> list[tuple[_Input, ...]]:
    """The correlated groups (input indices, or names) that ``cols`` holds part of but not whole.

    A Sobol' index of such a set is not one of the inputs alone: a pick-freeze design cannot
    freeze it, and a PCE's index of it depends on the order of the group's decorrelated germ
    (docs/error-budget.md#correlated-inputs)."""
    inside = set(cols)
    return [tuple(c) for c in correlated
            if len(c) > 1 and inside & set(c) and not set(c) <= inside]


class InputSpace:
    """The uncertain inputs of a run, in config order: one marginal per input (their ``name``
    are the model's input names) and correlated groups of normal inputs."""

    def __init__(self, marginals: Sequence[_Marginal], groups: Sequence[CorrelatedGroup] = ()):
        self.marginals = tuple(marginals)
        self.groups = tuple(groups)
        self._chol = [np.linalg.cholesky(g.matrix) for g in self.groups]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.marginals)

    @property
    def dim(self) -> int:
        return len(self.marginals)

    @property
    def independent(self) -> bool:
        return not self.groups

    @property
    def joint(self) -> chaospy.Distribution:
        """The chaospy joint distribution (``chaospy.J`` of the marginals; MvNormal for groups)."""
        if self.independent:
            return _chaospy().J(*[m.to_chaospy() for m in self.marginals])
        parts: list[chaospy.Distribution] = []
        order: list[int] = []
        grouped = {i for g in self.groups for i in g.index}
        for g in self.groups:
            mean, std = self._group_normal(g)
            parts.append(_chaospy().MvNormal(mean, g.matrix * np.outer(std, std)))
            order.extend(g.index)
        for i, m in enumerate(self.marginals):
            if i not in grouped:
                parts.append(m.to_chaospy())
                order.append(i)
        if order != sorted(order):
            raise ValueError("correlated groups must list consecutive inputs in config order")
        return _chaospy().J(*parts)

    def _group_normal(self, g: CorrelatedGroup) -> tuple[np.ndarray, np.ndarray]:
        """Means and standard deviations ``(g,)`` of a correlated group's normal inputs."""
        ms = [self.marginals[i] for i in g.index]
        normals = [m for m in ms if isinstance(m, Normal)]
        if len(normals) != len(ms):  # the config refuses this; a direct caller may not
            raise ValueError("correlated groups hold normal inputs only")
        return np.array([m.mean for m in normals]), np.array([m.std for m in normals])

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Map points ``u (n, d)`` of ``(0, 1)^d`` (column ``j`` for ``names[j]``) to physical
        inputs in SI units (inverse CDFs; correlated groups through their Cholesky factor)."""
        from scipy import special

        u = np.asarray(u, dtype=float)
        x = np.empty_like(u)
        for j, m in enumerate(self.marginals):
            x[:, j] = m.ppf(u[:, j])
        for g, L in zip(self.groups, self._chol):
            idx = list(g.index)
            mean, std = self._group_normal(g)
            z = special.ndtri(u[:, idx]) @ L.T
            x[:, idx] = mean + std * z
        return x

    def to_unit(self, x: np.ndarray) -> np.ndarray:
        """The inverse of :meth:`from_unit`: physical inputs ``(n, d)`` in SI units to points of
        ``[0, 1]^d`` (CDFs; a correlated group decorrelated through its Cholesky factor first),
        independent uniform when ``x`` follows the inputs' distribution."""
        from scipy import linalg, special

        x = np.asarray(x, dtype=float)
        u = np.empty_like(x)
        for j, m in enumerate(self.marginals):
            u[:, j] = m.cdf(x[:, j])
        for g, L in zip(self.groups, self._chol):
            idx = list(g.index)
            mean, std = self._group_normal(g)
            z = linalg.solve_triangular(L, ((x[:, idx] - mean) / std).T, lower=True).T
            u[:, idx] = special.ndtr(z)
        return u
