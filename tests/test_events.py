"""Events: Clopper-Pearson intervals, their coverage over seeds, config errors, PCE surrogate."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from uqguide.config.run_config import validate_config
from uqguide.errors import ConfigError
from uqguide.core.events import clopper_pearson
from uqguide.driver.propagate import run
from uqguide.results.result import read_hdf5, write_hdf5

LINEAR = {"model": {"name": "linear_gaussian", "coefficients": [[1.0, 2.0, -0.5]]},
          "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                     for i in (1, 2, 3)]}
SIGMA = float(np.sqrt(1 + 4 + 0.25))


def _config(methods, events, **extra):
    return validate_config({**LINEAR, "methods": methods, "events": events, **extra})


def test_zero_of_a_thousand_has_the_exact_upper_bound():
    lo, hi = clopper_pearson(0, 1000)
    assert lo == 0.0
    assert hi == pytest.approx(1 - 0.025 ** (1 / 1000), rel=1e-9)  # closed form for k = 0
    assert abs(hi - 0.0037) <= 1e-4
    lo, hi = clopper_pearson(1000, 1000)
    assert hi == 1.0 and lo == pytest.approx(0.025 ** (1 / 1000), rel=1e-9)


def test_monte_carlo_zero_events_reports_an_upper_bound_not_zero():
    cfg = _config([{"name": "monte_carlo", "n_samples": 1000, "bootstrap": 0}],
                  [{"name": "far", "output": "y", "above": 100 * SIGMA}])
    ev = run(cfg).runs[0].estimate.events["far"]
    assert (ev.n_in, ev.n_used, ev.probability, ev.ci[0]) == (0, 1000, 0.0, 0.0)
    assert abs(ev.ci[1] - 0.0037) <= 1e-4


def _exact_cp_coverage(n: int, p: float) -> float:
    """P(the Clopper-Pearson interval of Bin(n, p) covers p), summed over k."""
    ks = np.arange(n + 1)
    cover = np.array([lo <= p <= hi for lo, hi in (clopper_pearson(int(k), n) for k in ks)])
    return float(stats.binom.pmf(ks, n, p)[cover].sum())


@pytest.mark.slow
def test_event_intervals_cover_the_true_probability_over_seeds():
    """200 seeds of a 400-run Monte Carlo of P(y > t) with p = 0.02 exactly: the number of
    intervals that cover p is Bin(200, c) with c the exact coverage (>= 0.95); 4 sigma."""
    p, n, seeds = 0.02, 400, 200
    t = SIGMA * float(stats.norm.isf(p))
    cfg = _config([{"name": "monte_carlo", "n_samples": n, "bootstrap": 0}],
                  [{"name": "tail", "output": "y", "above": t}])
    hits = 0
    for seed in range(seeds):
        ev = run(cfg.with_seed(seed)).runs[0].estimate.events["tail"]
        hits += ev.ci[0] <= p <= ev.ci[1]
    c = _exact_cp_coverage(n, p)
    assert c >= 0.95
    assert abs(hits - seeds * c) <= 4 * np.sqrt(seeds * c * (1 - c)) + 1


def test_pce_reports_the_surrogate_probability():
    """A degree-1 PCE of a linear model is exact: its draws' probability is within 4 binomial
    standard errors of the exact one."""
    t = 1.5 * SIGMA
    cfg = _config([{"name": "pce_tensor", "m": 2, "surrogate_draws": 200_000}],
                  [{"name": "tail", "output": "y", "below": -t}])
    ev = run(cfg).runs[0].estimate.events["tail"]
    exact = float(stats.norm.cdf(-1.5))
    assert ev.estimator == "surrogate" and ev.n_used == 200_000
    assert abs(ev.probability - exact) <= 4 * np.sqrt(exact * (1 - exact) / ev.n_used)
    assert ev.ci[0] <= ev.probability <= ev.ci[1]


def test_events_round_trip_through_the_result_file(tmp_path):
    cfg = _config([{"name": "monte_carlo", "n_samples": 300, "bootstrap": 0}],
                  [{"name": "tail", "output": "y", "above": SIGMA}])
    res = run(cfg)
    back = read_hdf5(write_hdf5(res, tmp_path / "r.h5")).runs[0].estimate.events
    assert back == res.runs[0].estimate.events


@pytest.mark.parametrize("events, field, words", [
    ([{"name": "a", "output": "nope", "above": 1}], "events[0].output", "not among"),
    ([{"name": "a", "output": "ramp", "above": 1}], "events[0].output", "time series"),
    ([{"name": "a", "output": "y", "above": 1, "below": 0}], "events[0]", "exactly one"),
    ([{"name": "a", "output": "y", "component": "y7", "above": 1}], "events[0].component",
     "no component"),
    ([{"name": "a", "output": "y", "above": 1}, {"name": "a", "output": "y", "below": 0}],
     "events[1].name", "used twice"),
])
def test_bad_events_name_the_field(events, field, words):
    with pytest.raises(ConfigError) as exc:
        validate_config({**LINEAR, "outputs": ["y", "ramp"], "events": events,
                         "methods": [{"name": "monte_carlo", "n_samples": 10}]})
    assert exc.value.field == field and words in str(exc.value)


@pytest.mark.parametrize("validation", [
    {"validation_runs": 400},                                    # random runs (legacy form)
    {"validation": {"n_samples": 400}},                          # stratified by the surrogate
])
@pytest.mark.slow
def test_pce_validation_runs_correct_a_biased_surrogate_probability_over_seeds(validation):
    """A degree-1 PCE of a lognormal output has a Gaussian tail: its own probability of
    y > exp(2 s) (exactly 1 - Phi(2)) is far off. With 400 validation runs, random or
    stratified, the control-variate estimate's interval (>= 95% by construction) holds the
    exact value over 40 seeds at least as often as a 95% interval may miss by chance (4
    binomial standard errors: 33 of 40)."""
    a = [0.9, 0.6, 0.3]
    s = float(np.sqrt(np.sum(np.square(a))))
    exact = float(stats.norm.sf(2.0))
    cfg = validate_config({
        "model": {"name": "lognormal", "a": a},
        "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                   for i in (1, 2, 3)],
        "events": [{"name": "hi", "output": "y", "above": float(np.exp(2 * s))}],
        "methods": [{"name": "pce_adaptive", "n_samples": 30, "degree_min": 1,
                     "degree_max": 1, "enrich": False, **validation,
                     "surrogate_draws": 20_000}]})
    hits, seeds = 0, 40
    for seed in range(seeds):
        r = run(cfg.with_seed(seed)).runs[0]
        ev = r.estimate.events["hi"]
        assert ev.estimator == "surrogate+cv" and r.n_runs == 430
        hits += ev.ci[0] <= exact <= ev.ci[1]
    assert hits >= seeds * 0.95 - 4 * np.sqrt(seeds * 0.95 * 0.05)
    plain = run(validate_config({**cfg.raw.model_dump(mode="python"), "methods": [
        {"name": "pce_adaptive", "n_samples": 30, "degree_min": 1, "degree_max": 1,
         "enrich": False, "surrogate_draws": 20_000}]})).runs[0].estimate.events["hi"]
    assert not plain.ci[0] <= exact <= plain.ci[1]  # the surrogate alone is confidently wrong
