"""Sobol' indices with correlated inputs (issue 46, item 6): a PCE gives indices only of sets
holding whole correlated groups, the same quantity as the given-data and pick-freeze group
indices, and the budget's shares are fractions of the output's variance.

The model ``y = x1 + 2 x2 + 3 x3``, standard normals, ``corr(x1, x2) = 0.8``: ``Var y = 1 + 4 + 9
+ 2 * 0.8 * 2 = 17.2``; the group ``{x1, x2}`` explains ``(1 + 4 + 3.2) / 17.2 = 0.4767``, ``x3``
``9 / 17.2 = 0.5233``; no interaction, so the shares of ``x3`` and the group sum to 100%.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from uqguide.config.run_config import validate_config
from uqguide.driver.propagate import run
from uqguide.report.budget import budget_table, budget_tables, budget_text
from uqguide.results.statistics import result_statistics

GROUP, X3 = 8.2 / 17.2, 9.0 / 17.2

LINEAR = {
    "model": {"name": "linear_gaussian", "coefficients": [[1.0, 2.0, 3.0]]},
    "inputs": [{"name": n, "dist": "normal", "std": 1.0} for n in ("x1", "x2", "x3")],
    "correlations": [{"inputs": ["x1", "x2"], "matrix": [[1.0, 0.8], [0.8, 1.0]]}],
    "outputs": ["y"],
    "methods": [{"name": "pce_adaptive", "label": "apce", "n_samples": 30, "degree_max": 2,
                 "surrogate_draws": 2000}],
    "seed": 3,
}


@pytest.fixture(scope="module")
def linear():
    return run(validate_config({**LINEAR, "methods": LINEAR["methods"] + [
        {"name": "monte_carlo", "label": "mc", "n_samples": 2000},
        {"name": "sobol_saltelli", "label": "saltelli", "n_base": 500}]}))


def test_the_pce_gives_the_group_index_and_refuses_its_inputs_alone(linear):
    st = linear.run("apce").estimate.stats["y"]
    # the surrogate is exact (a linear model): the interval is the round-off floor, and it
    # holds the exact index
    lo, hi = st.sobol_group_first_ci[:, 0, 0]
    assert lo < hi and lo <= GROUP <= hi, (lo, st.sobol_group_first[0, 0], hi)
    lo, hi = st.sobol_first_ci[:, 0, 2]
    assert lo < hi and lo <= X3 <= hi
    # no interaction: the group's total index is its first-order one
    assert abs(st.sobol_group_total[0, 0] - GROUP) < 1e-9
    for name in ("sobol_first", "sobol_total", "sobol_first_ci", "sobol_total_ci"):
        assert np.isnan(np.asarray(getattr(st, name))[..., :2]).all(), name
    # the surrogate's own statistics refuse them too
    own = linear.surrogate("apce").statistics("y")
    assert np.isnan(own.sobol_first[0, :2]).all() and abs(own.sobol_first[0, 2] - X3) < 1e-9


def test_the_group_index_is_the_given_data_and_pick_freeze_quantity(linear):
    pce = linear.run("apce").estimate.stats["y"].sobol_group_first[0, 0]
    for label in ("mc", "saltelli"):
        st = linear.run(label).estimate.stats["y"]
        lo, hi = st.sobol_group_first_ci[:, 0, 0]
        assert lo <= pce <= hi, (label, lo, hi, pce)


def test_shares_are_fractions_of_the_variance_and_the_refusal_is_one_line(linear):
    tables = {b.label: b for b in budget_tables(linear)}
    b = tables["apce"]
    share = dict(zip(b.table["input"], b.table["share_%"]))
    assert abs(share["x3"] - 100 * X3) < 1e-6 and abs(share["group x1+x2"] - 100 * GROUP) < 1e-6
    assert np.isnan(share["x1"]) and np.isnan(share["x2"])
    text = budget_text(b)
    assert "shares sum to 100.0% of the variance of y[y1]; the rest, 0.0%: interactions" in text
    (line,) = [ln for ln in text.splitlines() if "no index alone" in ln]
    assert line.strip().startswith("x1, x2: no index alone (a PCE's terms")
    # the given-data table: the inputs' overlapping indices stay, without a share
    mc = dict(zip(tables["mc"].table["input"], tables["mc"].table["share_%"]))
    assert np.isnan(mc["x1"]) and np.isfinite(mc["group x1+x2"])
    assert "no index alone" not in budget_text(tables["mc"])
    # the pick-freeze footer names no "interactions" for the group's 48%
    notes = tables["saltelli"].notes
    total = float(np.nansum(tables["saltelli"].table["share_%"]))
    assert abs(total - 100.0) < 10.0, notes  # its noise: about 0.03 per index at N = 500
    assert any(n.startswith("x1, x2: no index alone (a pick-freeze") for n in notes)


def test_without_a_group_index_the_rest_is_named_the_groups_joint_part():
    result = run(validate_config({**LINEAR, "groups": {"third": ["x3"], "part": ["x1", "x3"]}}))
    st = result.run("apce").estimate.stats["y"]
    assert st.sobol_groups == ("third", "part")
    assert abs(st.sobol_group_first[0, 0] - X3) < 1e-9 and np.isnan(st.sobol_group_first[0, 1])
    (b,) = budget_tables(result)
    assert b.notes[0] == ("shares sum to 52.3% of the variance of y[y1]; the rest, 47.7%: the "
                          "joint part of correlated x1+x2 (no group index here) and interactions")
    assert any(n.startswith("group part: no index (holds part of the correlated group x1+x2")
               for n in b.notes)


def test_every_input_correlated_keeps_the_group_index():
    cfg = {**LINEAR, "model": {"name": "linear_gaussian", "coefficients": [[1.0, 2.0]]},
           "inputs": LINEAR["inputs"][:2]}
    st = run(validate_config(cfg)).run("apce").estimate.stats["y"]
    assert np.isnan(st.sobol_first).all()
    assert abs(st.sobol_group_first[0, 0] - 1.0) < 1e-9
    assert np.isfinite(st.sobol_group_first_ci).all()


def test_independent_shares_are_the_indices_not_their_normalised_sum(linear):
    # Ishigami-like: first-order indices summing to 0.8, the rest interactions
    s = dataclasses.replace(result_statistics(linear)["mc"]["y"],
                            sobol_first=np.array([[0.3, 0.5, -0.01]]), sobol_first_ci=None,
                            sobol_group_first=None)
    df = budget_table(s, ["a", "b", "c"], 0)
    np.testing.assert_allclose(df["share_%"], [50.0, 30.0, 0.0])
