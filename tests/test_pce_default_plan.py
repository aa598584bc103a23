"""Issue 27 item 1: the adaptive PCE's default plan (``uqguide/pce/default_plan.py``): a design
that grows until its evidence settles, within a stated budget, and a default validation set; a
config that states its run counts keeps them."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest
from click.testing import CliRunner

import uqguide
from uqguide.cli import main
from uqguide.config.run_config import validate_config
from uqguide.errors import ConfigError
from uqguide.methods.pce_adaptive import AdaptivePCE
from uqguide.pce.default_plan import (default_budget, default_validation, mean_and_std, settled,
                                       stalled)


# ---------------------------------------------------------------------------- the rules
def test_the_default_budget_and_validation_rules():
    # min(max(10 n0, 100), 1000), never below n0; max(20, ceil(n_fit / 4))
    assert [default_budget(n) for n in (10, 20, 80, 200, 1500)] == [100, 200, 800, 1000, 1500]
    assert [default_validation(n) for n in (20, 80, 81, 200, 1000)] == [20, 20, 21, 50, 250]
    # the method's own numbers, as `uqguide methods pce_adaptive` prints them
    assert AdaptivePCE.default_sizes(2) == {"n_samples": 20, "max_runs": 200, "validation": 50,
                                            "most runs": 250}
    # a config that states its run counts keeps them, and gets no validation runs unasked
    fixed = AdaptivePCE({"n_samples": 40})
    assert (fixed.budget(2), fixed.n_validation(40)) == (40, 0)
    grown = AdaptivePCE({"max_runs": 60})
    assert (grown.initial_size(2), grown.budget(2), grown.n_validation(60)) == (20, 60, 0)
    assert AdaptivePCE({"validation": {"n_samples": 0}}).n_validation(200) == 0
    assert AdaptivePCE({"validation": {"n_samples": 7}}).n_validation(200) == 7


def test_moments_settle_only_below_the_loo_target_and_within_twice_the_fit_error():
    mean, std = np.array([1.0, 2.0]), np.array([0.5, 0.5])
    now = {"y": (mean, std)}
    loo = {"y": 1e-6}  # a fit error of sqrt(1e-6) std = 5e-4: fits may differ by 1e-3
    assert settled({}, now, loo, 1e-5)                      # a first fit: nothing to compare
    assert settled({"y": (mean + 9e-4, std)}, now, loo, 1e-5)
    assert not settled({"y": (mean + 1.1e-3, std)}, now, loo, 1e-5)
    assert not settled({"y": (mean, std - 1.1e-3)}, now, loo, 1e-5)
    assert not settled({"y": (mean, std)}, now, {"y": 2e-5}, 1e-5)  # LOO above target
    # a column that does not vary (a series at t = 0): round-off is no movement
    assert settled({"y": (np.ones(1), np.zeros(1))}, {"y": (np.ones(1) + 1e-15, np.zeros(1))},
                   loo, 1e-5)
    coef = np.array([[3.0, 1.0], [0.6, 0.0], [0.8, 0.0]])
    m, s = mean_and_std(coef)
    np.testing.assert_allclose(m, [3.0, 1.0])
    np.testing.assert_allclose(s, [1.0, 0.0])


def test_validation_n_samples_1_is_refused_naming_the_field():
    cfg = {"model": {"name": "lognormal", "a": [0.3, 0.2]},
           "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                      for i in (1, 2)],
           "methods": [{"name": "pce_adaptive", "validation": {"n_samples": 1}}]}
    with pytest.raises(ConfigError, match=r"n_samples.*must be 0 \(no validation runs\) or an "
                                          r"integer >= 2\. Got 1 instead"):
        validate_config(cfg)


def test_methods_pce_adaptive_prints_the_rules_and_their_numbers():
    res = CliRunner().invoke(main, ["methods", "pce_adaptive"])
    assert res.exit_code == 0, res.output
    assert "min(max(10 n0, 100), 1000)" in res.output
    assert "max(20, ceil(n_fit / 4))" in res.output
    rows = {line.split()[0]: line.split()[1:] for line in res.output.splitlines()
            if line.strip() and line.split()[0].isdigit()}
    assert rows["2"] == ["20", "200", "50", "250"] and rows["50"] == ["500", "1000", "250",
                                                                       "1250"]
    bad = CliRunner().invoke(main, ["methods", "pce_adapt"])
    assert bad.exit_code == 2 and "unknown method 'pce_adapt'" in bad.output


# ---------------------------------------------------------------------------- end to end
A = 0.8


def _exp_plus_linear(x):
    """``exp(A x1) + x2`` of standard normals: mean ``exp(A^2 / 2)``, variance ``exp(A^2)
    (exp(A^2) - 1) + 1``; the Hermite coefficients of ``exp(A x)`` fall as ``A^k / sqrt(k!)``,
    so a 20-run first fit (degree <= 3) leaves about 1e-3 of the variance and the design must
    grow to reach the LOO target 1e-5."""
    return {"y": np.exp(A * x[:, 0]) + x[:, 1]}


def test_the_default_plan_grows_the_design_validates_it_and_stays_within_its_budget(caplog):
    cfg = {"model": {"name": "callable", "function": _exp_plus_linear, "inputs": ["x1", "x2"],
                     "nominal": [0.0, 0.0], "outputs": [{"name": "y"}]},
           "inputs": [{"name": "x1", "dist": "normal", "std": 1.0},
                      {"name": "x2", "dist": "normal", "std": 1.0}],
           # q_norm fixed only to keep the test cheap: it is no run count, so the plan is the
           # default one
           "methods": [{"name": "pce_adaptive", "label": "apce", "q_norm": 1.0},
                       {"name": "pce_adaptive", "label": "fixed", "n_samples": 20,
                        "q_norm": 1.0}],
           "seed": 3}
    with caplog.at_level(logging.INFO, logger="uqguide.methods.pce_adaptive"):
        r = uqguide.run(cfg)
    d = r.run("apce").estimate.diagnostics
    n_fit = r.run("apce").n_runs - d["n_validation"]
    assert d["n_initial"] == 20 and d["max_runs"] == 200
    assert d["n_enrichments"] >= 1 and 20 < n_fit <= 200, (d["n_enrichments"], n_fit)
    assert d["n_validation"] == max(20, math.ceil(n_fit / 4))
    assert "adding" in caplog.text
    # stopped by its evidence, not the budget: LOO at target (the moments settled with it)
    assert d["loo_error"] <= 1e-5 or n_fit == 200
    st = r.run("apce").estimate.stats["y"]
    assert st.corrected and np.isfinite(st.corrected["mean"]).all()
    # the PCE's mean and std against the closed form, within its own error: |E[S] - E[Y]| and
    # |std_S - std_Y| are at most sqrt(error) std (docs/methods.md, "Defaults that are rules"); the
    # validation error bounds it independently of the fit (three times, for its sampling)
    var = math.exp(A * A) * (math.exp(A * A) - 1.0) + 1.0
    err = max(d["loo_error"], d["validation_error.y"])
    tol = 3.0 * math.sqrt(err * var)
    assert abs(float(st.mean[0]) - math.exp(A * A / 2)) <= tol
    assert abs(float(st.std[0]) - math.sqrt(var)) <= tol
    # the config that states its run count makes exactly that, with no validation runs
    f = r.run("fixed")
    assert f.n_runs == 20 and "n_validation" not in f.estimate.diagnostics
    assert f.estimate.diagnostics["n_enrichments"] == 0


# ---------------------------------------------------------------------------- a stalled design
def test_a_design_stalls_only_on_three_fits_above_the_usable_error_without_halving():
    assert stalled(np.array([0.68, 0.73, 0.72]), 0.1)           # drift3's first fits, seed 1
    assert stalled(np.array([1e-3, 0.9, 0.6, 0.46]), 0.1)      # the last three count
    assert not stalled(np.array([0.68, 0.73]), 0.1)             # two fits: too early to tell
    assert not stalled(np.array([0.8, 0.6, 0.39]), 0.1)         # halved: still converging
    assert not stalled(np.array([0.5, 0.5, 0.09]), 0.1)         # usable now
    assert not stalled(np.array([0.5, 0.5, 0.5]), 0.6)          # usable all along


def _teeth(x):
    """A sawtooth of 10^4 teeth on [0, 1]: no polynomial the budget affords resolves it."""
    return {"y": np.modf(1e4 * x[:, 0])[0]}


#: The default plan (no run count given) on :func:`_teeth`; ``surrogate_draws`` only keeps it
#: cheap.
TEETH = {"model": {"name": "callable", "function": _teeth, "inputs": ["x"], "nominal": [0.5],
                   "outputs": [{"name": "y"}], "isolate": False},
         "inputs": [{"name": "x", "dist": "uniform", "low": 0.0, "high": 1.0}],
         "methods": [{"name": "pce_adaptive", "label": "apce", "q_norm": 1.0,
                      "surrogate_draws": 20_000}], "seed": 1}


def test_a_stalled_design_adds_the_rest_of_its_budget_at_once(caplog):
    """Issue 46 item 5's cost: a default plan whose LOO error stays above usable_error stops
    refitting on the way to its budget (10 -> 15 -> 23 -> 35 -> 100 fit runs, where it made
    10 -> 15 -> 23 -> 35 -> 53 -> 80 -> 100), and still makes every run of it."""
    with caplog.at_level(logging.INFO, logger="uqguide.methods.pce_adaptive"):
        r = uqguide.run(TEETH).run("apce")
    assert "adding the rest of the budget (65) at once" in caplog.text
    assert r.estimate.diagnostics["n_enrichments"] == 4
    assert r.n_runs == 100 + 25


@pytest.mark.slow
def test_a_stalled_design_gives_the_stepwise_statistics_bit_for_bit(monkeypatch):
    """The Sobol' points added at once are those the steps would add: every statistic is the
    stepwise design's, bit for bit."""
    fast = uqguide.run(TEETH).run("apce")
    monkeypatch.setattr("uqguide.methods.pce_adaptive.stalled", lambda *a: False)
    slow = uqguide.run(TEETH).run("apce")
    assert slow.estimate.diagnostics["n_enrichments"] == 6
    assert fast.n_runs == slow.n_runs == 125
    a, b = fast.estimate.stats["y"], slow.estimate.stats["y"]
    for k in ("mean", "std", "skewness", "kurtosis"):
        for got, want in ((a.stat(k), b.stat(k)), (a.corrected.get(k), b.corrected.get(k)),
                          (a.fallback.get(k), b.fallback.get(k))):
            np.testing.assert_array_equal(got, want)
