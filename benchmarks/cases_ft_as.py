"""Throughput cases of the ``ft_as`` model (imported by ``benchmarks/throughput.py``).

Each sample is one whole 6-DOF closed-loop run (3000 s, RK4 + zero-order hold, all metrics
accumulated per step) integrated by the compiled kernel for the whole batch at once:

- ``ft_as dispersion h=0.1``: the dispersion config (configs/ft_as_dispersion.yaml), 30 000
  steps per run;
- ``ft_as paper h=0.01``: the paper-reproduction step, 300 000 steps per run.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from uqguide.config.run_config import load_yaml

# the inputs and outputs of the shipped dispersion config, read from it so they cannot drift
_CONFIG = load_yaml(Path(__file__).resolve().parents[1] / "configs" / "ft_as_dispersion.yaml")
DISPERSION = _CONFIG["inputs"]
OUTPUTS = _CONFIG["outputs"]

CASES: list[dict[str, Any]] = [
    {
        "label": "ft_as dispersion h=0.1",
        "model": "ft_as",
        "params": {"step": 0.1, "duration": 3000.0, "output_interval": 10.0},
        "inputs": DISPERSION,
        "outputs": OUTPUTS,
        "report_times": [0.0, 500.0, 1000.0, 2000.0, 3000.0],
        "batches": [10, 100],
    },
    {
        "label": "ft_as paper h=0.01",
        "model": "ft_as",
        "params": {"step": 0.01, "duration": 3000.0, "output_interval": 10.0},
        "inputs": DISPERSION,
        "outputs": OUTPUTS,
        "report_times": [0.0, 500.0, 1000.0, 2000.0, 3000.0],
        "batches": [4],
    },
]
