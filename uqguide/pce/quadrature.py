"""Quadrature on the germ: one-dimensional rules (:func:`rule_1d`), tensor grids
(:func:`tensor_grid`) and Smolyak combinations (:func:`smolyak_grid`). This is the only module
that sees chaospy's ``(d, n)`` arrays.

The rules, the Smolyak formula and the chaospy details: docs/methods.md#bases-and-quadrature.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from functools import lru_cache, reduce
from math import comb

import numpy as np

from .basis import graded, index_lookup, recurrence, tensor_indices, univariate
from .germ import NORMAL, UNIFORM, Germ, kind_distribution

RULES = ("gauss", "genz_keister", "patterson", "clenshaw_curtis")
#: Germ families each rule is defined for.
RULE_FAMILIES = {
    "gauss": (NORMAL, UNIFORM, "other"),
    "genz_keister": (NORMAL,),
    "patterson": (UNIFORM,),
    "clenshaw_curtis": (UNIFORM,),
}
_ORTHO_TOL = 1e-8


@dataclass(frozen=True)
class Rule1D:
    """A one-dimensional rule on a germ variable: ``nodes``, ``weights (n,)`` (summing to 1)
    and the projection ``degree`` (:func:`projection_degree`)."""

    nodes: np.ndarray
    weights: np.ndarray
    degree: int


def gauss_rule(kind: tuple[str, float, float], n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss rule of ``n`` nodes for a germ variable of kind ``kind`` (Golub-Welsch)."""
    alpha, beta = recurrence(kind, n)
    if n == 1:
        return alpha[:1].copy(), np.ones(1)
    from scipy.linalg import eigh_tridiagonal

    nodes, vecs = eigh_tridiagonal(alpha[:n], np.sqrt(beta[1:n]))
    weights = vecs[0] ** 2
    return nodes, weights / weights.sum()


def projection_degree(kind: tuple[str, float, float], nodes: np.ndarray,
                      weights: np.ndarray) -> int:
    """Largest ``p`` for which the rule keeps ``phi_0..phi_p`` discretely orthonormal."""
    n = nodes.size
    phi = univariate(kind, nodes, n - 1)  # (n, n)
    gram = (phi * weights) @ phi.T
    err = np.abs(gram - np.eye(n))
    p = 0
    while p + 1 < n and err[: p + 2, : p + 2].max() <= _ORTHO_TOL:
        p += 1
    return p


def rule_1d(germ: Germ, j: int, rule: str, level: int) -> Rule1D:
    """The 1-D ``rule`` at ``level`` for germ variable ``j``."""
    kind = germ.kind(j)
    if kind[0] not in RULE_FAMILIES[rule]:
        raise ValueError(f"rule '{rule}' is not defined for a {kind[0]} germ variable")
    try:
        return _rule_cached(kind, rule, level)
    except (IndexError, AssertionError) as exc:
        # chaospy's nested rules are tabulated: Genz-Keister 24 stops at level 4 (43 nodes).
        raise ValueError(f"chaospy has no '{rule}' rule of level {level}") from exc


@lru_cache(maxsize=256)
def _rule_cached(kind: tuple[str, float, float], rule: str, level: int) -> Rule1D:
    # chaospy only for the tabulated rules: Gauss rules (and the Smolyak run count that
    # `uqguide validate` works out from them) do without its 1 s import.
    if rule == "gauss":
        nodes, weights = gauss_rule(kind, level + 1)
    elif rule == "genz_keister":
        from chaospy.quadrature import genz_keister_24

        nodes, weights = genz_keister_24(level)  # standard normal, no CDF round trip
        nodes, weights = np.asarray(nodes, float)[0], np.asarray(weights, float)
    else:
        import chaospy

        growth = rule == "patterson"
        nodes, weights = chaospy.generate_quadrature(
            level, kind_distribution(kind), rule=rule, growth=growth)
        nodes, weights = np.asarray(nodes, float)[0], np.asarray(weights, float)
    order = np.argsort(nodes)
    nodes, weights = nodes[order], weights[order]
    return Rule1D(nodes, weights, projection_degree(kind, nodes, weights))


@dataclass
class TensorTerm:
    """One tensor rule of a :class:`Grid`: combination ``coef`` (1 for a full tensor grid), one
    rule per germ variable, and ``rows (n_1, ..., n_d)``, each node's row in ``Grid.xi``."""

    coef: float
    rules: list[Rule1D]
    rows: np.ndarray

    @property
    def degrees(self) -> tuple[int, ...]:
        return tuple(r.degree for r in self.rules)


@dataclass
class Grid:
    """Quadrature nodes ``xi (N, d)`` on the germ (where the model runs) and the tensor rules
    they combine."""

    xi: np.ndarray
    terms: list[TensorTerm] = field(default_factory=list)

    @property
    def n_nodes(self) -> int:
        return int(self.xi.shape[0])

    def weights(self) -> np.ndarray:
        """Combined quadrature weights ``(N,)`` of the nodes (they may be negative for Smolyak)."""
        w = np.zeros(self.n_nodes)
        for t in self.terms:
            wt = t.coef * reduce(np.multiply.outer, [r.weights for r in t.rules], np.ones(()))
            np.add.at(w, t.rows.ravel(), wt.ravel())
        return w


def _cartesian(vectors: list[np.ndarray]) -> np.ndarray:
    """Every combination of one entry per vector, ``(prod(sizes), len(vectors))``, the last
    varying fastest (``meshgrid(indexing="ij")`` order, which takes at most 32 vectors)."""
    out = np.zeros((1, 0))
    for v in vectors:
        out = np.hstack([np.repeat(out, v.size, axis=0), np.tile(v, out.shape[0])[:, None]])
    return out


def build_grid(germ: Germ, combos: list[tuple[float, tuple[int, ...]]],
               rules: list[str]) -> Grid:
    """The union of the tensor grids of ``combos`` ((coefficient, one level per germ variable)),
    ``rules`` one rule name per germ variable."""
    d = germ.dim
    keys: dict[tuple[float, ...], int] = {}
    points: list[np.ndarray] = []
    terms = []
    for coef, levels in combos:
        rs = [rule_1d(germ, j, rules[j], levels[j]) for j in range(d)]
        flat = _cartesian([r.nodes for r in rs])
        rows = np.empty(flat.shape[0], dtype=int)
        # Nodes shared by several tensor grids (nested rules, the centre of odd Gauss rules)
        # are run once: identify them to 1e-10 in germ units.
        for i, key in enumerate(map(tuple, np.round(flat, 10) + 0.0)):
            r = keys.get(key)
            if r is None:
                r = keys[key] = len(points)
                points.append(flat[i])
            rows[i] = r
        terms.append(TensorTerm(coef, rs, rows.reshape([r.nodes.size for r in rs])))
    xi = np.array(points).reshape(-1, d)
    return Grid(xi, terms)


def tensor_grid(germ: Germ, m: int, rules: list[str]) -> Grid:
    """Full tensor grid of ``m`` nodes per input (level ``m - 1``): ``m^d`` nodes."""
    return build_grid(germ, [(1.0, (m - 1,) * germ.dim)], rules)


def smolyak_combos(d: int, order: int) -> list[tuple[float, tuple[int, ...]]]:
    """Smolyak's levels and coefficients for chaospy order ``q = order`` in ``d`` dimensions."""
    combos = []
    for total in range(max(0, order - d + 1), order + 1):
        c = (-1) ** (order - total) * comb(d - 1, order - total)
        if c == 0:
            continue
        for levels in _compositions(total, d):
            combos.append((float(c), levels))
    return combos


def _compositions(total: int, d: int):
    """All ``l`` in N^d with ``sum(l) == total``."""
    for cuts in itertools.combinations(range(total + d - 1), d - 1):
        prev, out = -1, []
        for c in cuts:
            out.append(c - prev - 1)
            prev = c
        out.append(total + d - 1 - prev - 1)
        yield tuple(out)


def smolyak_grid(germ: Germ, order: int, rules: list[str]) -> Grid:
    """Smolyak sparse grid of chaospy order ``order`` (the paper's level ``order + 1``)."""
    return build_grid(germ, smolyak_combos(germ.dim, order), rules)


def union_basis(grid: Grid) -> np.ndarray:
    """Multi-indices ``(P, d)`` of the union of the terms' tensor bases, graded."""
    seen: dict[tuple[int, ...], None] = {}
    for t in grid.terms:
        for row in tensor_indices(t.degrees):
            seen.setdefault(tuple(int(v) for v in row), None)
    return graded(np.array(list(seen), dtype=int).reshape(-1, grid.xi.shape[1]))


__all__ = ["RULES", "RULE_FAMILIES", "Rule1D", "Grid", "TensorTerm", "gauss_rule",
           "projection_degree", "rule_1d", "build_grid", "tensor_grid", "smolyak_combos",
           "smolyak_grid", "union_basis", "index_lookup"]
