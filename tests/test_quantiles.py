"""Quantiles: order statistics with distribution-free intervals (MC), surrogate draws (PCE)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from uqguide.config import validate_config
from uqguide.errors import ConfigError
from uqguide.methods import mc_reduce
from uqguide.propagate import run
from uqguide import quantiles
from uqguide.quantiles import (
    THREE_SIGMA,
    coverage,
    order_statistic_quantiles,
    ranks,
    select_order_statistics,
)
from uqguide.result import read_hdf5, write_hdf5

LEVELS = [0.01, 0.1, 0.5, 0.9, 0.99]
A = [0.3, 0.2, 0.1]
S = float(np.sqrt(np.sum(np.square(A))))


def _lognormal(n, **extra):
    return validate_config({
        "model": {"name": "lognormal", "a": A},
        "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                   for i in (1, 2, 3)],
        "methods": [{"name": "monte_carlo", "n_samples": n, "bootstrap": 0, "chunk_size": 128}],
        "quantiles": LEVELS, **extra})


def test_ranks_give_the_textbook_interval():
    # n = 100, median: B ~ Bin(100, 0.5), 2.5% point 40, 97.5% point 60 -> [Y_(40), Y_(61)]
    assert ranks(100, 0.5) == (50, 40, 61)
    assert coverage(100, 0.5) >= 0.95
    # too few samples for the tail: unbounded ends
    q, ci = order_statistic_quantiles(np.arange(1.0, 101.0)[:, None], (0.001, 0.999))
    assert ci[0, 0, 0] == -np.inf and ci[1, 1, 0] == np.inf


def test_monte_carlo_intervals_cover_the_exact_lognormal_quantiles_over_200_seeds():
    """For each level, the intervals that cover the exact quantile over 200 seeds number
    Bin(200, c), c the exact coverage of the order-statistic interval (>= 0.95): within 4
    binomial standard errors of 200 c. The lognormal output is skewed, so a normal-theory
    interval would fail the tails."""
    n, seeds = 500, 200
    cfg = _lognormal(n)
    exact = np.exp(S * stats.norm.ppf(LEVELS))
    hits = np.zeros(len(LEVELS))
    for seed in range(seeds):
        st = run(cfg.with_seed(seed)).runs[0].estimate.stats["y"]
        lo, hi = st.ci_quantiles[0, :, 0], st.ci_quantiles[1, :, 0]
        hits += (lo <= exact) & (exact <= hi)
    for p, h in zip(LEVELS, hits):
        c = coverage(n, p)
        assert c >= 0.95
        assert abs(h - seeds * c) <= 4 * np.sqrt(seeds * c * (1 - c)) + 1, (p, h, c)


def test_series_quantiles_at_report_times_equal_the_full_grid_ones(monkeypatch):
    """Above the memory cap a series keeps its values at the report times only; there the
    quantiles are the same numbers, elsewhere NaN."""
    cfg = validate_config({
        "model": {"name": "linear_gaussian"},
        "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                   for i in (1, 2, 3)],
        "methods": [{"name": "monte_carlo", "n_samples": 700, "chunk_size": 256,
                     "bootstrap": 0}],
        "report_times": [0.3], "quantiles": "3sigma"})
    full = run(cfg).runs[0].estimate.stats["ramp"]
    monkeypatch.setattr(mc_reduce, "QUANTILE_ALL_FLOATS", 10)
    part = run(cfg).runs[0].estimate.stats["ramp"]
    assert full.quantile_levels == part.quantile_levels == THREE_SIGMA
    kept = [3, 10]  # t = 0.3 and the last step of the 11-point grid
    assert np.array_equal(part.quantiles[:, kept], full.quantiles[:, kept])
    assert np.array_equal(part.ci_quantiles[:, :, kept], full.ci_quantiles[:, :, kept])
    assert np.isnan(np.delete(part.quantiles, kept, axis=1)).all()
    assert np.isfinite(full.quantiles).all()
    # scalars always keep every value
    y = run(cfg).runs[0]
    q, _ = order_statistic_quantiles(y.scalars["y"], THREE_SIGMA)
    assert np.array_equal(y.estimate.stats["y"].quantiles, q)


def test_pce_quantiles_from_surrogate_draws_match_the_exact_ones(tmp_path):
    """A degree-1 PCE of a linear model is exact: its draws' quantiles lie within their own
    order-statistic intervals' reach of the exact normal quantiles (4x the interval width)."""
    cfg = validate_config({
        "model": {"name": "linear_gaussian", "coefficients": [[1.0, 2.0, -0.5]]},
        "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                   for i in (1, 2, 3)],
        "methods": [{"name": "pce_tensor", "m": 2, "surrogate_draws": 100_000}],
        "quantiles": LEVELS})
    res = run(cfg)
    st = res.runs[0].estimate.stats["y"]
    exact = float(np.sqrt(5.25)) * stats.norm.ppf(LEVELS)
    half = (st.ci_quantiles[1, :, 0] - st.ci_quantiles[0, :, 0]) / 2
    assert np.all(np.abs(st.quantiles[:, 0] - exact) <= 2 * half)
    ramp = res.runs[0].estimate.stats["ramp"]
    assert ramp.quantiles.shape == (len(LEVELS), 11, 1)
    np.testing.assert_allclose(ramp.quantiles[:, -1, 0], st.quantiles[:, 0], rtol=1e-9)
    back = read_hdf5(write_hdf5(res, tmp_path / "r.h5")).runs[0].estimate.stats["y"]
    assert back.quantile_levels == st.quantile_levels
    assert np.array_equal(back.quantiles, st.quantiles)
    assert np.array_equal(back.ci_quantiles, st.ci_quantiles)


@pytest.mark.parametrize("value, field", [([], "quantiles"), ([0.5, 1.0], "quantiles[1]"),
                                          ("2sigma", "quantiles")])
def test_bad_quantile_levels_name_the_field(value, field):
    with pytest.raises(ConfigError) as exc:
        _lognormal(10, quantiles=value)
    assert exc.value.field == field


def test_envelope_figure_and_events_section_are_written(tmp_path):
    from uqguide.plots import write_figures
    from uqguide.report import render_markdown

    cfg = validate_config({
        "model": {"name": "linear_gaussian"},
        "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                   for i in (1, 2, 3)],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 3000,
                     "bootstrap": 20}],
        "quantiles": "3sigma", "events": [{"name": "hi", "output": "y", "component": "y1",
                                           "above": 3.0}]})
    res = run(cfg)
    kinds = [(f.kind, f.output, f.component) for f in write_figures(res, tmp_path)]
    assert ("envelope", "ramp", "y1") in kinds and ("envelope", "ramp", "y2") in kinds
    md = render_markdown(res)
    assert "## Events" in md and "y[y1] > 3" in md and "q0.99865" in md


@pytest.mark.parametrize("case", ["normal", "ties", "heavy", "small", "nan", "constant"])
def test_selection_equals_the_full_sort_on_uneven_chunks(case):
    """The bracketed selection returns exactly the sorted union's values at the wanted
    positions (bit for bit: an order statistic is one of the inputs), whatever the chunking;
    ties, a heavy tail, a constant lane, NaN (sorts last) and inputs too small to bracket."""
    rng = np.random.default_rng(7)
    n = 40 if case == "small" else 30_011
    y = rng.standard_normal((n, 3, 2))
    if case == "ties":
        y = np.floor(3 * y)
    elif case == "heavy":
        y = rng.standard_cauchy((n, 3, 2))
    elif case == "nan":
        y[rng.random(n) < 0.01, 1, 0] = np.nan
    elif case == "constant":
        y[:, 2, 1] = 4.0
    cuts = np.sort(rng.choice(np.arange(1, n), size=6, replace=False))
    chunks = np.split(y, cuts)
    positions = sorted({k - 1 for p in THREE_SIGMA for k in ranks(n, p) if 1 <= k <= n}
                       | {0, n - 1})
    got = select_order_statistics(chunks, positions)
    want = np.sort(y, axis=0)[positions]
    np.testing.assert_array_equal(got, want)


def test_a_bracket_that_misses_falls_back_to_the_exact_partition(monkeypatch):
    """With no margin the subsample's bracket misses the wanted ranks in most lanes; the
    counts catch every miss and the answer stays exact."""
    monkeypatch.setattr(quantiles, "_MARGIN_SD", -3.0)
    rng = np.random.default_rng(8)
    y = rng.standard_normal((20_000, 4))
    positions = [26, 9_999, 19_973]
    np.testing.assert_array_equal(select_order_statistics(np.split(y, [5_000, 5_001]),
                                                          positions),
                                  np.sort(y, axis=0)[positions])


def test_binomial_points_are_scipy_stats():
    """The ranks' binomial points (from scipy.special.bdtr, so that a run need not import
    scipy.stats) equal scipy.stats.binom.ppf over run counts from
    1 to 1e8 and the points of 90-99% intervals. At an exact tie (a cdf equal to q, such as
    the median of Bin(7, 0.5)) the two libraries' last bits can pick neighbours; the points
    (1 -+ level) / 2 of an interval fall on none."""
    from scipy.stats import binom

    for n in [1, 2, 3, 7, 10, 37, 100, 999, 1000, 4096, 10_007, 100_000, 1_000_000,
              12_345_678, 100_000_000]:
        for p in [*THREE_SIGMA, 1e-6, 0.001, 0.01, 0.05, 0.1, 0.25, 0.9, 0.99, 0.999]:
            for q in (0.025, 0.975, 0.005, 0.995, 0.05, 0.95):
                assert quantiles.binomial_ppf(q, n, p) == int(binom.ppf(q, n, p)), (n, p, q)
