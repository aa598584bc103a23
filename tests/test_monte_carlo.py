"""Monte Carlo against closed forms, within 4 standard errors, and its reproducibility."""

from __future__ import annotations

import numpy as np
import pytest

from uqguide.config.run_config import validate_config
from uqguide.driver.execution import SerialExecutor
from uqguide.models.benchmarks import LinearGaussian, Lognormal
from uqguide.driver.propagate import run


def _se_from_ci(ci: np.ndarray) -> np.ndarray:
    return (ci[1] - ci[0]) / (2 * 1.96)


@pytest.mark.parametrize("sampling", ["random", "lhs", "sobol"])
def test_lognormal_four_moments_within_4_standard_errors(lognormal_config, sampling):
    cfg = dict(lognormal_config)
    cfg["methods"] = [{"name": "monte_carlo", "label": "mc", "n_samples": 20000,
                       "sampling": sampling}]
    result = run(validate_config(cfg))
    s = result.run("mc").estimate.stats["y"]
    exact = Lognormal().exact_moments()
    assert abs(s.mean[0] - exact["mean"]) < 4 * s.sem[0]
    for stat in ("std", "skewness", "kurtosis"):
        se = _se_from_ci(s.ci[stat])[0]
        assert abs(s.stat(stat)[0] - exact[stat]) < 4 * se, (stat, s.stat(stat)[0], exact[stat])


def test_linear_gaussian_mean_covariance_skew_kurtosis():
    cfg = {
        "model": {"name": "linear_gaussian"},
        "inputs": [{"name": "x1", "dist": "normal", "mean": 1.0, "std": 2.0},
                   {"name": "x2", "dist": "normal", "mean": -1.0, "std": 0.5},
                   {"name": "x3", "dist": "normal", "mean": 0.0, "std": 1.0}],
        "outputs": ["y", "ramp"],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 20000, "bootstrap": 0}],
        "seed": 4,
    }
    result = run(validate_config(cfg))
    n = 20000
    s = result.run("mc").estimate.stats["y"]
    mean, cov = LinearGaussian().exact_mean_cov(np.array([1.0, -1.0, 0.0]),
                                                np.diag([4.0, 0.25, 1.0]))
    assert np.all(np.abs(s.mean - mean) < 4 * np.sqrt(np.diag(cov) / n))
    # var(c_ij estimate) = (c_ii c_jj + c_ij^2) / n for Gaussian data
    se_cov = np.sqrt((np.outer(np.diag(cov), np.diag(cov)) + cov**2) / n)
    assert np.all(np.abs(s.cov - cov) < 4 * se_cov)
    assert np.all(np.abs(s.skewness) < 4 * np.sqrt(6 / n))
    assert np.all(np.abs(s.kurtosis - 3) < 4 * np.sqrt(24 / n))
    # the series output t * y: std grows linearly in t, and is exactly 0 (skew NaN) at t = 0
    r = result.run("mc").estimate.stats["ramp"]
    t = result.time
    np.testing.assert_allclose(r.std, t[:, None] * s.std[None, :], rtol=1e-9, atol=1e-15)
    assert np.isnan(r.skewness[0]).all()
    # joint covariance of stacked scalars is the covariance of y
    np.testing.assert_allclose(result.run("mc").estimate.scalar_cov, s.cov, rtol=1e-12)


def test_same_seed_same_numbers_whatever_the_batch_size(lognormal_config):
    cfg = validate_config(lognormal_config)
    a = run(cfg, SerialExecutor(batch_size=4000)).run("mc")
    b = run(cfg, SerialExecutor(batch_size=333)).run("mc")
    np.testing.assert_array_equal(a.x, b.x)
    for k in ("mean", "std", "skewness", "kurtosis"):
        np.testing.assert_array_equal(a.estimate.stats["y"].stat(k), b.estimate.stats["y"].stat(k))
    np.testing.assert_array_equal(a.estimate.stats["y"].ci["kurtosis"],
                                  b.estimate.stats["y"].ci["kurtosis"])


def test_other_seed_other_numbers_and_label_streams_are_independent(lognormal_config):
    base = validate_config(lognormal_config)
    other = base.with_seed(8)
    assert not np.array_equal(run(base).run("mc").x, run(other).run("mc").x)
    cfg = dict(lognormal_config)
    cfg["methods"] = [{"name": "monte_carlo", "label": "first", "n_samples": 50},
                      {"name": "monte_carlo", "label": "mc", "n_samples": 4000}]
    # adding a method before 'mc' does not change mc's samples (streams keyed by label)
    np.testing.assert_array_equal(run(validate_config(cfg)).run("mc").x, run(base).run("mc").x)


def test_failed_samples_are_counted_and_excluded(write_config):
    cfg = {
        "model": {"name": "callable", "function": "tests.fixtures_models:sqrt_of_x",
                  "inputs": ["x"], "outputs": ["y"]},
        "inputs": [{"name": "x", "dist": "normal", "mean": 0.5, "std": 1.0}],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 2000, "bootstrap": 0}],
        "seed": 2,
    }
    result = run(validate_config(cfg))
    r = result.run("mc")
    expected_failed = int(np.sum(r.x[:, 0] < 0))
    assert r.n_failed == expected_failed > 0
    ok = r.x[:, 0] >= 0
    np.testing.assert_allclose(r.estimate.stats["y"].mean[0], np.sqrt(r.x[ok, 0]).mean())
    assert r.estimate.stats["y"].n_used == ok.sum()
    assert "non-finite output value" in r.estimate.diagnostics["failure_reasons"]


def test_a_chunk_that_raises_fails_only_its_raising_samples():
    cfg = {
        "model": {"name": "callable", "function": "tests.fixtures_models:raise_if_large",
                  "inputs": ["x"], "outputs": ["y"]},
        "inputs": [{"name": "x", "dist": "uniform", "low": 0.0, "high": 1.0}],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 1000, "bootstrap": 0}],
        "batch_size": 100,
        "seed": 7,
    }
    r = run(validate_config(cfg)).run("mc")
    # a call raises when it holds a value above 0.999: the call is split until the raising
    # samples are alone, so exactly those fail and the rest of their chunk keeps its values
    large = r.x[:, 0] > 0.999
    assert large.sum() == 3
    np.testing.assert_array_equal(r.failed, large)
    assert set(r.reasons[large]) == {"ValueError: value above 0.999 in this chunk"}
    np.testing.assert_array_equal(r.scalars["y"][~large, 0], 2 * r.x[~large, 0])


def test_quantiles_are_the_same_on_one_thread_and_on_two(monkeypatch):
    """The outputs' quantiles are selected on a thread pool; the selection is exact, so the
    numbers are the sorted values' whatever the thread count, bit for bit."""
    import threading

    from uqguide.methods import monte_carlo as mc
    from uqguide.stats.quantiles import ranks

    cfg = validate_config({
        "model": {"name": "linear_gaussian"},
        "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                   for i in (1, 2, 3)],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 5000,
                     "chunk_size": 512, "bootstrap": 0}],
        "quantiles": "3sigma", "seed": 5})
    where: list[str] = []

    def traced(f):
        def call(*args, **kwargs):
            where.append(threading.current_thread().name)
            return f(*args, **kwargs)
        return call

    monkeypatch.setattr(mc, "lane_quantiles", traced(mc.lane_quantiles))
    monkeypatch.setattr(mc, "order_statistic_quantiles", traced(mc.order_statistic_quantiles))
    got = {}
    for threads in (1, 2):
        monkeypatch.setattr(mc, "QUANTILE_THREADS", threads)
        where.clear()
        got[threads] = run(cfg).run("mc")
        assert len(where) == 2  # y and ramp
        on_pool = [w.startswith("quantiles") for w in where]
        assert not any(on_pool) if threads == 1 else all(on_pool)
    for name in ("y", "ramp"):
        one, two = (got[t].estimate.stats[name] for t in (1, 2))
        assert np.array_equal(one.quantiles, two.quantiles)
        assert np.array_equal(one.ci_quantiles, two.ci_quantiles)
        assert np.isfinite(one.ci_quantiles).all()
    y = np.sort(got[2].scalars["y"], axis=0)
    st = got[2].estimate.stats["y"]
    for i, p in enumerate(st.quantile_levels):
        r, lo, hi = ranks(5000, p)
        np.testing.assert_array_equal(st.quantiles[i], y[r - 1])
        np.testing.assert_array_equal(st.ci_quantiles[:, i], [y[lo - 1], y[hi - 1]])
