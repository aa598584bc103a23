"""A fitted polynomial chaos expansion of one output (paper eq 18), for all its ``m = T k``
columns at once, its coefficients possibly factored as ``core @ mix`` (principal components).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import basis
from .germ import Germ


@dataclass
class Expansion:
    """PCE of one output.

    ``alpha (P, d)``: multi-indices, row 0 the zero index (the constant); ``core (P, r)``;
    ``mix (r, m)`` or ``None`` for the identity (``r = m``); ``shape``: one sample of the output,
    ``(T, k)`` or ``(k,)``.
    """

    germ: Germ
    alpha: np.ndarray
    core: np.ndarray
    shape: tuple[int, ...]
    mix: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.alpha.shape[0] == 0 or self.alpha[0].any():
            raise ValueError("the first multi-index of an expansion must be the constant")

    @property
    def n_columns(self) -> int:
        return int(np.prod(self.shape))

    @property
    def coef(self) -> np.ndarray:
        """Coefficients ``(P, m)``."""
        return self.core if self.mix is None else self.core @ self.mix

    def mixed(self, core_rows: np.ndarray) -> np.ndarray:
        """``core_rows @ mix`` (rows of core-space values mapped to output columns)."""
        return core_rows if self.mix is None else core_rows @ self.mix

    def evaluate(self, xi: np.ndarray) -> np.ndarray:
        """Surrogate values ``(n, m)`` at germ points ``xi (n, d)``."""
        return self.mixed(basis.evaluate(self.germ, self.alpha, xi) @ self.core)

    def values(self, xi: np.ndarray) -> np.ndarray:
        """Surrogate values ``(n, *shape)`` at germ points ``xi (n, d)``."""
        return self.evaluate(xi).reshape((xi.shape[0],) + self.shape)

    def trimmed(self) -> Expansion:
        """The same expansion without terms whose coefficients are all zero (constant kept)."""
        keep = np.abs(self.core).max(axis=1) > 0
        keep[0] = True
        return Expansion(self.germ, self.alpha[keep], self.core[keep], self.shape, self.mix)
