"""The ft_as configs validate against the model (and the full config schema where available)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from uqguide.config.run_config import load_config
from uqguide.models.ft_as import FTAS
from uqguide.config.registry import METHODS

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


@pytest.mark.parametrize("name", ["ft_as_nominal.yaml", "ft_as_dispersion.yaml"])
def test_config_matches_the_model(name):
    raw = yaml.safe_load((CONFIGS / name).read_text())
    params = {k: v for k, v in raw["model"].items() if k != "name"}
    model = FTAS(params)
    assert raw["model"]["name"] == model.name
    assert {i["name"] for i in raw["inputs"]} <= set(model.input_names())
    assert set(raw.get("outputs", [])) <= {o.name for o in model.outputs()}
    if all(m["name"] in METHODS for m in raw["methods"]):
        cfg = load_config(CONFIGS / name)
        assert cfg.model.name == "ft_as"


def test_nominal_config_is_the_paper_scenario():
    cfg = load_config(CONFIGS / "ft_as_nominal.yaml")
    assert cfg.model.params == FTAS().params  # every setting at the paper's default
