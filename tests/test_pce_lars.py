"""Hybrid LARS with corrected leave-one-out error, degree adaptivity and PCA compression."""

from __future__ import annotations

import numpy as np
import pytest

from uqguide.pce import basis
from uqguide.pce.germ import Germ
from uqguide.pce.lars import LarsPath, corrected_loo_path, hybrid_lars, lars_order
from uqguide.pce.pca import constant_columns, principal_components
from uqguide.pce.sparse_regression import fit_columns

from .test_pce_helpers import normal_space


def _direct_loo(psi, y, cols):
    """Corrected LOO by the textbook formulas: hat matrix and explicit inverse."""
    a = psi[:, [0, *cols]]
    n, p = a.shape
    h = np.diag(a @ np.linalg.solve(a.T @ a, a.T))
    r = y - a @ np.linalg.lstsq(a, y, rcond=None)[0]
    t = n / (n - p) * (1 + np.trace(np.linalg.inv(a.T @ a / n)) / n)
    return np.mean((r / (1 - h)) ** 2) / y.var(ddof=1) * t


@pytest.fixture
def noisy_problem():
    germ = Germ.of(normal_space(3))
    rng = np.random.default_rng(5)
    xi = rng.normal(size=(60, 3))
    alpha = basis.hyperbolic_indices(3, 3, 1.0)
    psi = basis.evaluate(germ, alpha, xi)
    y = np.exp(0.4 * xi[:, 0] - 0.3 * xi[:, 1] * xi[:, 2]) + 0.01 * rng.normal(size=60)
    return psi, y


def test_incremental_loo_equals_direct_formula(noisy_problem):
    psi, y = noisy_problem
    order = lars_order(psi, y, max_steps=psi.shape[1] - 1)
    direct = [_direct_loo(psi, y, [])] + [_direct_loo(psi, y, order[:k])
                                          for k in range(1, order.size + 1)]
    for k in (0, 1, 5, 12, order.size):
        fit = corrected_loo_path(psi, y, order[:k])
        assert fit.loo == pytest.approx(min(direct[: k + 1]), rel=1e-9)
    best = corrected_loo_path(psi, y, order)
    k = best.terms.size - 1
    np.testing.assert_array_equal(best.terms, [0, *order[:k]])
    a = psi[:, best.terms]
    np.testing.assert_allclose(best.coef, np.linalg.lstsq(a, y, rcond=None)[0], rtol=1e-9)


def test_lars_recovers_a_sparse_polynomial():
    """Three true terms among 56 candidates, 40 runs (fewer than candidates): found exactly."""
    germ = Germ.of(normal_space(3))
    alpha = basis.hyperbolic_indices(3, 5, 1.0)
    xi = np.random.default_rng(2).normal(size=(40, 3))
    psi = basis.evaluate(germ, alpha, xi)
    truth = {0: 2.0, 7: 3.0, 30: -0.5}
    y = sum(c * psi[:, j] for j, c in truth.items())
    fit = hybrid_lars(psi, y)
    assert sorted(fit.terms.tolist()) == sorted(truth)
    np.testing.assert_allclose(dict(zip(fit.terms.tolist(), fit.coef)).get(30), -0.5, rtol=1e-10)
    assert fit.loo < 1e-20


def test_constant_output_is_exactly_its_value():
    germ = Germ.of(normal_space(2))
    xi = np.random.default_rng(0).normal(size=(20, 2))
    fit = fit_columns(germ, xi, np.full((20, 1), 4.5), degree_min=1, degree_max=3, q=1.0)
    assert fit.alpha.shape[0] == 1 and fit.core[0, 0] == 4.5 and fit.loo[0] == 0.0


def test_degree_adaptivity_finds_the_true_degree():
    """y is a degree-4 polynomial: the search over [1, 7] selects 4 (an exact fit ties at every
    higher degree, and the smallest candidate set wins), with exactly the two true terms."""
    germ = Germ.of(normal_space(2))
    xi = np.random.default_rng(1).normal(size=(60, 2))
    y = (xi[:, 0] ** 4 - 6 * xi[:, 0] ** 2 + 3) / np.sqrt(24) + xi[:, 1]
    fit = fit_columns(germ, xi, y[:, None], degree_min=1, degree_max=7, q=1.0)
    assert fit.degree[0] == 4
    nonzero = fit.alpha[np.abs(fit.core[:, 0]) > 1e-10].tolist()
    assert sorted(nonzero) == [[0, 1], [4, 0]]
    assert fit.loo[0] < 1e-12


def test_pca_keeps_the_variance_and_constant_columns():
    rng = np.random.default_rng(0)
    z = rng.normal(size=(50, 3))
    modes = rng.normal(size=(3, 8))
    y = z @ modes + 10.0
    y[:, 0] = 7.0  # a constant column (t = 0)
    assert constant_columns(y).tolist() == [True] + [False] * 7
    comps = principal_components(y, 0.9999)
    assert comps.n_components == 3
    recon = np.c_[comps.scores, np.ones(50)] @ comps.mix
    np.testing.assert_allclose(recon, y, atol=1e-10)
    assert comps.mix[:3, 0].tolist() == [0.0, 0.0, 0.0] and comps.mix[3, 0] == 7.0


def test_lars_on_orthonormal_columns_enters_by_coefficient_size():
    """With exactly orthonormal columns LARS's correlations are the coefficients, so terms
    enter in decreasing |coefficient| (the constant, forced first by the caller, aside)."""
    rng = np.random.default_rng(7)
    q, _ = np.linalg.qr(rng.normal(size=(50, 12)))
    q[:, 0] = 1.0 / np.sqrt(50)
    q, _ = np.linalg.qr(q)  # orthonormal again, column 0 still the constant
    coef = np.array([0.1, 3.0, -0.2, 1.5, 0.9, -2.2, 0.05, 0.6, -1.1, 0.3, 0.0, 0.45])
    order = lars_order(q, q @ coef, max_steps=11)
    want = [j for j in np.argsort(-np.abs(coef), kind="stable") if j != 0 and coef[j] != 0]
    assert order[: len(want)].tolist() == want  # the zero-coefficient column may follow


def test_lars_path_continues_where_it_stopped(noisy_problem):
    """Asking a LarsPath for more steps continues it: the same order as one long run."""
    psi, y = noisy_problem
    path = LarsPath(psi, y)
    short = path.order(5)
    longer = path.order(15)
    np.testing.assert_array_equal(longer[:5], short)
    np.testing.assert_array_equal(longer, lars_order(psi, y, max_steps=15))


def test_default_fit_is_deterministic_and_chooses_its_grid():
    """Defaults: q-norm and degree come from the grid (the q = 0.5 set reaches the high
    degree a smooth one-input function needs); two fits of the same data are identical."""
    germ = Germ.of(normal_space(3))
    xi = np.random.default_rng(3).normal(size=(120, 3))
    y = np.sin(1.5 * xi[:, 0]) + 0.3 * xi[:, 1] * xi[:, 2]
    a = fit_columns(germ, xi, y[:, None])
    b = fit_columns(germ, xi, y[:, None])
    np.testing.assert_array_equal(a.alpha, b.alpha)
    np.testing.assert_array_equal(a.core, b.core)
    assert a.q[0] in (0.5, 0.75, 1.0) and a.degree[0] >= 7
