"""The success region a PCE learns where some runs failed (uqguide.pce.success_region)."""

from __future__ import annotations

import numpy as np

from uqguide.core.events import clopper_pearson
from uqguide.pce.success_region import (
    check_region, conditional_moments, failed_share, fit_region, region_spread, turned_regions,
)


def _half_space(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` standard normal points in 2-d and their failures where ``a > 1``."""
    xi = np.random.default_rng(seed).standard_normal((n, 2))
    return xi, xi[:, 0] > 1.0


def test_runs_of_one_class_learn_no_region():
    xi, _ = _half_space(40, 0)
    assert fit_region(xi, np.zeros(40, dtype=bool)) is None
    assert fit_region(xi, np.ones(40, dtype=bool)) is None


def test_a_half_space_is_learnt_and_passes_its_check():
    xi, failed = _half_space(200, 1)
    region = fit_region(xi, failed)
    assert region is not None and region.degree == 1  # 30-odd failures: too few for degree 2
    # the runs separate: the near-hard margin classifies every one of them right
    assert np.array_equal(region.succeeds(xi), ~failed)
    check = check_region(xi, failed, np.arange(150, 200))
    assert check.passed and check.misclassified < check.failed
    assert check.line() == (f"{check.misclassified} of 50 validation runs misclassified "
                            f"({check.failed} of them failed)")


def test_failures_with_no_region_fail_the_check():
    # failures drawn independently of the inputs: nothing beats "every run succeeds"
    rng = np.random.default_rng(2)
    xi = rng.standard_normal((200, 2))
    failed = rng.random(200) < 0.1
    check = check_region(xi, failed, np.arange(100, 200))
    assert not check.passed


def test_the_failed_share_of_equal_weights_is_clopper_pearson():
    failed = np.zeros(50, dtype=bool)
    failed[:4] = True
    p, lo, hi = failed_share(failed, np.full(50, 1 / 50))
    assert p == 4 / 50
    np.testing.assert_allclose((lo, hi), clopper_pearson(4, 50), rtol=1e-12)


def test_the_spread_covers_the_true_region_where_few_runs_failed():
    # 3 failures of 60 runs, a + b > 2.9 the truth: the mean of a + 2 b inside the learnt
    # region moves to the truth's within the spread
    rng = np.random.default_rng(3)
    xi = rng.standard_normal((60, 2))
    xi[xi.sum(axis=1) > 2.9] *= 0.5  # the other runs all succeed
    xi[:3] = [[0.4, 3.7], [-0.2, 4.8], [0.1, 3.3]]  # the failed runs, all at large b
    failed = xi[:, 0] + xi[:, 1] > 2.9
    assert failed.sum() == 3
    draws = rng.standard_normal((20_000, 2))
    values = draws[:, 0] + 2 * draws[:, 1]
    region = fit_region(xi, failed)
    at = conditional_moments(values, region.succeeds(draws))["mean"]
    truth = conditional_moments(values, draws[:, 0] + draws[:, 1] <= 2.9)["mean"]
    share = failed_share(failed, np.full(60, 1 / 60))[1:]
    spread = region_spread(xi, failed, draws, values, share, seed=0)["mean"]
    assert abs(at - truth) <= spread
    # every turned boundary still separates the runs
    for inside in turned_regions(region, xi, failed, draws):
        assert inside.any()
