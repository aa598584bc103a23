"""Derived outputs through the config: a PCE method fits the carriers, MC uses the model's value."""

from __future__ import annotations

import pytest
import numpy as np

from uqguide.config.run_config import validate_config
from uqguide.driver.propagate import run


def _config(methods):
    # Table 4 case of the paper, reduced: position, velocity and target maneuver only
    return {
        "model": {"name": "ftcapn", "t_final": 95.0},
        "inputs": [{"name": n, "dist": "normal", "std": s} for n, s in
                   (("dx", 15.0), ("dvy", 3.0), ("at_theta", 0.1))],
        "outputs": ["zem", "t_stop"],
        "methods": methods,
        "seed": 3,
    }


@pytest.mark.slow
def test_pce_gets_the_miss_distance_through_the_stop_state_surrogate():
    cfg = validate_config(_config([
        {"name": "monte_carlo", "label": "mc", "n_samples": 20000},
        {"name": "pce_adaptive", "label": "apce", "n_samples": 120, "max_runs": 120,
         "degree_max": 5, "surrogate_draws": 200000},
    ]))
    result = run(cfg)
    apce, mc = result.run("apce"), result.run("mc")
    # only the requested outputs reach the result, though the carriers were evaluated
    assert set(apce.estimate.stats) == {"zem", "t_stop"} == set(apce.scalars)
    assert sorted(n.split("[")[0] for n in apce.estimate.scalar_names) == ["t_stop", "zem"]
    assert apce.estimate.scalar_cov.shape == (2, 2)
    assert apce.estimate.stats["zem"].moments_method == "surrogate-sampling"
    assert mc.estimate.stats["zem"].moments_method == "sample"
    # the surrogate-sampled moments agree with MC within 4 of MC's standard errors
    s, m = apce.estimate.stats["zem"], mc.estimate.stats["zem"]
    assert abs(s.mean[0] - m.mean[0]) < 4 * m.sem[0]
    for stat in ("std", "skewness", "kurtosis"):
        se = (m.ci[stat][1, 0] - m.ci[stat][0, 0]) / (2 * 1.96)
        assert abs(s.stat(stat)[0] - m.stat(stat)[0]) < 4 * se, stat


def test_derived_map_equals_the_models_own_output():
    from uqguide.models.ftcapn import FTCAPN

    model = FTCAPN({"t_final": 95.0})
    names = ["dx", "dvy", "at_theta", "at_r"]
    x = np.random.default_rng(0).normal(size=(200, 4)) * [15.0, 3.0, 0.1, 0.1]
    out = model.evaluate(x, names, ["zem", "zem_eq15", "r_at_stop", "v_at_stop"])
    inputs = dict(zip(names, x.T))
    for name, d in model.derived_outputs().items():
        carriers = {c: out.scalars[c] for c in d.carriers}
        np.testing.assert_allclose(d.function(carriers, inputs), out.scalars[name], rtol=1e-9)
