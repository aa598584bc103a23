"""The gmm_ftc configs validate, and the dispersion study runs through the pipeline.

The full study (1000 MC runs + adaptive PCE) is for `uqguide run`; here a shortened copy (20 s,
a handful of runs) checks the wiring: every configured output is produced and the MC mean of
``collided`` is the fraction of colliding runs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from uqguide.config.run_config import load_config, validate_config
from uqguide.driver.propagate import run

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


@pytest.mark.parametrize("name", ["gmm_ftc_nominal.yaml", "gmm_ftc_dispersion.yaml",
                                  "gmm_ftc_dispersion_smooth.yaml"])
def test_configs_validate(name):
    cfg = load_config(CONFIGS / name)
    assert cfg.model.name == "gmm_ftc"


def test_dispersion_config_runs_with_monte_carlo():
    data = yaml.safe_load((CONFIGS / "gmm_ftc_dispersion.yaml").read_text())
    data["model"].update(t_final=20.0)
    data["report_times"] = [0, 10, 20]
    data["methods"] = [{"name": "monte_carlo", "label": "mc", "n_samples": 6}]
    data.pop("reference", None)
    cfg = validate_config(data)
    result = run(cfg)
    mc = result.run("mc")
    assert mc.failed.sum() == 0
    assert set(mc.estimate.stats) == set(cfg.outputs)
    collided = mc.scalars["collided"][:, 0]
    assert set(np.unique(collided)) <= {0.0, 1.0}
    assert mc.estimate.stats["collided"].mean[0] == pytest.approx(collided.mean())
