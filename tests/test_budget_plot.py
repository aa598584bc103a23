"""The error-budget figure: one panel per method that has indices, none for a method whose
surrogate is unusable (its indices are NaN)."""

from __future__ import annotations

import numpy as np

import uqguide
from uqguide.report.budget_plot import budget_figure, has_budget
from uqguide.results.statistics import result_statistics

TIME = np.linspace(0.0, 1.0, 11)


def _step(x):
    # a step that 12 regression runs cannot fit: the PCE has no usable surrogate
    return {"time": TIME, "y": (x[:, :1] > 0.2) * TIME + 0.1 * x[:, 1:2]}


def test_a_method_without_usable_indices_gets_no_panel():
    result = uqguide.run({
        "model": {"name": "callable", "function": _step, "inputs": ["a", "b"],
                  "outputs": [{"name": "y", "kind": "series"}]},
        "inputs": [{"name": "a", "dist": "normal", "std": 1.0},
                   {"name": "b", "dist": "normal", "std": 1.0}],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 500},
                    {"name": "pce_adaptive", "label": "apce", "n_samples": 12,
                     "surrogate_draws": 2000}],
        "seed": 2})
    apce = result_statistics(result)["apce"]["y"].sobol_first
    assert apce is not None and np.isnan(apce).all()     # the case this test is about
    assert has_budget(result, "y")
    fig = budget_figure(result, "y")
    titles = [ax.get_title() for ax in fig.axes]
    assert titles == ["mc: from the Monte Carlo runs (given data)"]
    # the step in input a carries most of the variance at t = 1: its line is drawn
    assert "a" in [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
