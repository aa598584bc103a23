"""Streaming statistics: merged chunk sums equal the two-pass moments; the Poisson bootstrap
has the width of normal theory; progress display."""

from __future__ import annotations

import pytest
import io
import re

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from uqguide.driver.progress import Progress
from uqguide.stats.moments import MomentSums, sample_statistics, statistics_from_sums


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 400),
       cuts=st.lists(st.integers(0, 400), max_size=6), loc=st.floats(-1e3, 1e3),
       scale=st.floats(1e-2, 1e2))
def test_merged_chunk_sums_equal_two_pass_moments(seed, n, cuts, loc, scale):
    # Any split into chunks (empty ones included) merged in order gives the moments of the
    # whole; the tolerance is rounding: the merge formulas are exact in real arithmetic, and a
    # mean offset |loc| / sigma up to 1e5 costs that factor of eps in the central sums.
    y = loc + scale * np.random.default_rng(seed).gamma(2.0, size=(n, 3, 2))
    bounds = sorted({0, n, *[c for c in cuts if c <= n]})
    acc = MomentSums.of(y[:0])
    for a, b in zip(bounds[:-1], bounds[1:]):
        acc = acc.merge(MomentSums.of(y[a:b]))
    got = statistics_from_sums(acc)
    ref = sample_statistics(y, bootstrap=0)
    tol = 1e-12 * (1 + abs(loc) / scale) * 1e2
    assert got.n_used == n
    np.testing.assert_allclose(got.mean, ref.mean, rtol=1e-12, atol=1e-12 * abs(loc))
    np.testing.assert_allclose(got.std, ref.std, rtol=tol)
    np.testing.assert_allclose(got.cov, ref.cov, rtol=tol, atol=tol * scale**2)
    np.testing.assert_allclose(got.skewness, ref.skewness, rtol=tol, atol=tol)
    np.testing.assert_allclose(got.kurtosis, ref.kurtosis, rtol=tol)


def test_weighted_sums_with_unit_weights_are_the_plain_sums():
    y = np.random.default_rng(3).exponential(size=(500, 4))
    w = np.ones((2, 500))
    ws, ps = MomentSums.weighted(y, w), MomentSums.of(y)
    for f in ("mean", "m2", "m3", "m4"):
        np.testing.assert_allclose(getattr(ws, f)[1], getattr(ps, f), rtol=1e-10)
    # and integer weights are repeated samples
    k = np.random.default_rng(4).poisson(1.0, size=500)
    rep = MomentSums.of(np.repeat(y, k, axis=0), comoments=False)
    wk = MomentSums.weighted(y, k[None, :].astype(float))
    for f in ("mean", "m2", "m3", "m4"):
        np.testing.assert_allclose(getattr(wk, f)[0], getattr(rep, f), rtol=1e-9)


@pytest.mark.slow
def test_poisson_bootstrap_width_matches_normal_theory():
    # Same reasoning and tolerances as the multinomial bootstrap's test in test_stats.py
    # (Poisson(1) weights are the n -> infinity limit of multinomial counts): widths within
    # 3 combined sigmas, 25% for kurtosis, 15% for the others. Eight chunks of 5000.
    n, B = 40000, 1000
    y = np.random.default_rng(5).standard_normal((n, 1))
    acc = boot = None
    for c in range(8):
        part = y[c * 5000:(c + 1) * 5000]
        w = np.random.default_rng([9, c]).poisson(1.0, size=(B, 5000)).astype(float)
        s, b = MomentSums.of(part), MomentSums.weighted(part, w)
        acc = s if acc is None else acc.merge(s)
        boot = b if boot is None else boot.merge(b)
    ci = statistics_from_sums(acc, boot).ci
    for stat, se, tol in (("std", 1 / np.sqrt(2 * n), 0.15), ("skewness", np.sqrt(6 / n), 0.15),
                          ("kurtosis", np.sqrt(24 / n), 0.25), ("mean", 1 / np.sqrt(n), 0.15)):
        width = float(ci[stat][1, 0] - ci[stat][0, 0])
        assert abs(width / (2 * 1.96 * se) - 1) < tol, (stat, width, 2 * 1.96 * se)


def test_progress_lines_off_a_terminal_and_a_bar_on_one():
    log = io.StringIO()
    p = Progress(log, tty=False, interval=0.0)
    p.plan(4, 400)
    p.start("mc")
    p.restored(100, 0)
    p.advance(100, 3)
    p.close()
    lines = log.getvalue().splitlines()
    assert re.fullmatch(r"progress: mc 0/4 chunks  0/400 runs  0 failed  \d+s", lines[0])
    # the ETA extrapolates the runs evaluated here, not those restored from a checkpoint
    assert re.fullmatch(r"progress: mc 2/4 chunks  200/400 runs  3 failed  \d+s  ETA \d+s",
                        lines[1])
    assert lines[-1].startswith("progress: mc 2/4 chunks")
    quiet = io.StringIO()
    q = Progress(quiet, tty=False, interval=3600.0)
    q.plan(4, 400)
    q.advance(100, 0)
    q.close()
    assert quiet.getvalue() == ""  # nothing shown, no closing line either
    term = io.StringIO()
    t = Progress(term, tty=True, refresh=0.0)
    t.plan(4, 400)
    t.start("mc")
    t.advance(200, 0)
    t.close()
    assert term.getvalue().startswith("\r[--------------------] mc 0/4 chunks")
    # the bar measures runs (a chunk of twice the others' size fills half of it)
    assert "\r[##########----------] mc 1/4 chunks  200/400 runs  0 failed" in term.getvalue()
    assert term.getvalue().endswith("\n")


def test_poisson1_weights_have_the_poisson_pmf():
    # 1.6e6 draws: each frequency within 5 binomial standard errors sqrt(p (1 - p) / N) of
    # e^-1 / k!, and the draws are those of inverting the CDF of the same uniforms.
    import math

    from uqguide.methods.monte_carlo import _POISSON1_CDF, poisson1

    w = poisson1(np.random.default_rng(8), (200, 8000))
    N = w.size
    freq = np.bincount(w.astype(int).ravel(), minlength=8) / N
    for k in range(8):
        p = math.exp(-1.0) / math.factorial(k)
        assert abs(freq[k] - p) < 5 * math.sqrt(p * (1 - p) / N), (k, freq[k], p)
    u = np.random.default_rng(8).random((200, 8000))
    np.testing.assert_array_equal(w, np.searchsorted(_POISSON1_CDF, u, side="right"))
