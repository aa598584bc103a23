"""Surrogate draws are in the budget (issue 26): a PCE asked for 1e8 draws is refused before
it runs, with the figure, by how much, and the setting to lower."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

import uqguide
from uqguide.cli import main
from uqguide.config.budget import MAX_SURROGATE_TERMS, estimate
from uqguide.config.catalog import studies


def _pce(draws: int) -> dict:
    return {"model": {"name": "lognormal", "a": [0.3, 0.2, 0.1]},
            "inputs": [{"name": f"x{i}", "dist": "normal", "std": 1.0} for i in (1, 2, 3)],
            "methods": [{"name": "pce_tensor", "m": 4, "surrogate_draws": draws}],
            "quantiles": "3sigma"}


def test_1e8_surrogate_draws_are_refused_with_the_figure_and_the_setting(write_config):
    res = CliRunner().invoke(main, ["validate", str(write_config(_pce(100_000_000)))])
    assert res.exit_code == 2
    assert res.stderr.strip().splitlines() == [
        "error: methods[0].surrogate_draws: pce_tensor's 1e+08 surrogate draws need an "
        "estimated 1.14e+10 basis-term evaluations (64 terms + 50 a draw), 2.28 times the "
        "limit of 5e+09 (about ten minutes of one core); lower surrogate_draws to at most "
        "43,859,649"]


def test_the_largest_draws_it_names_pass(write_config):
    res = CliRunner().invoke(main, ["validate", str(write_config(_pce(43_859_649)))])
    assert res.exit_code == 0, res.output


@pytest.mark.slow  # (8 s: every shipped study's model is built)
def test_every_shipped_study_is_within_the_surrogate_budget():
    for study in studies():
        budget = estimate(uqguide.load_config(study.name))
        worst = max((m.surrogate_work for m in budget.methods), default=0.0)
        assert worst <= MAX_SURROGATE_TERMS / 5, (study.name, worst)
