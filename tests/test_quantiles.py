"""Quantiles: order statistics with distribution-free intervals (MC), surrogate draws (PCE)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from uqguide.config.run_config import validate_config
from uqguide.errors import ConfigError
from uqguide.methods import monte_carlo
from uqguide.driver.propagate import run
from uqguide.stats import quantiles
from uqguide.stats.quantiles import (
    THREE_SIGMA, coverage, order_statistic_quantiles, ranks, select_order_statistics,
)
from uqguide.results.result import read_hdf5, write_hdf5

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


@pytest.mark.slow
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
    monkeypatch.setattr(monte_carlo, "QUANTILE_ALL_FLOATS", 10)
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


@pytest.mark.slow
def test_envelope_figure_and_events_section_are_written(tmp_path):
    from uqguide.report.plots import write_figures
    from uqguide.report.tables import render_markdown

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


def _sorted_positions(n):
    return sorted({k - 1 for p in THREE_SIGMA for k in ranks(n, p) if 1 <= k <= n}
                  | {0, n // 3, n - 1})


@pytest.mark.parametrize("seed", range(24))
def test_selection_equals_the_full_sort_across_block_boundaries(monkeypatch, seed):
    """Random lane counts, run counts and chunk widths against narrow blocks, so that chunks
    are split, joined and cut at every kind of boundary (a chunk narrower, wider and as wide
    as a block, a run count a multiple of it); ties, NaN (also among the wanted ranks) and a
    few lanes; the answer is the sorted union's, bit for bit."""
    rng = np.random.default_rng(100 + seed)
    width = int(rng.choice([64, 100, 256]))
    monkeypatch.setattr(quantiles, "_BLOCK_COLUMNS", width)
    n_lanes = int(rng.integers(1, 12))
    if seed % 4 == 3:  # many lanes: narrower blocks, chunks cut but not joined
        monkeypatch.setattr(quantiles, "_BLOCK_VALUES", 7 * width)
        monkeypatch.setattr(quantiles, "_MIN_COLUMNS", width // 2)
        n_lanes = int(rng.integers(15, 30))
    n = width * int(rng.integers(10, 40)) if seed % 3 == 0 else int(rng.integers(1024, 12_000))
    y = rng.standard_normal((n_lanes, n))
    if seed % 5 == 1:
        y = np.round(y, 1)  # heavy ties: brackets share their end values
    if seed % 5 == 2:
        y[0, rng.random(n) < 0.01] = np.nan  # NaN in a lane (sort last)
        y[-1, rng.random(n) < 0.3] = np.nan  # the upper quantiles' ranks fall among the NaN
    widths = rng.choice([1, width - 1, width, width + 1, 3 * width + 7, 37], size=n)
    cuts = np.cumsum(widths)
    cuts = cuts[cuts < n]
    lanes = [np.ascontiguousarray(c) for c in np.split(y, cuts, axis=1)]
    positions = _sorted_positions(n)
    np.testing.assert_array_equal(quantiles.select_lanes(lanes, positions),
                                  np.sort(y, axis=1)[:, positions].T)


@pytest.mark.parametrize("at", [0.2, 0.39, 0.41, 0.5, 0.9])
def test_one_bracket_reaching_into_nan_stays_exact(at):
    """A lone wanted rank near where a lane's NaN begin (they sort last): the subsample's
    bracket may end on a NaN, which must not turn into a bracket of the wrong values."""
    rng = np.random.default_rng(11)
    n = 64_000
    y = rng.standard_normal((2, n))
    y[:, rng.permutation(n)[:int(0.6 * n)]] = np.nan
    positions = [int(at * n)]
    np.testing.assert_array_equal(quantiles.select_lanes(np.split(y, [5000, 40_000], axis=1),
                                                         positions),
                                  np.sort(y, axis=1)[:, positions].T)


@pytest.mark.parametrize("widths, width", [([5, 5, 5], 4), ([3, 9, 1, 1, 8, 2], 4),
                                           ([4, 4], 4), ([17], 4), ([1] * 11, 3), ([2], 8)])
@pytest.mark.parametrize("join", [True, False])
def test_blocks_cover_the_runs_in_order(widths, width, join):
    """Joined, every block but the last is exactly ``width`` wide; not, each is a piece of
    one chunk; either way they join to the chunks' union."""
    rng = np.random.default_rng(3)
    lanes = [rng.standard_normal((2, w)) for w in widths]
    blocks = [b.copy() for b in quantiles._blocks(lanes, width, join)]  # the buffer is reused
    assert all(1 <= b.shape[1] <= width for b in blocks)
    if join:
        assert all(b.shape[1] == width for b in blocks[:-1])
    else:
        assert len(blocks) == sum(-(-w // width) for w in widths)
    np.testing.assert_array_equal(np.concatenate(blocks, axis=1),
                                  np.concatenate(lanes, axis=1))


def test_a_bracket_that_misses_falls_back_across_blocks(monkeypatch):
    """The fallback stays exact with the runs cut into many blocks, for ties as well."""
    monkeypatch.setattr(quantiles, "_MARGIN_SD", -3.0)
    monkeypatch.setattr(quantiles, "_BLOCK_COLUMNS", 1000)
    rng = np.random.default_rng(9)
    y = np.floor(4 * rng.standard_normal((3, 20_500)))
    y[1] = rng.standard_normal(20_500)
    lanes = np.split(y, [700, 701, 9_000], axis=1)
    positions = _sorted_positions(20_500)
    np.testing.assert_array_equal(quantiles.select_lanes(lanes, positions),
                                  np.sort(y, axis=1)[:, positions].T)


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
