"""``stop_when: {target_rel_se, statistic, output}``: Monte Carlo stops after the first chunk at
which the statistic's delta-method relative standard error reaches the target."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.config.run_config import validate_config
from uqguide.driver.propagate import run
from uqguide.errors import ConfigError
from uqguide.methods.monte_carlo import relative_se
from uqguide.stats.moments import delta_standard_errors

from .failing_models import mc_config
from .test_resume import _assert_same, _stats, run_to_ctrl_c

LINEAR = {"model": {"name": "linear_gaussian", "coefficients": [[1.0, 2.0, -0.5]]},
          "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                     for i in (1, 2, 3)]}
CHUNK = 128


def _config(stop, cap=20_000, model=None):
    method = {"name": "monte_carlo", "label": "mc", "n_samples": cap, "chunk_size": CHUNK,
              "bootstrap": 0, "sensitivity": "off"}
    if stop is not None:
        method["stop_when"] = stop
    return validate_config({**(model or LINEAR), "methods": [method]})


def test_relative_se_is_the_delta_methods_over_the_estimate():
    """Against the formula of docs/statistics.md written out here: for the std,
    SE = sigma sqrt((mu4 / sigma^4 - 1) / (4 n)) (the delta method's leading term)."""
    y = np.random.default_rng(3).gamma(2.0, size=(2000, 2))
    d = y - y.mean(0)
    mu2, mu4 = (d**2).mean(0), (d**4).mean(0)
    expected = np.sqrt((mu4 / mu2**2 - 1) / (4 * len(y)))
    np.testing.assert_allclose(relative_se(y, "std"), expected, rtol=1e-12)
    mus = tuple((d**p).mean(0) for p in range(2, 9))
    se_mean = delta_standard_errors(mus, len(y))["mean"]
    np.testing.assert_allclose(relative_se(y, "mean"), se_mean / np.abs(y.mean(0)), rtol=1e-12)
    assert np.all(relative_se(y[:1], "std") == np.inf)


def test_the_run_stops_at_the_first_chunk_that_meets_the_target():
    """y ~ N(0, 5.25): rel. SE of the std about 1 / sqrt(2 n), 0.02 near n = 1250. The run
    stops at the first chunk boundary where the runs' own relative SE is at most 0.02, not
    before, and its numbers are those of a fixed run of that size."""
    stop = {"target_rel_se": 0.02, "statistic": "std", "output": "y"}
    r = run(_config(stop)).runs[0]
    m = r.n_runs
    assert m % CHUNK == 0 and 1000 < m < 1600
    y = r.scalars["y"]
    assert relative_se(y[:m], "std")[0] <= 0.02 < relative_se(y[:m - CHUNK], "std")[0]
    fixed = run(_config(None, cap=m)).runs[0]
    for name in ("mean", "std", "skewness", "kurtosis"):
        assert np.array_equal(getattr(r.estimate.stats["y"], name),
                              getattr(fixed.estimate.stats["y"], name))
    assert np.array_equal(np.asarray(r.x), np.asarray(fixed.x))
    assert r.estimate.diagnostics["stop_when"] == "rel. SE of std(y) <= 0.02"
    assert r.estimate.diagnostics["n_samples_cap"] == 20_000


def test_a_target_not_met_runs_to_the_cap():
    r = run(_config({"target_rel_se": 0.001, "output": "y"}, cap=1024)).runs[0]
    assert r.n_runs == 1024


def test_a_component_of_a_multi_component_output():
    """Components of sd 1 and 100 x that: the relative SE of the std does not depend on the
    scale, so both components stop at the same chunk, and the whole output at that one too."""
    model = {"model": {"name": "linear_gaussian", "coefficients": [[1.0], [100.0]]},
             "inputs": [{"name": "x1", "dist": "normal", "mean": 0.0, "std": 1.0}]}
    runs = [run(_config({"target_rel_se": 0.03, "output": "y", **c}, model=model)).runs[0]
            for c in ({"component": 0}, {"component": 1}, {})]
    assert runs[0].n_runs == runs[1].n_runs == runs[2].n_runs < 20_000


@pytest.mark.parametrize("stop, message", [
    ({"target_rel_se": 0, "output": "y"},
     "methods[0].stop_when.target_rel_se: Input should be greater than 0 (got 0)"),
    ({"target_rel_se": 0.01, "output": "y", "statistic": "var"},
     "methods[0].stop_when.statistic: unknown value 'var'; allowed: mean, std, skewness, "
     "kurtosis"),
    ({"target_rel_se": 0.01, "output": "y", "statstic": "std"},
     "methods[0].stop_when.statstic: unknown key (did you mean 'statistic'?); allowed keys: "
     "target_rel_se, statistic, output, component"),
    ({"output": "y"}, "methods[0].stop_when.target_rel_se: required field is missing"),
    ({"target_rel_se": 0.01, "output": "z"},
     "methods[0].stop_when.output: 'z' is not an output of the run; a precision target is on "
     "a scalar output; allowed: y"),
    ({"target_rel_se": 0.01, "output": "y", "component": 3},
     "methods[0].stop_when.component: component 3 is out of range 0..0"),
    ("sometimes", "methods[0].stop_when: unknown value 'sometimes'; allowed: decided"),
])
def test_bad_targets_name_the_field_the_value_and_what_is_allowed(stop, message):
    with pytest.raises(ConfigError) as err:
        _config(stop)
    assert str(err.value) == message


def test_a_target_on_a_series_output_is_refused():
    raw = mc_config("tests.failing_models:flaky", 100, 100)
    raw["model"]["outputs"] = ["y", {"name": "s", "kind": "series"}]
    raw["methods"][0]["stop_when"] = {"target_rel_se": 0.01, "output": "s"}
    try:
        validate_config(raw)
    except ConfigError as exc:
        assert str(exc).startswith("methods[0].stop_when.output: 's' is a time series; a "
                                   "precision target is on a scalar output; allowed: y")
    else:
        pytest.fail("a target on a series output was accepted")


@pytest.mark.slow
def test_a_stopping_run_resumes_after_ctrl_c_to_the_same_numbers(tmp_path, monkeypatch):
    """y = a + b, kurtosis 2.925: rel. SE of the std sqrt(1.925 / (4 n)), 0.03 near n = 535;
    Ctrl-C after 2 of the chunks of 100, the resumed run stops where an uninterrupted one
    does, with its numbers and those of a fixed run of that size."""
    raw = mc_config("tests.failing_models:ctrl_c_on_third_call", 1000, 100, bootstrap=40)
    raw["methods"][0]["stop_when"] = {"target_rel_se": 0.03, "output": "y"}
    cfg, out, res = run_to_ctrl_c(raw, tmp_path, monkeypatch)
    assert res.exit_code == 130
    resumed = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out), "--resume"])
    assert resumed.exit_code == 0, resumed.output
    got = _stats(out / "cc.h5")
    assert 400 <= int(got["n_runs"]) <= 800
    ref = CliRunner().invoke(main, ["run", str(cfg), "--out", str(tmp_path / "ref")])
    assert ref.exit_code == 0
    _assert_same(_stats(tmp_path / "ref" / "cc.h5"), got)
    fixed = yaml.safe_load(cfg.read_text())
    del fixed["methods"][0]["stop_when"]
    fixed["methods"][0]["n_samples"] = int(got["n_runs"])
    path = tmp_path / "fixed.yaml"
    path.write_text(yaml.safe_dump(fixed))
    res = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "fx")])
    assert res.exit_code == 0
    _assert_same(_stats(tmp_path / "fx" / "fixed.h5"), got)


def test_uqguide_methods_lists_both_forms():
    from uqguide.methods.monte_carlo import MonteCarloSettings
    from uqguide.report.describe import describe_settings

    line = next(t for t in describe_settings(MonteCarloSettings).splitlines()
                if t.strip().startswith("stop_when:"))
    assert line.strip().startswith("stop_when: one of decided | {target_rel_se, statistic, "
                                   "output, component}, or null; default null")
