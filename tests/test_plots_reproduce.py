"""scripts/reproduce_results.py: runs what it can into results/<name>/, skips the rest."""

from __future__ import annotations

import pytest
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import reproduce_results  # noqa: E402


@pytest.mark.slow
def test_runs_registered_configs_and_skips_the_others(tmp_path):
    configs = tmp_path / "configs"
    configs.mkdir()
    (configs / "lin.yaml").write_text(yaml.safe_dump({
        "model": {"name": "linear_gaussian"},
        "inputs": [{"name": f"x{i}", "dist": "normal", "std": 1.0} for i in (1, 2, 3)],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 200},
                    {"name": "pce_tensor", "label": "tpce", "m": 2}],
        "reference": "mc", "seed": 1}))
    (configs / "future.yaml").write_text(yaml.safe_dump({
        "model": {"name": "not_yet_a_model"},
        "methods": [{"name": "monte_carlo", "n_samples": 10}]}))
    out = tmp_path / "results"
    code = reproduce_results.main(["--configs", str(configs), "--out", str(out)])
    assert code == 0
    for f in ("lin.h5", "lin.txt", "lin_report.md", "lin_stats.csv", "figures/lin_y_hist.png",
              "figures/lin_ramp_y1.png", "figures/lin_cost.png"):
        assert (out / "lin" / f).is_file(), f
    assert not (out / "future").exists()
    index = (out / "index.md").read_text()
    assert "| future | skipped |" in index and "model 'not_yet_a_model' not registered" in index
    assert "| lin | done |" in index
    # Sobol' indices of y1 = x1 + 2 x2 - 0.5 x3 (independent unit normals): a_i^2 / sum a^2
    report = (out / "lin" / "lin_report.md").read_text()
    assert "| x2 | 0.7619 | 0.7619 |" in report  # 4 / 5.25, first-order = total (additive)
    # a partial rerun keeps the other rows of the index
    code = reproduce_results.main(["future", "--configs", str(configs), "--out", str(out)])
    assert code == 0
    assert "| lin | done |" in (out / "index.md").read_text()
