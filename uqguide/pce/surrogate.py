"""A fitted PCE kept whole: every output's expansion, the input-to-germ map (:func:`germ_map`)
and the derived outputs' carriers, evaluated as one vectorised predictor of the physical inputs
(:class:`Surrogate`), in the form the result file stores (:mod:`uqguide.results.surrogate`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from ..core.inputs import LogNormal, Normal, TruncNormal, Uniform
from ..core.types import DerivedOutput, OutputStats
from . import moments
from .derived import map_derived
from .expansion import Expansion
from .germ import Germ


@dataclass(frozen=True)
class GermMap:
    """The input-to-germ map, the inverse of :meth:`uqguide.pce.germ.Germ.to_physical`.

    ``family``: germ family per input; ``xi = (g(x) - shift) / scale`` before decorrelation
    [input units, or log units], ``g`` is ``log`` where ``log`` (lognormal inputs); ``groups``:
    correlated groups, input indices and the Cholesky factor ``L (g, g)`` of their correlation
    (``xi_group = L^-1 z``).
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


#: Outputs ``repr`` lists one per line before "... and N more".
SHOWN_OUTPUTS = 8


def summary(head: str, inputs: Sequence[str],
            rows: Sequence[tuple[str, np.ndarray, int | None, tuple[int, ...], str,
                                 tuple[str, float] | None]],
            derived: Mapping[str, Sequence[str]],
            full: str = ".expansions[name].alpha (terms, inputs), .coef (terms, columns)") -> str:
    """A few lines describing a surrogate, for ``repr`` (not its coefficients).

    ``rows``: per fitted output, its multi-indices ``(P, d)``, number of principal components
    (None: not compressed), shape of one sample, ``"series"`` or ``"scalar"``, and its (error
    kind, value) if known; ``derived``: derived outputs and their carriers; ``full``: where the
    full expansion is. At most :data:`SHOWN_OUTPUTS` output lines.
    """
    n_out = len(rows) + len(derived)
    names = ", ".join(inputs)
    if len(names) > 80:  # a long input list is cut, not wrapped: the summary stays short
        cut = names.rfind(", ", 0, 76)
        names = (names[:cut] if cut > 0 else names[:76]) + ", ..."
    lines = [f"{head}: {len(inputs)} input{'s' * (len(inputs) != 1)} -> {n_out} "
             f"output{'s' * (n_out != 1)}", f"  inputs: {names}"]
    for name, alpha, comps, shape, kind, error in rows[:SHOWN_OUTPUTS]:
        degree = int(alpha.sum(axis=1).max()) if alpha.size else 0
        terms = f"{alpha.shape[0]} terms" + (f" x {comps} components" if comps else "")
        size = "x".join(str(v) for v in shape)
        err = f", {error[0]} error {error[1]:.2g}" if error is not None else ""
        lines.append(f"  {name} ({kind}, {size}): degree {degree}, {terms}{err}")
    if len(rows) > SHOWN_OUTPUTS:
        lines.append(f"  ... and {len(rows) - SHOWN_OUTPUTS} more fitted outputs")
    for name, carriers in derived.items():
        lines.append(f"  {name}: derived from {', '.join(carriers)}")
    lines.append(f"  full expansion: {full}")
    return "\n".join(lines)


@dataclass
class Surrogate:
    """Every output's PCE of one method, as a predictor of the physical inputs.

    ``expansions``: the fitted outputs (carriers of derived outputs included): ``.alpha`` the
    multi-indices ``(P, d)`` in the config's input order (row 0 the constant), ``.coef`` the
    coefficients ``(P, m)``, time step slowest and component fastest; ``kinds``: ``"series"``
    or ``"scalar"``; ``label``, ``method``: the config's label and the method's registered name
    ("" when not known); ``errors``: per fitted output, the kind of its relative error
    (``"validation"`` or ``"LOO"``) and the worst value over its columns.
    """

    germ: Germ
    expansions: dict[str, Expansion]
    derived: Mapping[str, DerivedOutput] = field(default_factory=lambda: MappingProxyType({}))
    kinds: dict[str, str] = field(default_factory=dict)
    label: str = field(default="", compare=False)
    method: str = field(default="", compare=False)
    errors: dict[str, tuple[str, float]] = field(default_factory=dict, compare=False)

    def fitted_by(self, label: str, method: str, diagnostics: Mapping[str, Any]) -> Surrogate:
        """Record (and return itself) the method's label, registered name and errors from its
        ``diagnostics`` (``validation_error.<output>``, else ``loo_error.<output>``), for
        ``repr``."""
        self.label, self.method = label, method
        self.errors = {}
        for name in self.expansions:
            for kind, key in (("validation", "validation_error"), ("LOO", "loo_error")):
                value = diagnostics.get(f"{key}.{name}")
                if isinstance(value, (int, float, np.floating)):
                    self.errors[name] = (kind, float(value))
                    break
        return self

    def __repr__(self) -> str:
        who = f"{self.label!r} ({self.method})" if self.label else "(PCE)"
        rows = [(name, e.alpha, None if e.mix is None else e.mix.shape[0], e.shape,
                 self.kinds.get(name, "series" if len(e.shape) == 2 else "scalar"),
                 self.errors.get(name)) for name, e in self.expansions.items()]
        extra = [n for n in self.derived if n not in self.expansions]
        return summary(f"Surrogate {who}", list(self.germ.space.names), rows,
                       {n: self.derived[n].carriers for n in extra})

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
        need = {c for nm in names if nm in self.derived for c in self.derived[nm].carriers}
        need |= {nm for nm in names if nm in self.expansions}
        values = {nm: self.expansions[nm].values(xi) for nm in need}
        out = {nm: values[nm] for nm in names if nm in values}
        wanted = [nm for nm in names if nm in self.derived and nm not in self.expansions]
        if wanted:
            map_derived(self.germ, xi, self.derived, wanted, values)
            out.update({nm: values[nm] for nm in wanted})
        return out

    def __call__(self, x: np.ndarray, names: list[str] | None = None) -> dict[str, np.ndarray]:
        """Surrogate values ``(n, T, k)`` or ``(n, k)`` of the outputs ``names`` (default all) at
        physical inputs ``x (n, d)``, columns in the config's input order, SI units."""
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
