"""A method whose fit fails after its runs keeps them: the result file holds the runs and the
reason, the run folder stays for ``--resume``, and ``uqguide run`` exits 1 with one line per
failed method (issue 46, "no lost runs")."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.errors import MethodError, MethodsFailed
from uqguide.methods.pce_adaptive import AdaptivePCE
from uqguide.results.result import read_hdf5

from .failing_models import mc_config


def _config(tmp_path, method: dict):
    raw = mc_config("tests.failing_models:counted_clean", 40, 20)
    raw["model"]["isolate"] = False  # counted in this process
    raw["model"]["outputs"] = ["y", {"name": "path", "kind": "series"}]
    raw["methods"] = [method]
    path = tmp_path / "fits.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.fixture
def calls(monkeypatch):
    from tests import failing_models

    monkeypatch.setitem(failing_models._calls, "n", 0)
    return failing_models._calls


@pytest.mark.slow
def test_a_fit_raising_after_its_runs_writes_them_and_resumes(tmp_path, monkeypatch, calls):
    def overflow(self, *args):
        raise ValueError("dimensions are too large")

    cfg = _config(tmp_path, {"name": "pce_adaptive", "label": "apce", "n_samples": 40})
    out = tmp_path / "out"
    monkeypatch.setattr(AdaptivePCE, "_fit_now", overflow)
    res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out)])
    assert res.exit_code == 1, (res.output, res.exception)
    assert "Traceback" not in res.output
    assert res.stderr.strip().splitlines()[-1] == (
        "error: apce: ValueError: dimensions are too large (the traceback: uqguide -vv run CONFIG)")
    assert f"and {out / 'fits.run'} (every output; `uqguide run {cfg} --resume" in res.stderr
    n_calls = calls["n"]
    assert n_calls > 0
    kept = read_hdf5(out / "fits.h5").run("apce")
    assert not kept.success and "dimensions are too large" in kept.message
    assert kept.n_runs == 40 and kept.scalars["y"].shape == (40, 1)
    np.testing.assert_array_equal(kept.scalars["y"][:, 0], kept.x[:, 0] + kept.x[:, 1] ** 2)
    assert (out / "fits.run").is_dir()  # the series' histories too: resumable
    # the fit fixed, --resume fits the same runs without calling the model
    monkeypatch.undo()
    monkeypatch.setitem(calls, "n", n_calls)
    resumed = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out), "--resume"])
    assert resumed.exit_code == 0, resumed.output
    assert calls["n"] == n_calls
    done = read_hdf5(out / "fits.h5").run("apce")
    assert done.success and done.n_runs == 40
    np.testing.assert_array_equal(done.x, kept.x)
    assert not (out / "fits.run").exists()


def test_a_method_refusing_its_runs_keeps_them(tmp_path, calls):
    """pce_tensor refuses a design with failed nodes (MethodError) after running it: the
    successful nodes are kept and the reason is the error line."""
    from uqguide.config.run_config import validate_config
    from uqguide.driver.propagate import run

    raw = yaml.safe_load(_config(tmp_path, {"name": "pce_tensor", "label": "t", "m": 5})
                         .read_text())
    raw["model"]["function"] = "tests.failing_models:flaky"
    raw["model"]["outputs"] = ["y"]
    raw["model"]["isolate"] = False
    with pytest.raises(MethodsFailed) as exc:
        run(validate_config(raw))
    assert str(exc.value).startswith("t: 10 of 25 quadrature runs failed")
    r = exc.value.result.run("t")
    assert r.n_runs == 25 and r.n_failed == 10 and not r.success
    assert isinstance(exc.value, MethodError)  # what a caller of uqguide.run catches


def test_beside_a_method_that_completed(tmp_path, calls):
    """Monte Carlo completes, pce_tensor fails after its runs: the result holds both, the run
    folder stays for the failed one, and the exit is 1 with its reason."""
    cfg = _config(tmp_path, {"name": "pce_tensor", "label": "t", "m": 5})
    raw = yaml.safe_load(cfg.read_text())
    raw["model"]["function"] = "tests.failing_models:flaky"
    raw["model"]["outputs"] = ["y"]
    raw["methods"].insert(0, {"name": "monte_carlo", "label": "mc", "n_samples": 40})
    cfg.write_text(yaml.safe_dump(raw))
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out)])
    assert res.exit_code == 1, (res.output, res.exception)
    assert res.stderr.strip().splitlines()[-1].startswith(
        "error: t: 10 of 25 quadrature runs failed")
    assert "t: no statistics; the runs made are kept" in res.stderr
    result = read_hdf5(out / "fits.h5")
    assert result.run("mc").success and not result.run("t").success
    assert result.run("t").n_runs == 25
    assert (out / "fits.run").is_dir()
