"""Shared fixtures: small configs written to a temporary folder."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml


@pytest.fixture
def write_config(tmp_path: Path):
    """Write a config mapping (or YAML text) to a file and return its path."""

    def _write(content, name: str = "config.yaml") -> Path:
        p = tmp_path / name
        p.write_text(content if isinstance(content, str) else yaml.safe_dump(content))
        return p

    return _write


@pytest.fixture
def lognormal_config() -> dict:
    return {
        "model": {"name": "lognormal", "a": [0.3, 0.2, 0.1]},
        "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                   for i in (1, 2, 3)],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 4000}],
        "seed": 7,
    }


@pytest.fixture(scope="session")
def decay_fmu(tmp_path_factory) -> Path:
    """The test FMU of ``tests/fmu_decay.py`` (x' = -k x), compiled once per session."""
    import shutil

    pytest.importorskip("fmpy", reason="the fmu model needs FMPy: pip install 'uqguide[fmu]'")
    if shutil.which("cc") is None:
        pytest.skip("no C compiler 'cc' on PATH to build the test FMU")
    from tests import fmu_decay

    return fmu_decay.build(tmp_path_factory.mktemp("fmu"))


@pytest.fixture
def oracle_kernels():
    """The simulators run their NumPy test oracles instead of their compiled kernels
    (``tests/oracles``; this process only)."""
    from tests.oracles import substituted

    with substituted():
        yield
