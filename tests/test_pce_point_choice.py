"""The ``+cv`` row's point value: the PCE's own or the corrected one, by estimated MSE."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from uqguide.pce.point_choice import BIAS_FACTOR, better_points


def _mse_closed_form(b: float, se: float) -> float:
    """Mean squared error of the chosen value when the correction ``d ~ N(b, se^2)`` (the PCE's
    value 0, the truth ``b``): ``b^2`` where ``|d| < c``, ``(d - b)^2`` elsewhere,
    ``c = sqrt(2) se``."""
    c = BIAS_FACTOR * se
    lo, hi = (-c - b) / se, (c - b) / se          # the window in units of z = (d - b) / se
    inside = stats.norm.cdf(hi) - stats.norm.cdf(lo)
    # E[z^2; z outside [lo, hi]] = 1 - (Phi(hi) - Phi(lo)) + (hi phi(hi) - lo phi(lo))
    tail_z2 = 1.0 - inside + (hi * stats.norm.pdf(hi) - lo * stats.norm.pdf(lo))
    return b * b * inside + se * se * tail_z2


@pytest.mark.parametrize("b_over_se", [0.0, 0.5, 1.0, 2.0, 4.0])
def test_the_chosen_value_has_the_closed_form_mean_squared_error(b_over_se):
    se, n = 1.0, 50_000
    rng = np.random.default_rng(27)
    d = b_over_se * se + se * rng.standard_normal(n)
    own = np.zeros(n)
    value, _ = better_points(own, own + d, np.full(n, se))
    sq = (value - b_over_se * se) ** 2
    # 4 Monte Carlo standard errors of the mean squared error
    tol = 4.0 * sq.std() / math.sqrt(n)
    assert abs(sq.mean() - _mse_closed_form(b_over_se * se, se)) < tol


def test_it_beats_the_corrected_value_where_the_pce_is_good_and_costs_little_where_not():
    se = 1.0
    # exact surrogate: 0.57 se^2 against the correction's se^2
    assert _mse_closed_form(0.0, se) < 0.6 * se * se
    # the worst case over biases stays within twice the correction's own
    worst = max(_mse_closed_form(b, se) for b in np.linspace(0.0, 6.0, 121))
    assert worst < 2.0 * se * se
    # a large bias: the corrected value is taken (almost) always
    assert _mse_closed_form(6.0, se) == pytest.approx(se * se, rel=1e-3)


def test_a_withheld_or_missing_value_keeps_the_other():
    value, chose = better_points(np.array([np.nan, 1.0, 1.0]), np.array([2.0, np.nan, 1.1]),
                                 np.array([1.0, 1.0, 1.0]))
    assert np.array_equal(value[:2], [2.0, np.nan], equal_nan=True)
    assert value[2] == 1.0 and chose.tolist() == [False, False, True]
