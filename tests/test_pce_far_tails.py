"""A PCE's exact moments carried by inputs too rare for any run are replaced by the moments of
surrogate draws (:mod:`uqguide.pce.far_tails`)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import uqguide
from uqguide.core.types import OutputStats
from uqguide.pce import far_tails
from uqguide.pce.credibility import printed, widen
from uqguide.pce.far_tails import (BATCHES, FAR_FACTOR, beyond_the_runs, far_draws,
                                  replace_far_tails)
from uqguide.pce.validation import Corrected


def _exact(mean, std, skew, kurt) -> OutputStats:
    mean, std = np.asarray(mean, float), np.asarray(std, float)
    return OutputStats(mean=mean, std=std, skewness=np.asarray(skew, float),
                       kurtosis=np.asarray(kurt, float), cov=np.diag(std**2)[None],
                       n_used=200, moments_method="exact")


def test_an_exact_std_the_draws_refute_is_replaced_and_correct_ones_are_kept():
    """200 columns of standard normal draws whose exact moments are the normal's (0, 1, 0, 3),
    and one whose exact std is 1.1, as if a polynomial's swing at inputs of probability 1e-6
    added 21% to its variance: only that one is replaced, by the draws' own moments, with
    standard errors near the textbook ones (std: 1 / sqrt(2 m))."""
    rng = np.random.default_rng(3)
    m = far_draws(201)
    draws = rng.normal(size=(m, 201))
    std = np.ones(201)
    std[-1] = 1.1
    st = _exact(np.zeros(201), std, np.zeros(201), np.full(201, 3.0))
    st.cov = np.diag(std**2)
    cols = replace_far_tails(st, draws)
    assert cols.tolist() == [False] * 200 + [True]
    assert st.std[-1] == pytest.approx(draws[:, -1].std(), rel=1e-12)
    assert st.kurtosis[-1] == pytest.approx(stats.kurtosis(draws[:, -1], fisher=False),
                                            rel=1e-9)
    assert np.all(st.std[:200] == 1.0) and st.cov[-1, -1] == pytest.approx(st.std[-1] ** 2)
    se = st.sampling_se["std"]
    assert np.all(se[:200] == 0.0)
    # batch means of 32 batches: the se itself is within ~40% of the truth (chi, 31 df)
    assert se[-1] == pytest.approx(1 / np.sqrt(2 * m), rel=0.4)
    assert m % BATCHES == 0


def test_the_rule_is_six_standard_errors_and_the_immaterial_floor():
    rng = np.random.default_rng(5)
    m = far_draws(3)
    draws = rng.normal(size=(m, 3))
    se = 1 / np.sqrt(2 * m)  # of a normal sample's std
    # 3 se off: chance could do that; 0.5% of the std off: immaterial even at 10 se
    st = _exact(np.zeros(3), [draws[:, 0].std() + 3 * se, 1.0, 1.0], np.zeros(3),
                np.full(3, 3.0))
    assert not replace_far_tails(st, draws).any()
    far = draws[:, 0].std() + 2 * FAR_FACTOR * se + 0.011
    st = _exact(np.zeros(3), [far, 1.0, 1.0], np.zeros(3), np.full(3, 3.0))
    assert replace_far_tails(st, draws).tolist() == [True, False, False]


def test_a_heavy_tailed_kurtosis_the_draws_cannot_reach_is_not_judged():
    """A lognormal output (sigma 1, kurtosis 111): its exact kurtosis is carried by tails the
    draws seldom reach (theirs is biased low), yet it is the model's. The rule judges the mean
    and std only; their draws' standard errors grow with the tails."""
    rng = np.random.default_rng(11)
    m = far_draws(1)
    draws = np.exp(rng.normal(size=(m, 1)))
    s2 = np.exp(1.0)
    st = _exact([np.exp(0.5)], [np.sqrt((s2 - 1) * s2)], [(s2 + 2) * np.sqrt(s2 - 1)],
                [s2**4 + 2 * s2**3 + 3 * s2**2 - 3])
    assert abs(stats.kurtosis(draws[:, 0], fisher=False) - st.kurtosis[0]) > 20
    assert not replace_far_tails(st, draws).any()
    assert st.kurtosis[0] == pytest.approx(s2**4 + 2 * s2**3 + 3 * s2**2 - 3)


def test_the_part_beyond_the_runs_is_the_clipped_continuation_s_difference():
    """A standard normal output whose runs reach +-2.9: held constant beyond them, its variance
    is ``1 - 2 Q(c) - 2 c phi(c) + 2 c^2 Q(c)`` = 0.99313 at c = 2.9, its std 0.34% lower; the
    draws' difference (paired on the same 2e5 draws, so its own noise is far below that)
    matches within 10%. The mean does not move (the clipping is symmetric)."""
    rng = np.random.default_rng(17)
    z = rng.normal(size=(200_000, 1))
    c = 2.9
    q, phi = stats.norm.sf(c), stats.norm.pdf(c)
    want = 1.0 - np.sqrt(1 - 2 * q - 2 * c * phi + 2 * c**2 * q)
    got = beyond_the_runs(z, np.clip(z, -c, c))
    assert got["std"][0] == pytest.approx(want, rel=0.1)
    assert got["mean"][0] < 5e-4 and got["kurtosis"][0] > 0.05


def test_the_control_variate_interval_is_widened_on_either_side_and_its_check_is_not():
    half = {k: np.array([0.01, 0.02]) for k in ("mean", "std", "skewness", "kurtosis")}
    values = {k: np.array([1.0, 2.0]) for k in half}
    ci = {k: np.stack([values[k] - half[k], values[k] + half[k]]) for k in half}
    cv = Corrected(values=values, ci=ci, error=np.zeros(2), n=50, correction_half=half,
                   shown_ci={k: v.copy() for k, v in ci.items()})
    widen(cv, {k: np.array([0.0, 0.05]) for k in half})
    np.testing.assert_allclose(cv.ci["std"], [[0.99, 1.93], [1.01, 2.07]])
    np.testing.assert_allclose(cv.shown_ci["std"], [[0.99, 1.93], [1.01, 2.07]])
    assert cv.correction_half["std"].tolist() == [0.01, 0.02]


def test_a_widened_interval_is_printed_within_what_a_std_and_a_kurtosis_can_be():
    """gmm_dispersion's min_clearance: a +cv kurtosis interval widened beyond the runs reached
    -1058; a std cannot be below 0, a kurtosis below 1 (Monte Carlo's are clipped alike)."""
    half = {k: np.array([0.01, 0.02, 0.0]) for k in ("mean", "std", "skewness", "kurtosis")}
    values = {k: np.array([1.5, 0.01, np.nan]) for k in half}
    ci = {k: np.stack([values[k] - half[k], values[k] + half[k]]) for k in half}
    cv = Corrected(values=values, ci=ci, error=np.zeros(3), n=50, correction_half=half,
                   shown_ci={k: v.copy() for k, v in ci.items()})
    widen(cv, {k: np.array([1060.0, 0.5, 0.0]) for k in half})
    shown = printed(cv)
    np.testing.assert_allclose(shown["kurtosis"][0], [1.0, 1.0, np.nan])
    np.testing.assert_allclose(shown["std"][0], [0.0, 0.0, np.nan])
    # the upper ends, the other statistics and the interval the checks use are left alone
    np.testing.assert_allclose(shown["kurtosis"][1], cv.shown_ci["kurtosis"][1])
    np.testing.assert_allclose(shown["skewness"], cv.shown_ci["skewness"])
    assert cv.ci["kurtosis"][0, 0] == pytest.approx(1.5 - 0.01 - 1060.0)


RAMP_T = np.linspace(0.0, 5.0, 101)


def ramp(x):
    a, b = x[:, :1], x[:, 1:2]
    return {"time": RAMP_T, "y": np.minimum(a * RAMP_T, 1.0) + b * RAMP_T}


def _ramp_std(t: float) -> float:
    """The exact std of ``min(a t, 1) + b t``, ``a`` lognormal(mu -0.5, sigma 0.4), ``b``
    normal(0, 0.05): ``E[min(a t, 1)^p] = t^p E[a^p; a < 1/t] + P(a >= 1/t)`` with the
    lognormal's partial moment ``E[a^p; a < k] = exp(p mu + p^2 sigma^2 / 2)
    Phi((ln k - mu - p sigma^2) / sigma)``."""
    mu, sigma, k = -0.5, 0.4, np.log(1.0 / t)
    tail = stats.norm.sf((k - mu) / sigma)
    m1, m2 = (t**p * np.exp(p * mu + p**2 * sigma**2 / 2)
              * stats.norm.cdf((k - mu - p * sigma**2) / sigma) + tail for p in (1, 2))
    return float(np.sqrt(m2 - m1**2 + (0.05 * t) ** 2))


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 8])
def test_the_kinked_ramp_prints_no_std_its_far_tails_carry(seed):
    """``benchmarks/defaults_zoo.py``'s ramp at ``pce_adaptive`` defaults. At seed 8, t = 5 s the
    exact std was 0.2744 (the model's 0.2501) and the +cv interval +-0.0014 around it: 17
    half-widths off. Now every std printed at t = 2 s and 5 s is within 10% of the exact value,
    and every interval printed with one (+cv, +mc) within two of its half-widths (about four
    standard errors) of it."""
    cfg = {"model": {"name": "callable", "function": ramp, "inputs": ["a", "b"],
                     "outputs": [{"name": "y", "kind": "series"}]},
           "inputs": [{"name": "a", "dist": "lognormal", "mu": -0.5, "sigma": 0.4},
                      {"name": "b", "dist": "normal", "mean": 0.0, "std": 0.05}],
           "methods": [{"name": "pce_adaptive", "label": "apce"}], "seed": seed}
    st = uqguide.run(cfg).run("apce").estimate.stats["y"]
    for t in (2.0, 5.0):
        i = int(np.argmin(np.abs(RAMP_T - t)))
        exact = _ramp_std(t)
        own = st.std[i, 0]
        if np.isfinite(own):
            assert abs(own - exact) <= 0.1 * exact, (t, own, exact)
        for value, ci in ((st.corrected["std"], st.corrected_ci["std"]),
                          (st.fallback.get("std"), st.fallback_ci.get("std"))):
            if value is None or not np.isfinite(value[i, 0]):
                continue
            lo, hi = ci[:, i, 0]
            assert abs(value[i, 0] - exact) <= (hi - lo), (t, value[i, 0], lo, hi, exact)


def test_the_draws_statistics_do_not_depend_on_the_column_blocks(monkeypatch):
    """A long series' draws are reduced a block of columns at a time (the peak memory is the
    draws'): blocks of 3 and 4 columns give the bits of the whole array, a lone last column
    (NumPy sums one column pairwise) never appears."""
    from uqguide.stats.moments import central_moments, column_blocks, shape_moments
    assert column_blocks(7, 3) == [slice(0, 3), slice(3, 7)]
    assert column_blocks(1, 3) == [slice(0, 1)]
    assert column_blocks(6, 1) == [slice(0, 2), slice(2, 4), slice(4, 6)]
    v = np.random.default_rng(2).standard_t(4, size=(64, 7))
    mean, mu2, mu3, mu4 = central_moments(v)
    whole = np.array([mean, *shape_moments(mean, mu2, mu3, mu4)])
    monkeypatch.setattr(far_tails, "_CHUNK_FLOATS", 64 * 3)
    assert far_tails._blocks(64, 7) == [slice(0, 3), slice(3, 7)]
    assert np.array_equal(far_tails._stats(v), whole)
