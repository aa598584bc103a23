"""The germ: independent standardised variables the polynomial chaos is built on, and their
maps to the unit cube and the physical inputs (:class:`Germ`).

The table of germs and why standardised variables: docs/methods.md#the-germ.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import chaospy

from ..core.inputs import InputSpace, LogNormal, Normal, TruncNormal, Uniform

#: Germ families: which orthogonal polynomials and which nested rules apply.
NORMAL, UNIFORM, OTHER = "normal", "uniform", "other"


@dataclass(frozen=True)
class Germ:
    """Independent standardised variables of an :class:`InputSpace`, one per input.

    ``families``: ``"normal"`` (standard normal germ), ``"uniform"`` (U(-1, 1)) or ``"other"``
    (a standardised truncated normal) per input.
    """

    space: InputSpace
    families: tuple[str, ...]

    @classmethod
    def of(cls, space: InputSpace) -> Germ:
        fams = []
        for m in space.marginals:
            if isinstance(m, (Normal, LogNormal)):
                fams.append(NORMAL)
            elif isinstance(m, Uniform):
                fams.append(UNIFORM)
            elif isinstance(m, TruncNormal):
                fams.append(OTHER)
            else:  # pragma: no cover - InputSpace admits only the four kinds
                raise TypeError(f"no germ for marginal {type(m).__name__}")
        return cls(space, tuple(fams))

    @property
    def dim(self) -> int:
        return self.space.dim

    def kind(self, j: int) -> tuple[str, float, float]:
        """Hashable description of germ variable ``j``'s measure: ``(family, a, b)``, where
        ``a, b`` are the standardised truncation bounds of an ``"other"`` germ (else 0, 0)."""
        fam = self.families[j]
        if fam != OTHER:
            return (fam, 0.0, 0.0)
        m = self.space.marginals[j]
        a, b = (m.low - m.mean) / m.std, (m.high - m.mean) / m.std  # type: ignore[attr-defined]
        return (fam, float(a), float(b))

    def marginal(self, j: int) -> chaospy.Distribution:
        """The chaospy distribution of germ variable ``j`` (for recurrences and rules)."""
        return kind_distribution(self.kind(j))

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Germ values ``xi (n, d)`` of unit-cube points ``u (n, d)`` (independent inverse CDFs)."""
        from scipy import special, stats

        u = np.asarray(u, dtype=float)
        xi = np.empty_like(u)
        for j, fam in enumerate(self.families):
            if fam == NORMAL:
                xi[:, j] = special.ndtri(u[:, j])
            elif fam == UNIFORM:
                xi[:, j] = 2.0 * u[:, j] - 1.0
            else:
                _, a, b = self.kind(j)
                xi[:, j] = stats.truncnorm(a, b).ppf(u[:, j])
        return xi

    def to_physical(self, xi: np.ndarray) -> np.ndarray:
        """Physical inputs ``x (n, d)`` (SI units, columns as ``space.names``) of germ values."""
        xi = np.asarray(xi, dtype=float)
        x = np.empty_like(xi)
        for j, m in enumerate(self.space.marginals):
            if isinstance(m, Uniform):
                x[:, j] = 0.5 * (m.low + m.high) + 0.5 * (m.high - m.low) * xi[:, j]
            elif isinstance(m, LogNormal):
                x[:, j] = np.exp(m.mu + m.sigma * xi[:, j])
            else:  # normal and truncated normal
                x[:, j] = m.mean + m.std * xi[:, j]  # type: ignore[attr-defined]
        for g in self.space.groups:
            L = np.linalg.cholesky(g.matrix)
            idx = list(g.index)
            ms = [self.space.marginals[i] for i in idx]
            mean = np.array([m.mean for m in ms])  # type: ignore[attr-defined]
            std = np.array([m.std for m in ms])  # type: ignore[attr-defined]
            x[:, idx] = mean + std * (xi[:, idx] @ L.T)
        return x

    def from_physical(self, x: np.ndarray) -> np.ndarray:
        """Germ values ``xi (n, d)`` of physical inputs ``x (n, d)``: the inverse of
        :meth:`to_physical`, in closed form (a detour through the unit cube would lose the
        normal tails to the rounding of CDFs near 1)."""
        from scipy import linalg

        x = np.asarray(x, dtype=float)
        xi = np.empty_like(x)
        for j, m in enumerate(self.space.marginals):
            if isinstance(m, Uniform):
                xi[:, j] = (x[:, j] - 0.5 * (m.low + m.high)) / (0.5 * (m.high - m.low))
            elif isinstance(m, LogNormal):
                xi[:, j] = (np.log(x[:, j]) - m.mu) / m.sigma
            else:
                xi[:, j] = (x[:, j] - m.mean) / m.std  # type: ignore[attr-defined]
        for g in self.space.groups:
            L = np.linalg.cholesky(g.matrix)
            idx = list(g.index)
            xi[:, idx] = linalg.solve_triangular(L, xi[:, idx].T, lower=True).T
        return xi


def kind_distribution(kind: tuple[str, float, float]) -> chaospy.Distribution:
    """The chaospy distribution of a germ variable of the given :meth:`Germ.kind`."""
    import chaospy

    fam, a, b = kind
    if fam == NORMAL:
        return chaospy.Normal(0.0, 1.0)
    if fam == UNIFORM:
        return chaospy.Uniform(-1.0, 1.0)
    return chaospy.TruncNormal(a, b, 0.0, 1.0)
