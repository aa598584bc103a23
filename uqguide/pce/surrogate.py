"""A fitted PCE kept whole: every output's expansion, the input-to-germ map and the derived
outputs' carriers, evaluated as one vectorised predictor of the physical inputs.

The statistics of a PCE are a function of its coefficients; keeping only the statistics throws
away what the runs paid for (a density, a probability, a value at a new point). A
:class:`Surrogate` is what a PCE method fitted, in the form the result file stores
(:mod:`uqguide.results.surrogate`) and :meth:`uqguide.results.result.Result.surrogate` gives back.

The input-to-germ map is the inverse of :meth:`uqguide.pce.germ.Germ.to_physical`, input by
input (:func:`germ_map`): ``xi = (g(x) - shift) / scale`` with ``g`` the identity, or ``log`` for
a lognormal input; a correlated normal group is then decorrelated by its Cholesky factor
(``xi_group = L^-1 z``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from ..core.inputs import LogNormal, Normal, TruncNormal, Uniform
from ..core.types import DerivedOutput, OutputStats
from . import moments
from .expansion import Expansion
from .germ import Germ


@dataclass(frozen=True)
class GermMap:
    """The input-to-germ map, input by input (module docstring).

    Attributes
    ----------
    family : tuple of str
        Germ family per input (``"normal"``, ``"uniform"``, ``"other"``).
    shift, scale : ndarray, shape (d,)
        ``xi = (g(x) - shift) / scale`` before decorrelation [input units, or log units].
    log : ndarray of bool, shape (d,)
        Whether ``g`` is ``log`` (lognormal inputs).
    groups : tuple of (tuple of int, ndarray (g, g))
        Correlated groups: input indices and the Cholesky factor ``L`` of their correlation.
    """

    family: tuple[str, ...]
    shift: np.ndarray
    scale: np.ndarray
    log: np.ndarray
    groups: tuple[tuple[tuple[int, ...], np.ndarray], ...] = ()

    def to_germ(self, x: np.ndarray) -> np.ndarray:
        """Germ values ``xi (n, d)`` of physical inputs ``x (n, d)``."""
        x = np.asarray(x, dtype=float)
        if x.ndim != 2 or x.shape[1] != self.shift.size:
            raise ValueError(f"inputs must have shape (n, {self.shift.size}); got {x.shape}")
        g = np.where(self.log, np.log(np.where(self.log, x, 1.0)), x)
        xi = (g - self.shift) / self.scale
        for index, chol in self.groups:
            idx = list(index)
            xi[:, idx] = np.linalg.solve(chol, xi[:, idx].T).T
        return xi


def germ_map(germ: Germ) -> GermMap:
    """The :class:`GermMap` of a germ (the inverse of ``germ.to_physical``)."""
    d = germ.dim
    shift, scale, log = np.zeros(d), np.ones(d), np.zeros(d, dtype=bool)
    for j, m in enumerate(germ.space.marginals):
        if isinstance(m, (Normal, TruncNormal)):
            shift[j], scale[j] = m.mean, m.std
        elif isinstance(m, Uniform):
            shift[j], scale[j] = 0.5 * (m.low + m.high), 0.5 * (m.high - m.low)
        elif isinstance(m, LogNormal):
            shift[j], scale[j], log[j] = m.mu, m.sigma, True
    groups = tuple((tuple(int(i) for i in g.index), np.linalg.cholesky(g.matrix))
                   for g in germ.space.groups)
    return GermMap(germ.families, shift, scale, log, groups)


@dataclass
class Surrogate:
    """Every output's PCE of one method, as a predictor of the physical inputs.

    Attributes
    ----------
    germ : Germ
    expansions : dict of str to Expansion
        The fitted outputs (carriers of derived outputs included).
    derived : mapping of str to DerivedOutput
        Outputs computed from their carriers' surrogates.
    kinds : dict of str to str
        ``"series"`` or ``"scalar"`` per fitted output.
    """

    germ: Germ
    expansions: dict[str, Expansion]
    derived: Mapping[str, DerivedOutput] = field(default_factory=lambda: MappingProxyType({}))
    kinds: dict[str, str] = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        """Outputs it predicts: the fitted ones, then the derived ones."""
        return list(self.expansions) + [n for n in self.derived if n not in self.expansions]

    @property
    def map(self) -> GermMap:
        return germ_map(self.germ)

    def at_germ(self, xi: np.ndarray, names: list[str] | None = None) -> dict[str, np.ndarray]:
        """Values ``(n, *shape)`` of the outputs ``names`` (default: all) at germ points
        ``xi (n, d)``; a derived output's map gets the physical inputs of those points."""
        names = self.names if names is None else names
        n = xi.shape[0]
        need = {c for nm in names if nm in self.derived for c in self.derived[nm].carriers}
        need |= {nm for nm in names if nm in self.expansions}
        values = {nm: self.expansions[nm].evaluate(xi).reshape((n,) + self.expansions[nm].shape)
                  for nm in need}
        out = {nm: values[nm] for nm in names if nm in values}
        wanted = [nm for nm in names if nm in self.derived and nm not in self.expansions]
        if wanted:
            x = self.germ.to_physical(xi)
            inputs = {nm: x[:, j] for j, nm in enumerate(self.germ.space.names)}
            for nm in wanted:
                dv = self.derived[nm]
                y = np.asarray(dv.function({c: values[c] for c in dv.carriers}, inputs), float)
                out[nm] = y if y.ndim > 1 else y[:, None]
        return out

    def __call__(self, x: np.ndarray, names: list[str] | None = None) -> dict[str, np.ndarray]:
        """Surrogate values of the outputs at physical inputs.

        Parameters
        ----------
        x : ndarray, shape (n, d)
            Physical inputs, columns in the config's input order, SI units.
        names : list of str, optional
            Outputs wanted (default: every fitted and derived output).

        Returns
        -------
        dict of str to ndarray, shape (n, T, k) or (n, k)
        """
        return self.at_germ(self.map.to_germ(x), names)

    def at_unit(self, u: np.ndarray, names: list[str] | None = None) -> dict[str, np.ndarray]:
        """Values at unit-cube points ``u (n, d)`` (the maps of the designs)."""
        return self.at_germ(self.germ.from_unit(u), names)

    def statistics(self, name: str, n_runs: int = 0) -> OutputStats:
        """Exact statistics of a fitted output from its coefficients (mean, covariance,
        skewness, kurtosis and Sobol' indices; :func:`uqguide.pce.moments.output_statistics`)."""
        if name not in self.expansions:
            raise KeyError(f"{name!r} is not a fitted output of this surrogate (derived outputs "
                           f"have no coefficients; sample them with at_unit)")
        return moments.output_statistics(self.expansions[name], n_runs=n_runs)
