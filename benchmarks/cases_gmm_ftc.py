"""Throughput cases of the ``gmm_ftc`` model (imported by ``benchmarks/throughput.py``).

Each sample is one whole GMM-FTC closed-loop run around the spinning target: 0.1 s control
period = RK4 step, 3,000 steps over 300 s, the 12-kernel GMM potential with its third
derivative at every step, per-step clearance / swept-collision checks; the compiled kernel
runs the samples in parallel.

- ``gmm_ftc dispersion``: the inputs and outputs of configs/gmm_ftc_dispersion.yaml (per-sample
  spin rates, so the plant matrices are per sample);
- ``gmm_ftc paper noise``: the nominal scenario with the paper's +-5 % per-period thruster
  noise (keyed streams) and only the initial position dispersed (spin common to the batch).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from uqguide.config.run_config import load_yaml

# the inputs and outputs of configs/gmm_ftc_dispersion.yaml, read from it so they cannot drift
_CONFIG = load_yaml(Path(__file__).resolve().parents[1] / "configs" / "gmm_ftc_dispersion.yaml")
DISPERSION = _CONFIG["inputs"]
OUTPUTS = _CONFIG["outputs"]

CASES: list[dict[str, Any]] = [
    {
        "label": "gmm_ftc dispersion",
        "model": "gmm_ftc",
        "params": {"thrust_noise": 0.0, "t_final": 300.0, "record_dt": 1.0},
        "inputs": DISPERSION,
        "outputs": OUTPUTS,
        "report_times": [0.0, 50.0, 100.0, 150.0, 300.0],
        "batches": [10, 100, 1000],
    },
    {
        "label": "gmm_ftc paper noise",
        "model": "gmm_ftc",
        "params": {"thrust_noise": 0.05, "t_final": 300.0, "record_dt": 1.0},
        "inputs": DISPERSION[:3],
        "outputs": OUTPUTS,
        "report_times": [0.0, 50.0, 100.0, 150.0, 300.0],
        "batches": [100],
    },
]
