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


def _two_inputs(x):
    # b, the second input, dominates: a panel ranking its inputs draws it first
    return {"time": TIME, "y": 0.4 * x[:, :1] + (1.0 + TIME) * x[:, 1:2]
            + 0.1 * x[:, :1] ** 2}


def test_each_input_keeps_its_colour_and_sampled_indices_are_not_joined():
    """The Monte Carlo and PCE panels gave an input different colours (ranked per panel: a and
    b swapped), and joined the report times' Monte Carlo indices by lines as if known between."""
    from matplotlib.colors import to_hex

    from uqguide.report.figures import input_colour

    result = uqguide.run({
        "model": {"name": "callable", "function": _two_inputs, "inputs": ["a", "b"],
                  "outputs": [{"name": "y", "kind": "series"}]},
        "inputs": [{"name": "a", "dist": "normal", "std": 1.0},
                   {"name": "b", "dist": "normal", "std": 1.0}],
        "report_times": [0.0, 0.5, 1.0],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 500},
                    {"name": "pce_adaptive", "label": "apce"}],
        "seed": 2})
    fig = budget_figure(result, "y")
    assert len(fig.axes) == 2
    for ax in fig.axes:
        lines = {t.get_text(): h for h, t in zip(ax.get_legend().legend_handles,
                                                 ax.get_legend().get_texts())}
        for i, name in enumerate(["a", "b"]):
            handle = lines[name]
            colour = handle.get_color() if hasattr(handle, "get_color") else \
                handle.get_children()[0].get_color()
            assert to_hex(colour) == input_colour(i), (ax.get_title(), name)
    mc = fig.axes[0]
    assert mc.get_title().startswith("mc:")
    # markers at the 3 report times (and the last step), no line between them
    ours = {input_colour(0), input_colour(1)}
    drawn = [ln for ln in mc.get_lines() if to_hex(ln.get_color()) in ours]
    assert len(drawn) >= 2 and all(ln.get_linestyle() == "None" for ln in drawn)
