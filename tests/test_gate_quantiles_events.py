"""The gate checks quantiles and event probabilities (issue 26), with the sealed-baseline rules.

Each regression below is built to move one quantile (one event probability) by several
combined standard errors while every moment moves by less than the gate's 4 (the arithmetic
is in each test's docstring); the same seed gives both runs the same inputs, so the
difference is the model's alone. Checked over three seeds.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import uqguide
from uqguide.errors import ResultError
from uqguide.gate.baseline import read_baseline, sealed, write_baseline
from uqguide.gate.check import check_result


def normal(x):
    """``y = a``, a ~ N(0, 1)."""
    return x[:, 0]


def event_regression(x):
    """``y = a``, but the samples in (-0.25, 0] moved up by 0.25 (past the event's 0)."""
    a = x[:, 0]
    return np.where((a > -0.25) & (a <= 0.0), a + 0.25, a)


def quantile_regression(x):
    """``y = a``, but the samples in (0.5, 0.674] moved up by 0.25 (past the upper quartile)."""
    a = x[:, 0]
    return np.where((a > 0.5) & (a <= 0.674), a + 0.25, a)


def _config(function, n: int, seed: int, **top) -> dict:
    return {"name": "gate", "model": {"name": "callable", "function": function,
                                      "inputs": ["a"], "isolate": False},
            "inputs": [{"name": "a", "dist": "normal", "std": 1.0}],
            "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": n}],
            "seed": seed, **top}


def _rows(tmp_path, regression, n: int, seed: int, **top):
    base = uqguide.run(_config(normal, n, seed, **top))
    path = write_baseline(base, tmp_path / f"b{seed}.json")
    report = check_result(uqguide.run(_config(regression, n, seed, **top)),
                          read_baseline(path))
    return report


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_an_event_probability_alone_catches_a_regression(tmp_path, seed):
    """P(y > 0) = 0.5 moves by P(-0.25 < a <= 0) = 0.099 (sd 0.007 over seeds at n = 2000);
    its combined standard error is sqrt(2 x 0.25 / 2000) = 0.016, 4 of them 0.063. The mean
    moves by 0.25 x 0.099 = 0.025 against 4 x sqrt(2 / 2000) = 0.126; the variance by
    0.25 E[2a + 0.25; -0.25 < a <= 0] ~ 0, skewness and kurtosis by less than 0.02."""
    report = _rows(tmp_path, event_regression, 2000, seed,
                   events=[{"name": "positive", "output": "y", "above": 0.0}])
    failed = [(r.stat, r.output) for r in report.failures]
    assert failed == [("probability", "positive")], report.render()
    row = next(r for r in report.rows if r.stat == "probability")
    assert row.basis.startswith("4 x combined SE")


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_quantile_alone_catches_a_regression(tmp_path, seed):
    """The upper quartile 0.674 moves to about 0.80 (+0.13); its standard error is
    sqrt(0.75 x 0.25 / 8000) / phi(0.674) = 0.015, 4 combined 0.086. The mean moves by
    0.25 x 0.0585 = 0.015 against 0.063; the std by 0.010 against 0.045; skewness by ~0.03
    against 0.16; kurtosis by ~0.05 against 0.31."""
    report = _rows(tmp_path, quantile_regression, 8000, seed, quantiles=[0.25, 0.5, 0.75])
    failed = [r.stat for r in report.failures]
    assert failed == ["q0.75"], report.render()


def test_the_same_model_passes_with_quantiles_and_events(tmp_path):
    report = _rows(tmp_path, normal, 2000, 4, quantiles="3sigma",
                   events=[{"name": "positive", "output": "y", "above": 0.0}])
    assert report.passed and {"q0.5", "probability"} <= {r.stat for r in report.rows}


@pytest.fixture
def baseline_data(tmp_path):
    cfg = _config(normal, 1000, 5, quantiles=[0.5, 0.9],
                  events=[{"name": "positive", "output": "y", "above": 0.0}])
    path = write_baseline(uqguide.run(cfg), tmp_path / "b.json")
    return json.loads(path.read_text())


def _resealed(tmp_path, data) -> str:
    """Write ``data`` sealed again (as someone who knows the digest's recipe would) and read
    it back: the consistency rules must refuse it on their own."""
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(sealed(data)))
    with pytest.raises(ResultError) as err:
        read_baseline(path)
    return str(err.value)


def test_a_quantile_interval_widened_by_hand_is_refused(tmp_path, baseline_data):
    point = baseline_data["methods"]["mc"]["outputs"]["y"]["points"][0]
    value = point["quantiles"]["q0.9"][0]
    point["quantiles"]["q0.9"] = [value, value - 1e300, value + 1e300]
    assert "quantiles.q0.9: the interval's low end" in _resealed(tmp_path, baseline_data)


def test_an_event_interval_widened_by_hand_is_refused(tmp_path, baseline_data):
    baseline_data["methods"]["mc"]["events"]["positive"]["ci"] = [0.0, 1.0]
    assert "Clopper-Pearson interval" in _resealed(tmp_path, baseline_data)


def test_quantiles_removed_by_hand_are_refused(tmp_path, baseline_data):
    for p in baseline_data["methods"]["mc"]["outputs"]["y"]["points"]:
        p.pop("quantiles")
    assert "asks for quantiles and it holds none" in _resealed(tmp_path, baseline_data)


def test_events_removed_by_hand_are_refused(tmp_path, baseline_data):
    baseline_data["methods"]["mc"].pop("events")
    assert "holds no event probability" in _resealed(tmp_path, baseline_data)
