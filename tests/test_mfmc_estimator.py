"""Multi-fidelity Monte Carlo: allocation against the closed form, the estimator's variance
against its formula, unbiasedness, and agreement with plain Monte Carlo with one level.

The analytic problem: ``x, e_j ~ N(0, 1)`` independent, level 0 ``y_0 = x``, level ``j``
``y_j = x + s_j e_j``, so ``rho_j = 1 / sqrt(1 + s_j^2)`` exactly.
"""

from __future__ import annotations

import numpy as np
import pytest

from uqguide.stats.mfmc_allocation import (
    Allocation,     mfmc_ratios, ordering_holds, sample_sizes, select_allocation, variance_factor,
    variance_ratio,
)
from uqguide.stats.mfmc_estimator import mfmc_statistics
from uqguide.stats.moments import sample_statistics

NOISE = np.array([0.0, 0.3, 1.0])
RHO = 1.0 / np.sqrt(1.0 + NOISE**2)
COST = np.array([1.0, 0.05, 0.01])


def _levels(rng: np.random.Generator, sizes: np.ndarray) -> list[np.ndarray]:
    n = int(sizes[-1])
    x = rng.standard_normal(n)
    return [(x + s * rng.standard_normal(n))[:m, None] for s, m in zip(NOISE, sizes)]


def test_ratios_match_the_closed_form_and_the_optimal_variance():
    r = mfmc_ratios(RHO, COST)
    r2 = np.append(RHO**2, 0)
    by_hand = [np.sqrt(COST[0] * (r2[i] - r2[i + 1]) / (COST[i] * (1 - r2[1])))
               for i in range(3)]
    assert r[0] == pytest.approx(1.0)
    np.testing.assert_allclose(r, by_hand, rtol=1e-14)
    # PWG16 eq (3.13): the optimal ratio is (sum_i sqrt(w_i (rho_i^2 - rho_{i+1}^2)))^2 / w_0
    closed = np.sum(np.sqrt(COST * (r2[:-1] - r2[1:])))**2 / COST[0]
    assert variance_ratio(RHO, COST, r) == pytest.approx(closed, rel=1e-12)
    # and no other nested allocation of the same levels does better
    rng = np.random.default_rng(1)
    for _ in range(200):
        other = np.sort(np.concatenate([[1.0], 1 + rng.exponential(30, 2)]))
        assert variance_ratio(RHO, COST, other) >= closed - 1e-12


def test_ordering_condition_and_model_selection():
    assert ordering_holds(RHO, COST)
    # a level that costs almost as much as the one above it breaks eq (3.8)
    assert not ordering_holds(np.array([1.0, 0.6, 0.5]), np.array([1.0, 0.9, 0.01]))
    # the selection is the best subset by the closed form (here level 2 adds less than it costs)
    a = select_allocation(RHO[None, :], COST)
    best = min(variance_ratio(RHO[list(s)], COST[list(s)], mfmc_ratios(RHO[list(s)],
                                                                        COST[list(s)]))
               for s in [(0, 1), (0, 2), (0, 1, 2)])
    assert a.variance_ratio == pytest.approx(best, rel=1e-12) and a.levels == (0, 1)
    # an uncorrelated cheap level brings nothing: plain Monte Carlo
    mc = select_allocation(np.array([[1.0, 0.05]]), np.array([1.0, 0.01]))
    assert mc.is_plain_mc and mc.variance_ratio == 1.0
    # two quantities: the allocation is scored by the worse one
    both = select_allocation(np.array([[1.0, 0.99], [1.0, 0.3]]), np.array([1.0, 0.01]))
    assert both.variance_ratio == pytest.approx(
        max(variance_ratio(np.array([1.0, 0.99]), [1, 0.01], both.ratios),
            variance_ratio(np.array([1.0, 0.3]), [1, 0.01], both.ratios)))
    # a budget gives m_0 = p / (w . r), nested
    m = sample_sizes(a, COST, budget=1000.0)
    assert np.all(np.diff(m) >= 0) and float(np.dot(COST[list(a.levels)], m)) <= 1000.0 + 1e-9


def test_one_level_is_plain_monte_carlo():
    y = np.random.default_rng(3).lognormal(size=(500, 2))
    s = mfmc_statistics([y], np.array([500]), n_resamples=0)
    ref = sample_statistics(y, bootstrap=0)
    for k in ("mean", "std", "skewness", "kurtosis"):
        np.testing.assert_allclose(getattr(s, k), getattr(ref, k), rtol=1e-10)
    np.testing.assert_allclose(s.sem, ref.sem, rtol=1e-10)


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow),
                                  pytest.param(2, marks=pytest.mark.slow),
                                  pytest.param(3, marks=pytest.mark.slow)])
def test_mean_is_unbiased_with_the_variance_of_its_formula(seed):
    # all three levels, whether or not the selection would keep level 2
    levels = (0, 1, 2)
    sizes = sample_sizes(Allocation(levels, mfmc_ratios(RHO, COST), 0.0), COST, budget=100.0)
    g = float(variance_factor(RHO, sizes / sizes[0]))
    var_formula = g / sizes[0]  # sigma_0 = 1
    rng = np.random.default_rng([seed, 30])
    n_rep = 200
    reps = [mfmc_statistics(_levels(rng, sizes), sizes, n_resamples=0) for _ in range(n_rep)]
    est = np.array([r.mean[0] for r in reps])
    # unbiased: the replicate mean is within 4 standard errors of E[y_0] = 0
    assert abs(est.mean()) < 4 * np.sqrt(var_formula / n_rep)
    # the sample variance of n_rep normal estimates has relative s.e. sqrt(2/(n_rep-1)); the
    # weights estimated from the runs add O(1/m_0) to the formula's variance
    rel_se = np.sqrt(2 / (n_rep - 1))
    assert abs(est.var(ddof=1) / var_formula - 1) < 4 * rel_se + 3 / sizes[0]
    # and MFMC beats plain MC of the same cost
    assert var_formula < 1.0 / (float(np.dot(COST, sizes)) / COST[0])
    # the std's standard error by the same formula on the squares: the replicates' spread of
    # the std (the std's estimates are near normal here: same tolerance, with the O(1/m_0) of
    # estimated weights counted twice, once for each power)
    stds = np.array([r.std[0] for r in reps])
    se2 = np.mean([r.se_std[0] ** 2 for r in reps])
    assert abs(stds.var(ddof=1) / se2 - 1) < 4 * rel_se + 6 / sizes[0]


def test_a_level_with_an_offset_serves_the_variance_as_well_as_the_mean():
    # A coarser step's bias shifts the cheap level: y_1 = y_0 + 3 exactly. About its own mean
    # the cheap level's square is the expensive one's, so it is a perfect control of the
    # variance too: the formula's standard error is plain MC's with all m_1 rows,
    # equivalent_mc_runs_std = m_1 (PWG16 Lemma 3.3 with rho = alpha = 1). Centred at the
    # expensive level's mean instead, the square would carry 6 (y_0 - mean), which tracks
    # the mean and not the spread: rho of the squares 0.2.
    rng = np.random.default_rng(5)
    sizes = np.array([50, 1000])
    y0 = rng.standard_normal(1000)
    st = mfmc_statistics([y0[:50, None], (y0 + 3.0)[:, None]], sizes, n_resamples=0)
    assert st.rho[1, 1, 0] == pytest.approx(1.0, abs=1e-12)
    assert st.equivalent_mc_runs_std[0] == pytest.approx(1000, rel=1e-9)
    assert st.equivalent_mc_runs[0] == pytest.approx(1000, rel=1e-9)
    # and the estimates are those of the 1000 rows (the control is exact)
    assert st.mean[0] == pytest.approx(y0.mean(), abs=1e-12)
    assert st.std[0] == pytest.approx(y0.std(), rel=1e-12)
    # with noise on the cheap level, the replicates' spread of the std follows the formula
    noisy = [mfmc_statistics([y[:50, None], (y + 3.0 + 0.3 * rng.standard_normal(1000))[:, None]],
                             sizes, n_resamples=0)
             for y in rng.standard_normal((200, 1000))]
    stds = np.array([r.std[0] for r in noisy])
    se2 = np.mean([r.se_std[0] ** 2 for r in noisy])
    # (as in the test above: 4 relative s.e. of a 200-replicate variance, plus O(1/m_0))
    assert abs(stds.var(ddof=1) / se2 - 1) < 4 * np.sqrt(2 / 199) + 6 / 50


def _skewed(rng: np.random.Generator, sizes: np.ndarray) -> list[np.ndarray]:
    """``y_0 = x + 0.2 x^2`` (mean 0.2, variance 1.08), level 1 = level 0 + 0.3 noise."""
    n = int(sizes[-1])
    x = rng.standard_normal(n)
    y0 = x + 0.2 * x**2
    return [y0[:sizes[0], None], (y0 + 0.3 * rng.standard_normal(n))[:, None]]


def test_intervals_are_reproducible_and_bracket_the_estimates():
    sizes = np.array([100, 1000])
    y = _skewed(np.random.default_rng(5), sizes)
    a = mfmc_statistics(y, sizes, n_resamples=100, seed=7)
    b = mfmc_statistics(y, sizes, n_resamples=100, seed=7)
    for k in ("mean", "std", "skewness", "kurtosis"):
        np.testing.assert_array_equal(a.ci[k], b.ci[k])
        assert a.ci[k][0, 0] < getattr(a, k)[0] < a.ci[k][1, 0]
    # a failed row is left out at every level: same numbers as the rows without it
    ok = np.ones(1000, bool)
    ok[[3, 500]] = False
    c = mfmc_statistics(y, sizes, ok, n_resamples=0)
    keep = np.flatnonzero(ok)
    d = mfmc_statistics([y[0][keep[keep < 100]], y[1][keep]], np.array([99, 998]),
                        n_resamples=0)
    np.testing.assert_allclose(c.mean, d.mean, rtol=1e-12)
    assert list(c.n_used) == [99, 998]


@pytest.mark.slow
def test_interval_coverage_over_seeds():
    """95% intervals of mean and std hold the exact values in >= 90% of 100 seeds (the
    acceptance floor; a true 95% coverage falls below 90% over 100 seeds with probability
    < 2%)."""
    sizes = np.array([100, 2000])
    hits = {"mean": 0, "std": 0}
    n_seeds = 100
    for seed in range(n_seeds):
        s = mfmc_statistics(_skewed(np.random.default_rng([seed, 31]), sizes), sizes,
                            n_resamples=200, seed=seed)
        hits["mean"] += s.ci["mean"][0, 0] <= 0.2 <= s.ci["mean"][1, 0]
        hits["std"] += s.ci["std"][0, 0] <= np.sqrt(1.08) <= s.ci["std"][1, 0]
    assert min(hits.values()) >= 0.9 * n_seeds, hits


def test_moments_no_distribution_has_are_not_reported():
    """Each power has its own weight, so the four estimates need not be one distribution's:
    raw moments whose kurtosis falls below 1 + skewness^2 give NaN, not a number."""
    from uqguide.stats.mfmc_estimator import _central

    # E[z] = 0, E[z^2] = 1, E[z^3] = 0, E[z^4] = 0.5: kurtosis 0.5 < 1
    mean, std, skew, kurt = _central(np.array([[[0.0, 0.0], [1.0, 1.0], [0.0, 1.0],
                                                [0.5, 3.0]]]), np.zeros(2))
    assert std.tolist() == [[1.0, 1.0]]
    assert np.isnan(skew[0, 0]) and np.isnan(kurt[0, 0])
    # a valid set (skewness 1, kurtosis 3 >= 2) is kept
    assert skew[0, 1] == 1.0 and kurt[0, 1] == 3.0


def _grid_best(rho: np.ndarray, w: np.ndarray, cap: float) -> float:
    """The worst-quantity variance ratio of the best nested allocation of three levels on a
    fine log grid of ``r_1 = m_1/m_0`` and ``r_2 / r_1 <= cap`` (an independent search)."""
    best = np.inf
    for r1 in np.geomspace(1.0, 1e3, 241):
        for step in np.geomspace(1.0, cap, 241):
            best = min(best, float(np.max(variance_ratio(rho, w, np.array([1, r1, r1 * step])))))
    return best


def test_a_capped_level_gets_the_best_allocation_within_its_cap():
    # a nearly free level 2 (a surrogate) capped at 20 times level 1's rows: the closed form
    # wants it at ~2000 times; the best allocation within the cap gives level 1 more rows
    rho = np.array([[1.0, 0.999, 0.995], [1.0, 0.995, 0.97]])
    w = np.array([1.0, 0.5, 1e-5])
    cap = np.array([np.inf, np.inf, 20.0])
    a = select_allocation(rho, w, max_step=cap)
    assert a.levels == (0, 1, 2) and a.ratios[2] <= 20 * a.ratios[1] * (1 + 1e-9)
    grid = _grid_best(rho, w, 20.0)
    # at least as good as every point of the grid, and the grid comes within 1% of it
    assert a.variance_ratio <= grid * (1 + 1e-6) and grid <= a.variance_ratio * 1.01
    # the closed form for each quantity, capped afterwards (what the method did before the
    # search), does worse: here by 2.4%
    post_hoc = []
    for q in range(2):
        r = mfmc_ratios(rho[q], w)
        r[2] = min(r[2], 20 * r[1])
        post_hoc.append(float(np.max(variance_ratio(rho, w, r))))
    assert a.variance_ratio < min(post_hoc) * (1 - 1e-3)
    # with one quantity and no cap the closed form is the optimum, and it is kept as it is
    one = select_allocation(RHO[None, :], COST)
    np.testing.assert_array_equal(one.ratios, mfmc_ratios(RHO[list(one.levels)],
                                                          COST[list(one.levels)]))


def test_the_blue_of_two_levels_is_the_mfmc_estimate():
    # with two levels the best linear unbiased estimator of nested runs is the control variate
    # with the optimal weight, which is MFMC's: the same estimate, from the same covariance
    rng = np.random.default_rng(7)
    sizes = np.array([40, 900])
    x = rng.standard_normal(900)
    lv = [(x + 0.2 * x**2)[:40, None], (x + 0.3 * rng.standard_normal(900) + 2.0)[:, None]]
    a = mfmc_statistics(lv, sizes, n_resamples=0, estimator="mfmc")
    b = mfmc_statistics(lv, sizes, n_resamples=0, estimator="blue")
    for stat in ("mean", "std", "skewness", "kurtosis", "sem", "se_std"):
        np.testing.assert_allclose(getattr(b, stat), getattr(a, stat), rtol=1e-7)


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_the_blue_is_unbiased_with_the_variance_of_its_formula_and_never_above_mfmcs(seed):
    levels = (0, 1, 2)
    sizes = sample_sizes(Allocation(levels, mfmc_ratios(RHO, COST), 0.0), COST, budget=100.0)
    rng = np.random.default_rng([seed, 31])
    n_rep = 200
    blue, mfmc = [], []
    for _ in range(n_rep):
        lv = _levels(rng, sizes)
        blue.append(mfmc_statistics(lv, sizes, n_resamples=0, estimator="blue"))
        mfmc.append(mfmc_statistics(lv, sizes, n_resamples=0, estimator="mfmc"))
    est = np.array([r.mean[0] for r in blue])
    var_formula = np.mean([r.sem[0] ** 2 for r in blue])
    # unbiased for E[y_0] = 0 (4 standard errors), and the spread its formula gives (the
    # tolerance of test_mean_is_unbiased_with_the_variance_of_its_formula)
    assert abs(est.mean()) < 4 * np.sqrt(var_formula / n_rep)
    assert abs(est.var(ddof=1) / var_formula - 1) < 4 * np.sqrt(2 / (n_rep - 1)) + 3 / sizes[0]
    # MFMC is a linear unbiased estimator of the same runs: at the same (sample) covariance
    # the BLUE's variance is at most its, on every replicate, for the mean and the variance
    for b, m in zip(blue, mfmc):
        assert b.sem[0] <= m.sem[0] * (1 + 1e-6)
        # (se_std is se(var) / (2 std), and each has its own std)
        assert b.se_std[0] * b.std[0] <= m.se_std[0] * m.std[0] * (1 + 1e-6)
