"""Hybrid LARS with corrected leave-one-out error, degree adaptivity and PCA compression."""

from __future__ import annotations

import numpy as np
import pytest

from uqguide.pce import basis
from uqguide.pce.germ import Germ
from uqguide.pce.lars import LarsPath
from uqguide.pce.loo import LooPath, score_path
from uqguide.pce.pca import constant_columns, principal_components
from uqguide.pce import sparse_regression
from uqguide.pce.sparse_regression import fit_columns

from uqguide.core.inputs import InputSpace, Uniform

from .test_pce_helpers import normal_space


def _direct_loo(psi, y, cols, se=False):
    """Corrected LOO by the textbook formulas: hat matrix and explicit inverse (and the standard
    error of the mean of the squared LOO residuals, times the same factors)."""
    a = psi[:, [0, *cols]]
    n, p = a.shape
    h = np.diag(a @ np.linalg.solve(a.T @ a, a.T))
    r = y - a @ np.linalg.lstsq(a, y, rcond=None)[0]
    t = n / (n - p) * (1 + np.trace(np.linalg.inv(a.T @ a / n)) / n) / y.var(ddof=1)
    e2 = (r / (1 - h)) ** 2
    return (np.mean(e2) * t, np.std(e2) / np.sqrt(n) * t) if se else np.mean(e2) * t


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
    order = LarsPath(psi, y).order(psi.shape[1] - 1)
    direct = [_direct_loo(psi, y, [])] + [_direct_loo(psi, y, order[:k])
                                          for k in range(1, order.size + 1)]
    for k in (0, 1, 5, 12, order.size):
        fit = score_path(psi, y, order[:k]).fit()
        assert fit.loo == pytest.approx(min(direct[: k + 1]), rel=1e-9)
    best = score_path(psi, y, order).fit()
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
    fit = score_path(psi, y, LarsPath(psi, y)).fit()
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
    order = LarsPath(q, q @ coef).order(11)
    want = [j for j in np.argsort(-np.abs(coef), kind="stable") if j != 0 and coef[j] != 0]
    assert order[: len(want)].tolist() == want  # the zero-coefficient column may follow


def test_lars_path_continues_where_it_stopped(noisy_problem):
    """Asking a LarsPath for more steps continues it: the same order as one long run."""
    psi, y = noisy_problem
    path = LarsPath(psi, y)
    short = path.order(5)
    longer = path.order(15)
    np.testing.assert_array_equal(longer[:5], short)
    np.testing.assert_array_equal(longer, LarsPath(psi, y).order(15))


def test_loo_path_reads_a_lars_path_only_as_far_as_it_scores(noisy_problem):
    """Handed the LARS path itself, the patient scoring takes only the steps it reads and
    returns the fit it returns for the whole order; without patience it reads it all."""
    _, y = noisy_problem
    germ = Germ.of(normal_space(3))
    xi = np.random.default_rng(5).normal(size=(60, 3))
    psi = basis.evaluate(germ, basis.hyperbolic_indices(3, 7, 1.0), xi)  # 120 candidates
    whole = LarsPath(psi, y).order(psi.shape[1] - 1)  # 58 steps: the runs' limit
    taken = []
    for patience, hint in ((3, 0), (5, 2), (20, 0)):
        lazy = LarsPath(psi, y)
        got = score_path(psi, y, lazy, patience=patience, hint=hint).fit()
        ref = score_path(psi, y, whole, patience=patience, hint=hint).fit()
        np.testing.assert_array_equal(got.terms, ref.terms)
        np.testing.assert_array_equal(got.coef, ref.coef)
        assert got.loo == ref.loo
        taken.append(len(lazy.active))
    assert min(taken) < whole.size  # the short patience stopped LARS early (best set: 15)
    lazy = LarsPath(psi, y)
    got = score_path(psi, y, lazy).fit()
    ref = score_path(psi, y, whole).fit()
    np.testing.assert_array_equal(got.terms, ref.terms)
    assert lazy.done or len(lazy.active) >= min(psi.shape[1], y.size - 1)


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


def test_loo_path_fed_in_blocks_equals_the_direct_formula(noisy_problem):
    """A LooPath extended block by block (as LARS goes on) scores every nested set as the
    textbook formulas do, and as one path scored at once; its standard error too."""
    psi, y = noisy_problem
    order = LarsPath(psi, y).order(psi.shape[1] - 1)
    full = np.concatenate([[0], order])
    blocks = LooPath(psi, y)
    for end in (1, 4, 11, 12, 30, full.size):
        blocks.feed(full[:end])
    once = LooPath(psi, y)
    once.feed(full)
    np.testing.assert_array_equal(blocks.cols, full)
    np.testing.assert_allclose(blocks.loo, once.loo, rtol=1e-9)
    for k in (1, 2, 9, 15, full.size - 1):
        loo, se = _direct_loo(psi, y, full[1:k], se=True)
        assert blocks.loo[k - 1] == pytest.approx(loo, rel=1e-9)
        assert blocks.se[k - 1] == pytest.approx(se, rel=1e-9)
    fit = blocks.fit(12)
    np.testing.assert_allclose(fit.coef, np.linalg.lstsq(psi[:, full[:12]], y, rcond=None)[0],
                               rtol=1e-9)


def test_loo_path_drops_a_column_in_the_span(noisy_problem):
    """A column equal to a combination of earlier ones adds nothing: dropped, not scored."""
    psi, y = noisy_problem
    psi = np.c_[psi, psi[:, 1] - 2.0 * psi[:, 3]]
    path = LooPath(psi, y)
    path.feed(np.array([0, 1, 2]))
    path.feed(np.array([0, 1, 2, 3, psi.shape[1] - 1, 5]))
    assert path.cols.tolist() == [0, 1, 2, 3, 5]
    assert path.loo[-1] == pytest.approx(_direct_loo(psi, y, [1, 2, 3, 5]), rel=1e-9)


@pytest.mark.slow
def test_columns_fitted_together_equal_their_separate_fits():
    """The principal components of a series share one candidate basis (and its LARS layout):
    each column's expansion is the one it gets when fitted alone."""
    germ = Germ.of(normal_space(2))
    xi = np.random.default_rng(11).normal(size=(40, 2))
    y = np.c_[np.exp(0.3 * xi[:, 0]) + xi[:, 0] * xi[:, 1], np.sin(xi[:, 1]), xi[:, 0] ** 3]
    together = fit_columns(germ, xi, y)

    def terms(fit, c):
        return {tuple(a): v for a, v in zip(fit.alpha.tolist(), fit.core[:, c]) if v != 0.0}

    for c in range(3):
        alone = fit_columns(germ, xi, y[:, c:c + 1])
        mine, ref = terms(together, c), terms(alone, 0)
        assert mine.keys() == ref.keys()
        np.testing.assert_allclose([mine[k] for k in ref], list(ref.values()), rtol=1e-12)
        assert together.loo[c] == alone.loo[0] and together.degree[c] == alone.degree[0]


def test_selected_fit_is_within_the_rule_of_every_cheap_degree():
    """Every degree whose own LARS is cheap is scored by it, so the selected expansion's error
    is at most any such degree's own-LARS error plus the selection rule's 1%: checked on a
    kinked (G-function-like) output with few runs, where the largest set's shared path misses
    low-degree fits."""
    germ = Germ.of(InputSpace([Uniform(name=f"u{i}", dist="uniform", low=-1.0, high=1.0)
                               for i in range(4)]))
    xi = np.random.default_rng(4).uniform(-1.0, 1.0, size=(60, 4))
    y = np.prod((2 * np.abs(xi) + np.array([0.0, 1.0, 4.5, 9.0])) / np.array([1, 2, 5.5, 10]),
                axis=1)
    chosen = fit_columns(germ, xi, y[:, None]).loo[0]
    checked = 0
    for q in sparse_regression.Q_GRID:
        for p in range(1, 8):
            alpha = basis.hyperbolic_indices(4, p, q)
            top = sparse_regression.top_degree(4, q, sparse_regression.candidate_cap(60), 1,
                                               None)
            work = 60 * alpha.shape[0] * min(alpha.shape[0], 60)
            if p > top or work > sparse_regression.OWN_LARS_WORK:
                continue
            psi = basis.evaluate(germ, alpha, xi)
            own = score_path(psi, y, LarsPath(psi, y)).fit()
            assert chosen <= 1.01 * own.loo
            checked += 1
    assert checked >= 10
