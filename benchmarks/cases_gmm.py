"""Throughput cases of the ``gmm_proximity`` model (imported by ``benchmarks/throughput.py``).

Each sample is one whole 800 s sampled-data run (800 control periods, 10 RK4 sub-steps each,
swept collision tests and clearances at every sub-step) of GMM-NTSMC next to the [W] chief.
The inputs, outputs and model parameters are read from the dispersion configs, so the
benchmark measures exactly what ``uqguide run`` evaluates:

- ``gmm_proximity E``: configs/gmm_dispersion.yaml (published GMM, 11 inputs, per-sample GMM
  kernels because the GMM shift and covariance scale are dispersed);
- ``gmm_proximity F2``: configs/gmm_dispersion_f2.yaml (variance-floored GMM, same inputs).

The compiled kernel runs the blocks of samples in parallel threads; ``--param threads=1`` on
one thread.

    python benchmarks/throughput.py --model gmm_proximity
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from uqguide.config.run_config import load_yaml

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def _case(label: str, config: str, batches: list[int]) -> dict[str, Any]:
    raw = load_yaml(CONFIGS / config)
    return {
        "label": label,
        "model": raw["model"]["name"],
        "params": {k: v for k, v in raw["model"].items() if k != "name"},
        "inputs": raw["inputs"],
        "outputs": raw["outputs"],
        "report_times": raw.get("report_times"),
        "batches": batches,
    }


CASES: list[dict[str, Any]] = [
    _case("gmm_proximity E", "gmm_dispersion.yaml", [100, 1_000, 10_000]),
    _case("gmm_proximity F2", "gmm_dispersion_f2.yaml", [100, 1_000, 10_000]),
]
