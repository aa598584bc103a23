"""The G-function's exact moments against independent closed forms and quadrature."""

from __future__ import annotations

import numpy as np
from scipy.integrate import quad

from uqguide.models.sobol_g import SobolG


def test_one_input_with_a_zero_is_uniform_on_0_2():
    # y = |4x - 2| with x ~ U(0, 1) is U(0, 2): mean 1, variance 1/3, skewness 0, kurtosis 9/5
    e = SobolG({"a": [0.0]}).exact_moments()
    np.testing.assert_allclose([e["mean"], e["std"] ** 2, e["skewness"], e["kurtosis"]],
                               [1.0, 1 / 3, 0.0, 1.8], atol=1e-14)


def test_variance_is_the_textbook_product():
    a = np.array(SobolG().params.a)
    var = np.prod(1 + 1 / (3 * (1 + a) ** 2)) - 1  # Saltelli & Sobol' 1995
    assert abs(SobolG().exact_moments()["std"] ** 2 - var) <= 1e-14 * var


def test_raw_moments_equal_quadrature_of_each_factor():
    m = SobolG({"a": [0.0, 1.0, 4.5]})
    for k in (1, 2, 3, 4):
        by_quad = np.prod([quad(lambda x, a=a, k=k: ((abs(4 * x - 2) + a) / (1 + a)) ** k, 0, 1,
                                points=[0.5])[0] for a in m.params.a])
        assert abs(m.raw_moment(k) - by_quad) <= 1e-12 * by_quad, k
