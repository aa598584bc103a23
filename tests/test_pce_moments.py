"""Statistics of a PCE from its coefficients (spec 4.5), against closed forms and sampling."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from uqguide.core.inputs import InputSpace, Uniform
from uqguide.pce import basis, linearisation, moments
from uqguide.pce.expansion import Expansion
from uqguide.pce.germ import Germ
from uqguide.pce.outputs import joint_scalar_moments

from .test_pce_helpers import normal_space


def _expansion(space, alpha, coef, shape=None):
    coef = np.asarray(coef, float).reshape(len(alpha), -1)
    return Expansion(Germ.of(space), np.asarray(alpha), coef, shape or (coef.shape[1],))


def test_chi_square_moments_are_exact():
    """``y = xi^2 = 1 + sqrt(2) He_2(xi)/sqrt(2)``: chi-square(1): mean 1, variance 2,
    skewness sqrt(8), kurtosis 15."""
    exp = _expansion(normal_space(1), [[0], [2]], [1.0, np.sqrt(2.0)])
    s = moments.output_statistics(exp, n_runs=1)
    assert s.moments_method == "exact"
    np.testing.assert_allclose([s.mean[0], s.std[0] ** 2, s.skewness[0], s.kurtosis[0]],
                               [1.0, 2.0, np.sqrt(8.0), 15.0], rtol=1e-13)


def test_uniform_kurtosis_is_exact():
    """A uniform input's own kurtosis is 9/5."""
    space = InputSpace([Uniform(name="u", dist="uniform", low=2.0, high=4.0)])
    s = moments.output_statistics(_expansion(space, [[0], [1]], [3.0, 0.7]), n_runs=1)
    np.testing.assert_allclose([s.skewness[0], s.kurtosis[0]], [0.0, 1.8], atol=1e-13)


def test_sobol_indices_from_coefficients():
    """``y = xi1 + 2 xi2 + xi1 xi2``: V = 6, S = [1/6, 4/6], T = [2/6, 5/6]."""
    exp = _expansion(normal_space(2), [[0, 0], [1, 0], [0, 1], [1, 1]], [0.0, 1.0, 2.0, 1.0])
    first, total = moments.sobol_indices(exp)
    np.testing.assert_allclose(first[0], [1 / 6, 4 / 6], rtol=1e-14)
    np.testing.assert_allclose(total[0], [2 / 6, 5 / 6], rtol=1e-14)


def test_covariance_of_a_vector_output():
    """Two components on one basis: cov = sum over alpha != 0 of c c^T (eq 22)."""
    coef = np.array([[1.0, -2.0], [0.5, 1.0], [0.0, 3.0], [2.0, -1.0]])
    exp = _expansion(normal_space(2), [[0, 0], [1, 0], [0, 1], [2, 0]], coef, (2,))
    mean, cov = moments.mean_and_cov(exp)
    np.testing.assert_array_equal(mean, [1.0, -2.0])
    np.testing.assert_allclose(cov, coef[1:].T @ coef[1:])


def test_joint_scalar_covariance_across_different_bases():
    g = normal_space(2)
    e1 = _expansion(g, [[0, 0], [1, 0]], [1.0, 2.0])
    e2 = _expansion(g, [[0, 0], [0, 1], [1, 0]], [[5.0, 0.0], [1.0, 1.0], [3.0, -1.0]], (2,))
    names, mean, cov = joint_scalar_moments([("a", e1), ("b", e2)])
    assert [ix.name for ix in names] == ["a", "b[0]", "b[1]"]
    np.testing.assert_array_equal(mean, [1.0, 5.0, 0.0])
    # a = 1 + 2 x1; b0 = 5 + x2 + 3 x1; b1 = x2 - x1.
    np.testing.assert_allclose(cov, [[4, 6, -2], [6, 10, -2], [-2, -2, 2]])


def test_zero_variance_gives_nan_silently():
    """A series whose first step is constant (t = 0, no dispersion yet)."""
    coef = np.zeros((3, 4))
    coef[0] = [0.0, 0.0, 1.0, 2.0]
    coef[1:, 2:] = [[1.0, 0.5], [0.2, 0.1]]
    exp = _expansion(normal_space(2), [[0, 0], [1, 0], [0, 1]], coef, (2, 2))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for method in ("exact", "surrogate-sampling"):
            s = moments.output_statistics(exp, n_runs=1, n_draws=2000, moments=method)
            assert np.isnan(s.skewness[0]).all() and np.isnan(s.kurtosis[0]).all()
            assert np.isnan(s.sobol_first[0]).all()
            assert np.isfinite(s.skewness[1]).all() and (s.std[0] == 0).all()


def test_exact_rule_size_and_fallback_to_sampling(monkeypatch):
    exp = _expansion(normal_space(7), basis.hyperbolic_indices(7, 1, 1.0), np.ones(8))
    assert moments.exact_grid_size(exp) == 3**7
    assert moments.exact_rule(exp) == "linearisation"  # 36 pairs beat 2187 nodes
    assert moments.output_statistics(exp, n_runs=1, max_exact_points=100).moments_method \
        == "exact"
    monkeypatch.setattr(linearisation, "MAX_PRODUCT_TERMS", 10)
    s = moments.output_statistics(exp, n_runs=1, max_exact_points=100, n_draws=5000)
    assert s.moments_method == "surrogate-sampling"


def _rule_moments(exp, rule):
    if rule == "linearisation":
        return linearisation.central_moments_linearised(exp)
    return moments.central_moments_exact(exp)


def _shape(mu2, mu3, mu4):
    return mu3 / mu2**1.5, mu4 / mu2**2


@pytest.mark.parametrize("rule", ["grid", "linearisation"])
def test_linear_gaussian_moments_are_exact(rule):
    """The linear-Gaussian benchmark y = x1 + 2 x2 - 0.5 x3, x ~ N(1, 2^2): Gaussian, so
    skewness 0 and kurtosis 3; its PCE is exact at degree 1 (coefficients 2 x the weights)."""
    exp = _expansion(normal_space(3), basis.hyperbolic_indices(3, 1, 1.0),
                     [1.0 + 2.0 - 0.5, 2.0, 4.0, -1.0])
    mu2, mu3, mu4 = _rule_moments(exp, rule)
    skew, kurt = _shape(mu2, mu3, mu4)
    np.testing.assert_allclose([mu2[0], skew[0], kurt[0]], [4 * 5.25, 0.0, 3.0],
                               rtol=1e-13, atol=1e-13)


def _lognormal_expansion(s, degree):
    """PCE of exp(s . xi), xi ~ N(0, I): c_alpha = exp(|s|^2 / 2) prod s_j^a_j / sqrt(a_j!)."""
    d = len(s)
    alpha = basis.hyperbolic_indices(d, degree, 1.0)
    fact = np.array([math.factorial(k) for k in range(degree + 1)], float)
    coef = np.exp(np.sum(np.square(s)) / 2) * np.prod(
        np.asarray(s) ** alpha / np.sqrt(fact[alpha]), axis=1)
    return _expansion(normal_space(d), alpha, coef)


def _lognormal_shape(s):
    w = math.exp(float(np.sum(np.square(s))))
    return (w + 2) * math.sqrt(w - 1), w**4 + 2 * w**3 + 3 * w**2 - 3


@pytest.mark.parametrize("rule,s,degree", [
    ("grid", [0.3, 0.2, 0.1], 14),  # the lognormal benchmark; truncation below 1e-15
    ("linearisation", [0.3, 0.2, 0.1], 12),  # truncation error 1e-13 on the kurtosis
    ("linearisation", [0.5], 30),
])
def test_lognormal_skewness_kurtosis_match_closed_form(rule, s, degree):
    exp = _lognormal_expansion(s, degree)
    skew, kurt = _shape(*_rule_moments(exp, rule))
    np.testing.assert_allclose([skew[0], kurt[0]], _lognormal_shape(s), rtol=1e-12)


@pytest.mark.parametrize("rule", ["grid", "linearisation"])
def test_products_of_legendre_terms_match_closed_form(rule):
    """phi_1(x1) phi_2(x2) and phi_2(x1) phi_2(x2), x uniform: with E[phi_1^4] = 9/5,
    E[phi_2^3] = 2 sqrt(5) / 7, E[phi_2^4] = 15/7 (from E[x^2k] = 1/(2k+1) on U(-1, 1)), the
    skewness / kurtosis are 0 / 27/7 and 20/49 / 225/49; and their sum (two terms sharing
    inputs) against a fine tensor Gauss-Legendre rule of the same polynomial."""
    space = InputSpace([Uniform(name=f"x{i}", dist="uniform", low=-1, high=3) for i in (1, 2)])
    alpha = [[0, 0], [1, 2], [2, 2]]
    for coef, want in (([0.5, 1.0, 0.0], [0.0, 27 / 7]), ([0.5, 0.0, 1.0], [20 / 49, 225 / 49])):
        mu2, mu3, mu4 = _rule_moments(_expansion(space, alpha, coef), rule)
        np.testing.assert_allclose(mu2, 1.0, rtol=1e-13)
        np.testing.assert_allclose(np.ravel(_shape(mu2, mu3, mu4)), want, rtol=1e-13,
                                   atol=1e-14)
    exp = _expansion(space, alpha, [0.5, 0.7, -1.3])
    nodes, w = np.polynomial.legendre.leggauss(20)
    xi = np.stack(np.meshgrid(nodes, nodes, indexing="ij"), axis=-1).reshape(-1, 2)
    z = exp.evaluate(xi)[:, 0] - 0.5
    ww = np.outer(w, w).ravel() / 4
    want = [ww @ z**2, ww @ z**3, ww @ z**4]
    np.testing.assert_allclose(np.ravel(_rule_moments(exp, rule)), want, rtol=1e-12)


@pytest.mark.slow
def test_linearisation_and_grid_agree_on_random_sparse_expansions():
    """Both exact rules, on sparse expansions in several germ families at once (normal,
    uniform and truncated normal)."""
    from uqguide.core.inputs import TruncNormal
    space = InputSpace([Uniform(name="u", dist="uniform", low=0, high=1),
                        normal_space(1).marginals[0],
                        TruncNormal(name="t", dist="truncnormal", mean=0.0, std=1.0, low=-1.0,
                                    high=2.0)])
    rng = np.random.default_rng(3)
    alpha = basis.hyperbolic_indices(3, 5, 0.75)
    keep = np.concatenate([[0], 1 + np.flatnonzero(rng.random(alpha.shape[0] - 1) < 0.5)])
    coef = rng.normal(size=(keep.size, 3))
    exp = _expansion(space, alpha[keep], coef, (3,))
    np.testing.assert_allclose(np.ravel(linearisation.central_moments_linearised(exp)),
                               np.ravel(moments.central_moments_exact(exp)), rtol=1e-11)


@settings(max_examples=8, deadline=None, derandomize=True)
@given(coef=st.lists(st.floats(-1.0, 1.0), min_size=9, max_size=9),
       uniform=st.booleans(), sampling=st.sampled_from(["random", "sobol"]))
def test_exact_and_sampled_skewness_kurtosis_agree(coef, uniform, sampling):
    """Property: for any degree-3 PCE in two inputs, the exact skewness and kurtosis equal the
    expectation of the sampled ones (random or scrambled Sobol' draws). Checked against 16
    independent replicates (seeds) of 2^15 draws: the replicates' mean must be within 5
    standard errors (their own spread / 4) of the exact value (|t_15| > 5 has probability
    1.6e-4). Heavy-tailed cases (exact kurtosis above 10) are left out: the spread of a sampled
    kurtosis depends on the 8th moment, and 2^15 draws under-represent such tails (the
    replicates are then skewed and biased low, and a t-test does not apply)."""
    c = np.array([0.3] + coef)
    if np.sum(c[1:] ** 2) < 0.05:
        c[1] = 0.5  # keep the variance away from zero, where both are undefined
    space = (InputSpace([Uniform(name=f"x{i}", dist="uniform", low=-1, high=3) for i in (1, 2)])
             if uniform else normal_space(2))
    exp = _expansion(space, basis.hyperbolic_indices(2, 3, 1.0), c)
    exact = moments.output_statistics(exp, n_runs=1, moments="exact")
    assume(exact.kurtosis[0] < 10.0)
    reps = []
    for r in range(16):
        mu2, mu3, mu4 = moments.central_moments_sampled(exp, 2**15, seed=r, sampling=sampling)
        reps.append([mu3[0] / mu2[0] ** 1.5, mu4[0] / mu2[0] ** 2])
    reps = np.array(reps)
    se = reps.std(axis=0, ddof=1) / 4.0
    got = reps.mean(axis=0)
    want = np.array([exact.skewness[0], exact.kurtosis[0]])
    assert np.all(np.abs(got - want) <= 5 * se + 1e-12), (got, want, se)


@pytest.mark.parametrize("sampling", ["random", "sobol"])
def test_sampled_moments_do_not_depend_on_chunking(monkeypatch, sampling):
    exp = _expansion(normal_space(2), basis.hyperbolic_indices(2, 2, 1.0), np.arange(6.0))
    a = moments.central_moments_sampled(exp, 5000, seed=4, sampling=sampling)
    monkeypatch.setattr(moments, "_CHUNK_FLOATS", 3000)
    b = moments.central_moments_sampled(exp, 5000, seed=4, sampling=sampling)
    np.testing.assert_allclose(a, b, rtol=1e-12)


def test_linearisation_of_many_active_inputs_is_exact():
    """40 inputs, each in ``a_j xi_j + b_j He_2(xi_j)/sqrt(2)``: the product of ``(2p + 1) = 5``
    over them (9e27) is past any integer code, so the codes are ranked as they grow
    (``linearisation._ranked``). Cumulants of independent terms add; each term's come from a
    10-node Gauss-Hermite rule (exact to degree 19 >= 8). Tolerance: round-off of sums of
    ~1e3 terms."""
    d = 40
    rng = np.random.default_rng(46)
    a, b = rng.normal(size=d), 0.3 * rng.normal(size=d)
    alpha = np.zeros((2 * d + 1, d), dtype=int)
    alpha[1 + np.arange(d), np.arange(d)] = 1
    alpha[1 + d + np.arange(d), np.arange(d)] = 2
    exp = _expansion(normal_space(d), alpha, np.concatenate([[0.5], a, b]))
    assert math.prod([5] * d) > 2**63
    x, w = np.polynomial.hermite_e.hermegauss(10)
    w = w / w.sum()
    z = a[:, None] * x + b[:, None] * (x**2 - 1) / np.sqrt(2.0)  # (d, nodes), each mean 0
    m2, m3, m4 = ((z**k) @ w for k in (2, 3, 4))
    k2, k3, k4 = m2.sum(), m3.sum(), (m4 - 3 * m2**2).sum()
    np.testing.assert_allclose(np.ravel(linearisation.central_moments_linearised(exp)),
                               [k2, k3, k4 + 3 * k2**2], rtol=1e-12)


def test_ranked_codes_give_the_same_bits(monkeypatch):
    """Ranking the partial codes keeps their order, so forcing it at every input changes no
    bit of the moments (a sparse degree-4 expansion in five normal and uniform inputs)."""
    space = InputSpace([*normal_space(3).marginals,
                        *[Uniform(name=f"u{i}", dist="uniform", low=0, high=1) for i in (1, 2)]])
    rng = np.random.default_rng(7)
    alpha = basis.hyperbolic_indices(5, 4, 0.75)
    keep = np.concatenate([[0], 1 + np.flatnonzero(rng.random(alpha.shape[0] - 1) < 0.6)])
    exp = _expansion(space, alpha[keep], rng.normal(size=(keep.size, 2)), (2,))
    plain = linearisation.central_moments_linearised(exp)
    monkeypatch.setattr(linearisation, "_CODE_LIMIT", 1)
    ranked = linearisation.central_moments_linearised(exp)
    for p, r in zip(plain, ranked):
        assert np.array_equal(p, r)
