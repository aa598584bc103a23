"""Grouped first-order indices: closed form for a correlated pair, the config's ``groups`` and
their default (each correlated group), and the budget table and file that carry them."""

from __future__ import annotations

import numpy as np
import pytest

from uqguide.config.run_config import validate_config
from uqguide.driver.propagate import run
from uqguide.errors import ConfigError
from uqguide.report.budget import budget_tables, budget_text
from uqguide.stats.sobol_given_data import first_order_indices
from uqguide.stats.sobol_groups import group_indices


def _correlated(seed: int, n: int = 2000) -> np.ndarray:
    """(x1, x2) standard normals with correlation 0.8, x3 and x4 independent of them."""
    z = np.random.default_rng(seed).normal(size=(n, 4))
    z[:, 1] = 0.8 * z[:, 0] + 0.6 * z[:, 1]
    return z


@pytest.mark.parametrize("seed", range(3))
def test_a_correlated_pair_explains_its_joint_variance(seed):
    # y = x1 + x2 + x3 + x4 / 2: Var(x1 + x2) = 3.6 of 4.85; the one-input indices overlap
    # (each carries its partner: (1 + 0.8)^2 / 4.85 = 0.668), the group's does not
    x = _correlated(seed)
    y = x @ np.array([1.0, 1.0, 1.0, 0.5])
    first, ci = group_indices(x, y[None, :], [(0, 1), (3,)])
    exact = np.array([3.6, 0.25]) / 4.85
    se = (ci[1, 0] - ci[0, 0]) / (2 * 1.96)
    assert np.all(np.abs(first[0] - exact) < 4 * se), (first[0], exact, se)
    one = first_order_indices(x, y[None, :])
    assert np.all(np.abs(one.first[0, :2] - 3.24 / 4.85) < 4 * one.se[0, :2])
    # a group of one input is the one-input estimator
    assert first[0, 1] == one.first[0, 3]


LINEAR = {
    "model": {"name": "linear_gaussian", "coefficients": [[1.0, 1.0, 1.0]]},
    "inputs": [{"name": "x1", "dist": "normal", "std": 1.0},
               {"name": "x2", "dist": "normal", "std": 1.0},
               {"name": "x3", "dist": "normal", "std": 1.0}],
    "correlations": [{"inputs": ["x1", "x2"], "matrix": [[1.0, 0.8], [0.8, 1.0]]}],
    "outputs": ["y"],
    "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 1000}],
    "seed": 2,
}


def test_a_correlated_group_is_a_group_by_default_and_reaches_the_table_and_file(tmp_path):
    from uqguide.results.result import read_hdf5, write_hdf5

    result = run(validate_config(LINEAR))
    st = result.run("mc").estimate.stats["y"]
    assert st.sobol_groups == ("x1+x2",)
    # Var(x1 + x2) = 3.6 of 4.6
    se = (st.sobol_group_first_ci[1] - st.sobol_group_first_ci[0]) / (2 * 1.96)
    assert abs(st.sobol_group_first[0, 0] - 3.6 / 4.6) < 4 * se[0, 0]
    text = budget_text(budget_tables(result)[0])
    assert "group x1+x2" in text
    back = read_hdf5(write_hdf5(result, tmp_path / "r.h5")).run("mc").estimate.stats["y"]
    assert back.sobol_groups == ("x1+x2",)
    assert np.array_equal(back.sobol_group_first, st.sobol_group_first)
    assert np.array_equal(back.sobol_group_first_ci, st.sobol_group_first_ci)


def test_the_config_names_its_groups():
    cfg = validate_config({**LINEAR, "groups": {"nav": ["x1", "x2", "x3"], "third": ["x3"]}})
    assert cfg.methods[0].context.groups == (("nav", (0, 1, 2)), ("third", (2,)))


@pytest.mark.parametrize("groups, message", [
    ({"nav": ["x1", "x9"]}, "groups.nav[1]: 'x9' is not an uncertain input of this config"),
    ({"nav": []}, "groups.nav: a group needs at least one input (got [])"),
    ({"nav": ["x1", "x1"]}, "groups.nav[1]: 'x1' is listed twice"),
    ({"9 lives": ["x1"]}, "groups: group name '9 lives' must start with a letter"),
])
def test_a_bad_group_is_a_config_error_naming_it(groups, message):
    with pytest.raises(ConfigError) as err:
        validate_config({**LINEAR, "groups": groups})
    assert str(err.value).startswith(message)
