"""docs/your-model.md runs as written: its files in an empty folder, its commands there, with
no PYTHONPATH; and the callable model's function objects, module lookup and total failure."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

import uqguide

DOC = Path(__file__).resolve().parents[1] / "docs" / "your-model.md"
UQGUIDE = str(Path(sys.executable).parent / "uqguide")


def _env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}


def _blocks() -> list[tuple[str, str]]:
    return re.findall(r"```(\w+)\n(.*?)```", DOC.read_text(), re.S)


def _write_files(folder: Path) -> list[str]:
    written = []
    for _, body in _blocks():
        first = body.splitlines()[0]
        if first.startswith("# file: "):
            (folder / first[len("# file: "):].strip()).write_text(body)
            written.append(first[len("# file: "):].strip())
    return written


def _commands() -> list[str]:
    return [line for lang, body in _blocks() if lang == "bash" for line in body.splitlines()
            if line.startswith("uqguide ")]


@pytest.mark.slow
def test_the_guide_runs_from_an_empty_folder_without_pythonpath(tmp_path):
    assert _write_files(tmp_path) == ["oscillator.py", "oscillator.yaml", "study.py"]
    commands = _commands()
    assert commands == ["uqguide validate oscillator.yaml",
                        "uqguide run oscillator.yaml --out results"]
    for cmd in commands:
        p = subprocess.run([UQGUIDE, *cmd.split()[1:]], cwd=tmp_path, env=_env(),
                           capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, p.stderr
    assert "Failed runs" in p.stdout and "non-finite output value" in p.stdout
    result = uqguide.read_result(tmp_path / "results" / "oscillator.h5")
    run = result.run("mc2000")
    # zeta ~ U(0.05, 1.05): P(zeta >= 1) = 5%; 2000 runs: 4 binomial standard errors
    assert abs(run.n_failed - 100) <= 4 * np.sqrt(2000 * 0.05 * 0.95)
    assert result.config["model"]["module_dir"] == str(tmp_path.resolve())
    pos = result.output("position")
    assert pos.unit == "m" and pos.components == ("x", "y")
    # at t = 0 the position is (x0, y0): x mean within 4 standard errors of E[x0] = 1, y exact
    s = run.estimate.stats["position"]
    assert abs(s.mean[0, 0] - 1.0) <= 4 * s.sem[0, 0]
    assert s.mean[0, 1] == pytest.approx(0.5, abs=1e-15)

    p = subprocess.run([sys.executable, "study.py"], cwd=tmp_path, env=_env(),
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    # the same config and seed from Python: the same failures as the command line
    assert p.stdout.splitlines()[0] == f"{run.n_failed} of 2000 runs failed"


def test_the_module_is_found_beside_the_config_from_another_folder(tmp_path):
    _write_files(tmp_path)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    p = subprocess.run([UQGUIDE, "validate", str(tmp_path / "oscillator.yaml")], cwd=elsewhere,
                       env=_env(), capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr


def _failing_config(folder: Path) -> Path:
    (folder / "always_fails.py").write_text(
        "def f(x):\n    raise RuntimeError('solver diverged')\n")
    cfg = {"model": {"name": "callable", "function": "always_fails:f", "inputs": ["a"],
                     "outputs": ["y", {"name": "s", "kind": "series"}]},
           "inputs": [{"name": "a", "dist": "normal", "mean": 0.0, "std": 1.0}],
           "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 64}]}
    path = folder / "fails.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


@pytest.mark.slow
def test_a_function_failing_on_every_sample_is_exit_1_with_a_failure_table(tmp_path):
    path = _failing_config(tmp_path)
    p = subprocess.run([UQGUIDE, "run", path.name, "--out", "out"], cwd=tmp_path, env=_env(),
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 1, p.stderr
    assert "Traceback" not in p.stderr
    assert "error: mc: every one of the 64 runs failed, no statistics" in p.stderr
    table = p.stderr[p.stderr.index("Failed runs"):].splitlines()
    assert table[1].split() == ["label", "runs", "failed", "share", "reason", "count"]
    assert table[2].split() == ["mc", "64", "64", "100%", "RuntimeError:", "solver",
                                "diverged", "64"]
    assert not (tmp_path / "out" / "fails.h5").exists()  # no statistics: no result file


def test_a_function_object_is_a_model_from_python():
    def f(x):
        return {"y": x[:, 0] * 2.0 + 1.0}

    result = uqguide.run({
        "model": {"name": "callable", "function": f, "inputs": ["a"], "outputs": ["y"]},
        "inputs": [{"name": "a", "dist": "normal", "mean": 0.0, "std": 1.0}],
        "methods": [{"name": "pce_tensor", "label": "t", "m": 2}]})
    s = result.run("t").estimate.stats["y"]
    # y = 2a + 1, a ~ N(0, 1): mean 1, std 2, exact for a 2-node Gauss-Hermite rule
    np.testing.assert_allclose([s.mean[0], s.std[0]], [1.0, 2.0], rtol=1e-12)
    assert result.config["model"]["function"].endswith(
        "test_a_function_object_is_a_model_from_python.<locals>.f")
