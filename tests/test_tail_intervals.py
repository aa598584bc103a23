"""Tail-aware moment intervals (uqguide.stats.tail_intervals): the influence-function moments
against Hermite closed forms, the large-n limit, the stated floor on a constructed heavy tail,
independence from the chunking, coverage on a lognormal output over many seeds, and the
floor's text in the report."""

from __future__ import annotations

from math import sqrt

import numpy as np
import pandas as pd
import pytest

from uqguide.report.tables import wide_table
from uqguide.stats.moments import MomentSums, sample_statistics
from uqguide.stats.tail_intervals import if_moments, tail_intervals


def _gaussian_r(top: int = 16) -> list[np.ndarray]:
    """Standardised moments of a Gaussian: r_k = (k - 1)!! for even k, 0 for odd."""
    r = []
    for k in range(top + 1):
        r.append(np.array(0.0 if k % 2 else float(np.prod(np.arange(k - 1, 0, -2)))))
    return r


def test_influence_moments_of_a_gaussian_are_the_hermite_closed_forms():
    r = _gaussian_r()
    # IF of the kurtosis is He4(z) = z^4 - 6 z^2 + 3: E[He4^2] = 4! = 24 and
    # E[He4^3] = (4!)^3 / (2!)^3 = 1728; the skewness' is He3(z): E = 3! = 6, odd cube 0.
    v2, v3 = if_moments("kurtosis", r)
    assert (float(v2), float(v3)) == (24.0, 1728.0)
    v2, v3 = if_moments("skewness", r)
    assert (float(v2), float(v3)) == (6.0, 0.0)
    assert float(if_moments("std", r)[0]) == 0.5


def test_large_n_limit_is_the_normal_theory_interval():
    n, s = 1e10, 2.0
    r = _gaussian_r()
    mus = tuple(r[k] * s**k for k in range(2, 17))
    ci = tail_intervals(np.array(1.0), mus, n)[0]
    half = {k: (float(v[1]) - float(v[0])) / 2 for k, v in ci.items()}
    z = 1.959963984540054
    expect = {"mean": s / sqrt(n), "std": s / sqrt(2 * n), "skewness": sqrt(6 / n),
              "kurtosis": sqrt(24 / n)}
    for k, e in expect.items():
        # Hall's shift is O(1/n) relative to the half-width's O(1/sqrt(n))
        assert abs(half[k] / (z * e) - 1.0) < 1e-4, (k, half[k], z * e)


def test_a_handful_of_runs_carrying_the_tail_gives_a_floor():
    y = np.random.default_rng(1).standard_normal((1000, 1))
    y[7, 0] = 60.0  # one run carries the 4th-8th moment sums
    st = sample_statistics(y, intervals="tail")
    lo, hi = st.ci["kurtosis"][:, 0]
    assert np.isinf(hi) and hi > 0 and 1.0 <= lo < st.kurtosis[0]
    assert np.isinf(st.ci["skewness"][1, 0])
    # a light-tailed output keeps two finite ends
    u = np.random.default_rng(1).random((1000, 1))
    st = sample_statistics(u, intervals="tail")
    assert all(np.isfinite(st.ci[k]).all() for k in st.ci)


def test_intervals_do_not_depend_on_the_chunking():
    y = np.random.default_rng(4).lognormal(0.0, 0.4, (3000, 2))
    whole = MomentSums.of(y, comoments=False, high=True)
    merged = MomentSums.of(y[:1000], comoments=False, high=True)
    for a in (1000, 2000):
        merged = merged.merge(MomentSums.of(y[a:a + 1000], comoments=False, high=True))
    one = tail_intervals(whole.mean, tuple(m / 3000 for m in whole.central_sums()), 3000)[0]
    parts = tail_intervals(merged.mean, tuple(m / 3000 for m in merged.central_sums()), 3000)[0]
    for k in one:
        np.testing.assert_allclose(parts[k], one[k], rtol=1e-9)


def test_coverage_on_a_lognormal_output_over_seeds():
    # 400 independent samples of 1000 runs as 400 columns; exact moments of exp(N(0, 0.25)).
    # Nominal 95%; issue 27 accepts 93% (the skewness measures 92-94% here, its floors missing
    # where a sample overshoots). Over 400 seeds a true 93% has a binomial SE of 1.3%: 4 SEs
    # below is 0.879; the delta method's 81% / 65% (skewness / kurtosis) fails it.
    n, seeds, s2 = 1000, 400, 0.25
    raw = [np.exp(k * k * s2 / 2) for k in range(5)]
    m = raw[1]
    mu2 = raw[2] - m * m
    mu3 = raw[3] - 3 * m * raw[2] + 2 * m**3
    mu4 = raw[4] - 4 * m * raw[3] + 6 * m * m * raw[2] - 3 * m**4
    exact = {"mean": m, "std": sqrt(mu2), "skewness": mu3 / mu2**1.5, "kurtosis": mu4 / mu2**2}
    floor = 0.93 - 4 * sqrt(0.93 * 0.07 / seeds)
    for seed in (0, 1):
        y = np.random.default_rng([seed, 27]).lognormal(0.0, sqrt(s2), (n, seeds))
        st = sample_statistics(y, intervals="tail")
        for k, e in exact.items():
            lo, hi = st.ci[k]
            assert np.mean((lo <= e) & (e <= hi)) >= floor, (seed, k)


def test_the_side_toward_the_tail_closes_continuously_from_the_floor():
    """A Gaussian's kurtosis: its Kish count is n r_8^2 / r_16 = n / 183.9. Just above the
    floor's threshold of 10 effective runs the upper end is Student's t on n_eff - 10 degrees
    of freedom (far out), it tightens as the runs grow, and the lower end is Hall's with the
    normal quantile throughout."""
    from scipy.special import stdtrit

    from uqguide.stats.tail_intervals import MIN_EFFECTIVE_RUNS, hall_interval, if_moments

    r = _gaussian_r()
    per_run = float(r[8] ** 2 / r[16])
    z = 1.959963984540054
    v2, v3 = if_moments("kurtosis", r)
    uppers = []
    for n_eff in (10.05, 11.0, 20.0, 100.0):
        n = n_eff / per_run
        ci = tail_intervals(np.array(0.0), tuple(r[k] for k in range(2, 17)), n)[0]
        lo, hi = (float(v) for v in ci["kurtosis"])
        se, skew = np.sqrt(v2 / n), v3 / v2 ** 1.5 / np.sqrt(n)
        q = stdtrit(n_eff - MIN_EFFECTIVE_RUNS, 0.975)
        assert hi == pytest.approx(float(hall_interval(3.0, se, q, skew)[1]), rel=1e-9)
        assert lo == pytest.approx(max(1.0, float(hall_interval(3.0, se, z, skew)[0])),
                                   rel=1e-9)
        uppers.append(hi)
    assert uppers[0] > 100 and uppers == sorted(uppers, reverse=True)


def test_a_gaussian_kurtosis_at_250_runs_covers_95_percent():
    """Issue 46: samples of 250 that pass the floor's threshold are those that missed the
    tail (their kurtosis low and its standard error too); with the normal quantile on the
    tail side their intervals held the truth 93.2% +- 0.4% of 4000 samples. Nominal 95%, 4000
    samples: a binomial SE of 0.34%, so 3 SEs below is 0.940."""
    y = np.random.default_rng([250, 46]).standard_normal((250, 4000))
    d = y - y.mean(axis=0)
    mus, pw = [], d * d
    for _ in range(15):  # central moments 2 .. 16
        mus.append(pw.mean(axis=0))
        pw = pw * d
    lo, hi = tail_intervals(y.mean(axis=0), tuple(mus), 250)[0]["kurtosis"]
    assert np.mean((lo <= 3.0) & (3.0 <= hi)) >= 0.95 - 3 * sqrt(0.95 * 0.05 / 4000)


def test_the_report_states_a_floor():
    stats = pd.DataFrame([{"time": np.nan, "component": 0, "label": "mc", "stat": "kurtosis",
                           "value": 7.5, "ci_low": 5.25, "ci_high": np.inf}])
    cell = wide_table(stats, with_ref=False)["kurtosis"].iloc[0]
    # the key under the tables says what a floor is; two digits of the distance to it
    assert cell == "7.5 [>= 5.2]"


# ------------------------------------------------------------------ control-variate intervals
def test_stratified_degrees_of_freedom_are_welch_for_gaussian_kurtosis_and_fewer_for_heavy():
    from uqguide.pce.validation import stratified_se, stratified_skewness

    # values with sample kurtosis exactly 3 (two point masses at +-a and 0 in proportions
    # 1/6, 1/6, 2/3: E d^4 / (E d^2)^2 = (a^4/3) / (a^2/3)^2 = 3)
    n = 60
    x = np.concatenate([np.full(10, 1.0), np.full(10, -1.0), np.zeros(40)])[:, None]
    w, strat, share = np.full(n, 1 / n), np.zeros(n, int), np.ones(1)
    se, df = stratified_se(x, w, strat, share)
    assert df[0] == pytest.approx(n - 1) and se[0] == pytest.approx(np.sqrt(x.var(ddof=1) / n))
    assert stratified_skewness(x, strat, share, se)[0] == pytest.approx(0.0, abs=1e-12)
    # one large value among zeros: kurtosis ~ n, Satterthwaite's df ~ 2n / (kappa - 1) ~ 2
    y = np.zeros((n, 1))
    y[3] = 5.0
    se_y, df_y = stratified_se(y, w, strat, share)
    welch = stratified_se(y, w, strat, share, kurtosis_adjusted=False)[1]
    assert welch[0] == pytest.approx(n - 1) and df_y[0] < 3.0
    assert stratified_skewness(y, strat, share, se_y)[0] > 0.5


def test_hall_interval_is_symmetric_without_skew_and_longer_toward_it():
    from uqguide.stats.tail_intervals import hall_interval

    lo, hi = hall_interval(np.array([1.0, 1.0]), np.array([0.1, 0.1]), 1.96,
                           np.array([0.0, 0.3]))
    np.testing.assert_allclose([lo[0], hi[0]], [1.0 - 0.196, 1.0 + 0.196], rtol=1e-12)
    assert hi[1] - 1.0 > 1.0 - lo[1]


def test_the_corrected_interval_keeps_both_symmetric_sides_and_lengthens_toward_the_skew():
    # Hall's correction reads the skew from the runs (3-8 per outer stratum in a stratified
    # design): it may lengthen the side toward the skew, never shorten the other below the
    # symmetric t interval's (before the rule it shortened the lower side here by ~20%).
    from scipy.stats import t as student

    from uqguide.pce.validation import corrected_moments, stratified_se
    from uqguide.core.types import OutputStats

    rng = np.random.default_rng(3)
    n = 80
    s = rng.normal(size=n)
    d = rng.lognormal(0.0, 1.0, n) - np.exp(0.5)  # right-skewed model-minus-surrogate values
    pce = OutputStats(mean=np.array(0.0), std=np.array(1.0), cov=np.array([[1.0]]),
                      skewness=np.array(0.0), kurtosis=np.array(3.0), n_used=n)
    cv = corrected_moments(pce, s + d, s)
    se, df = stratified_se(d[:, None], np.full(n, 1 / n), np.zeros(n, int), np.ones(1))
    half = student.ppf(0.975, df[0]) * se[0]
    lo, hi = cv.shown_ci["mean"]
    value = float(cv.values["mean"])
    assert value == pytest.approx(d.mean(), rel=1e-12)
    assert lo <= value - half * (1 - 1e-12)
    assert hi - value > (value - lo) * 1.05  # lengthened toward the skew
