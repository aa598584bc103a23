"""The PCE building blocks: germ maps, bases, quadrature grids and projection.

Each is checked against an independent computation: chaospy's expansions and sparse grids,
InputSpace.from_unit, and exact polynomial identities.
"""

from __future__ import annotations

import chaospy
import numpy as np
import pytest

from uqguide.core.inputs import CorrelatedGroup, InputSpace, LogNormal, Normal, TruncNormal, Uniform
from uqguide.pce import basis
from uqguide.pce import quadrature as Q
from uqguide.pce.germ import Germ
from uqguide.pce.projection import project

from .test_pce_helpers import normal_space


def mixed_space() -> InputSpace:
    return InputSpace([
        Normal(name="a", dist="normal", mean=2.0, std=15.0),
        Uniform(name="b", dist="uniform", low=-3.0, high=5.0),
        LogNormal(name="c", dist="lognormal", mu=0.5, sigma=0.3),
        TruncNormal(name="e", dist="truncnormal", mean=1.0, std=2.0, low=-1.0, high=6.0),
    ])


@pytest.mark.parametrize("d, p, q", [(2, 4, 0.5), (3, 6, 1.0), (5, 3, 0.7), (9, 6, 0.5),
                                     (9, 4, 0.5), (4, 5, 0.3)])
def test_hyperbolic_set_equals_chaospy(d, p, q):
    ours = basis.hyperbolic_indices(d, p, q)
    dist = chaospy.J(*[chaospy.Normal() for _ in range(d)])
    theirs = chaospy.generate_expansion(p, dist, cross_truncation=q, retall=True)[0]
    exps = {tuple(int(v) for v in e) for e in np.asarray(theirs.exponents)}
    # chaospy lists the exponents of every monomial; with an orthogonal basis the set of
    # leading exponents equals the set of all exponents that appear.
    assert {tuple(r) for r in ours.tolist()} == exps
    assert not ours[0].any()


def test_total_degree_count_is_eq_19():
    from math import comb
    for d, p in [(7, 1), (7, 3), (9, 6)]:
        assert basis.hyperbolic_indices(d, p, 1.0).shape[0] == comb(p + d, d)


def test_germ_maps_agree_with_input_space():
    space = InputSpace(
        [Normal(name="n1", dist="normal", mean=1.0, std=2.0),
         Normal(name="n2", dist="normal", mean=-1.0, std=0.5),
         *mixed_space().marginals[1:]],
        groups=[CorrelatedGroup((0, 1), np.array([[1.0, 0.6], [0.6, 1.0]]))])
    germ = Germ.of(space)
    u = np.random.default_rng(3).random((500, space.dim))
    np.testing.assert_allclose(germ.to_physical(germ.from_unit(u)), space.from_unit(u),
                               rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("j", range(4))
def test_univariate_polynomials_are_orthonormal(j):
    """Against chaospy's own Gauss rule of each germ measure (12 nodes: exact to degree 23,
    above the 16 of a product of two degree-8 polynomials)."""
    germ = Germ.of(mixed_space())
    nodes, weights = chaospy.generate_quadrature(11, germ.marginal(j), rule="gaussian")
    phi = basis.univariate(germ.kind(j), nodes[0], 8)
    np.testing.assert_allclose((phi * weights) @ phi.T, np.eye(9), atol=1e-9)


def test_gauss_rule_projection_degree_is_m_minus_1():
    germ = Germ.of(mixed_space())
    for j in range(4):
        for m in (1, 2, 5):
            assert Q.rule_1d(germ, j, "gauss", m - 1).degree == m - 1


def test_tensor_grid_size():
    germ = Germ.of(normal_space(7))
    assert Q.tensor_grid(germ, 2, ["gauss"] * 7).n_nodes == 128
    assert Q.tensor_grid(Germ.of(normal_space(3)), 3, ["gauss"] * 3).n_nodes == 27


@pytest.mark.parametrize("order, rule, chaospy_rule", [
    (1, "gauss", "gaussian"), (2, "gauss", "gaussian"), (3, "gauss", "gaussian"),
    (1, "genz_keister", "genz_keister_24"), (2, "genz_keister", "genz_keister_24")])
def test_smolyak_nodes_are_chaospys(order, rule, chaospy_rule):
    """The nodes and combined weights of chaospy's sparse grid (15 nodes for 7 inputs at order
    1: the paper's SPCE). chaospy's Gauss grids repeat the centre node of the odd rules (its
    computed zero is not exactly 0), so its coincident nodes are merged first."""
    d = 7
    germ = Germ.of(normal_space(d))
    grid = Q.smolyak_grid(germ, order, [rule] * d)
    dist = chaospy.J(*[chaospy.Normal() for _ in range(d)])
    nodes, weights = chaospy.generate_quadrature(order, dist, rule=chaospy_rule, sparse=True)
    theirs: dict[tuple, float] = {}
    for p, w in zip(nodes.T, weights):
        key = tuple(np.round(p, 8) + 0.0)
        theirs[key] = theirs.get(key, 0.0) + w
    ours = {tuple(np.round(p, 8) + 0.0): w for p, w in zip(grid.xi, grid.weights())}
    assert grid.n_nodes == len(theirs) == len(ours)
    if order == 1:
        assert grid.n_nodes == 15
    for key, w in theirs.items():
        assert ours[key] == pytest.approx(w, abs=1e-9)


def test_smolyak_integrates_total_degree_2q_plus_1():
    """Gauss Smolyak of order q integrates total degree 2q + 1 exactly (Novak & Ritter)."""
    d, q = 3, 3
    germ = Germ.of(normal_space(d))
    grid = Q.smolyak_grid(germ, q, ["gauss"] * d)
    w = grid.weights()
    alpha = basis.hyperbolic_indices(d, 2 * q + 1, 1.0)
    psi = basis.evaluate(germ, alpha, grid.xi)
    expected = np.zeros(alpha.shape[0])
    expected[0] = 1.0
    np.testing.assert_allclose(w @ psi, expected, atol=1e-10)


@pytest.mark.parametrize("kind", ["tensor", "smolyak", "smolyak-nested"])
def test_projection_reproduces_polynomials_in_its_basis(kind):
    """Any polynomial of the grid's basis is recovered coefficient by coefficient."""
    space = InputSpace([Normal(name="a", dist="normal", std=2.0),
                        Uniform(name="b", dist="uniform", low=0.0, high=1.0),
                        Normal(name="c", dist="normal", mean=5.0, std=0.1)])
    germ = Germ.of(space)
    if kind == "tensor":
        grid = Q.tensor_grid(germ, 3, ["gauss"] * 3)
    elif kind == "smolyak":
        grid = Q.smolyak_grid(germ, 3, ["gauss"] * 3)
    else:
        grid = Q.smolyak_grid(germ, 2, ["genz_keister", "patterson", "genz_keister"])
    alpha = Q.union_basis(grid)
    coef = np.random.default_rng(0).normal(size=(alpha.shape[0], 2))
    y = basis.evaluate(germ, alpha, grid.xi) @ coef
    got_alpha, got = project(germ, grid, y)
    np.testing.assert_array_equal(got_alpha, alpha)
    np.testing.assert_allclose(got, coef, atol=1e-10)


def test_nested_rules_refuse_unknown_levels_and_families():
    germ = Germ.of(mixed_space())
    with pytest.raises(ValueError, match="level 5"):
        Q.rule_1d(germ, 0, "genz_keister", 5)
    with pytest.raises(ValueError, match="not defined"):
        Q.rule_1d(germ, 0, "patterson", 1)
