"""Listings with allowed values, defaults, units and meanings; "did you mean" for misspelt
keys; report times outside the grid; the interval legend of every statistics table."""

from __future__ import annotations

import re

import pytest
from click.testing import CliRunner

from uqguide.cli import main


def _invoke(*args: str):
    return CliRunner().invoke(main, list(args))


def test_methods_list_allowed_values_defaults_and_meanings():
    r = _invoke("methods")
    assert r.exit_code == 0
    out = r.output
    assert "Literal" not in out and "[W" not in out and ":mod:" not in out
    # a default made by a factory is shown, not pydantic's placeholder for it
    assert "PydanticUndefined" not in out
    assert "  fidelities: list; default [{}] — " in out
    assert ("  sampling: one of random | lhs | sobol; default random — design of the samples "
            "within each chunk") in out
    assert "  n_samples: integer >= 1, <= 1e8; required — number of model runs" in out
    # rules, not pointers to the source: the adaptive PCE's design size and its budget
    assert "module docstring" not in out
    assert "initial design size; default n0 = max(10 d, 2 P_min), capped by max_runs" in out
    assert ("default min(max(10 n0, 100), 1000) when n_samples is not given either, else "
            "n_samples (no enrichment)") in out
    # every setting has a one-line meaning
    settings = [ln for ln in out.splitlines() if ln.startswith("  ")]
    assert settings and all(" — " in ln for ln in settings), [
        ln for ln in settings if " — " not in ln]


@pytest.mark.parametrize("name", ["ftcapn", "gmm_proximity", "callable"])
def test_models_list_parameters_without_internal_references(name):
    r = _invoke("models", name)
    assert r.exit_code == 0
    assert "Literal" not in r.output and "[W" not in r.output and "spec choice" not in r.output


def test_a_unit_is_shown_where_the_meaning_gives_one():
    out = _invoke("models", "ftcapn").output
    assert re.search(r"  A_sat: number.*; default 10, unit m/s\^2 — LOS acceleration limit",
                     out)
    assert "  gravity: one of none | hill; default none" in out


@pytest.mark.parametrize("methods, inputs, expected", [
    ([{"name": "monte_carlo", "n_sample": 100}], None,
     "methods[0].n_sample: unknown key (did you mean 'n_samples'?)"),
    ([{"name": "monte_carlo", "n_samples": 100}],
     [{"name": "dx", "dist": "normal", "mean": 0.0, "sd": 1.0}],
     "inputs[0].sd: unknown key (did you mean 'std'?)"),
])
def test_a_misspelt_required_key_is_named_with_did_you_mean(write_config, methods, inputs,
                                                            expected):
    cfg = {"model": {"name": "ftcapn"},
           "inputs": inputs or [{"name": "dx", "dist": "normal", "mean": 0.0, "std": 1.0}],
           "methods": methods}
    r = _invoke("validate", str(write_config(cfg)))
    assert r.exit_code == 2
    assert expected in r.output and "required field is missing" not in r.output


def test_a_misspelt_top_level_key(write_config):
    path = write_config("model: {name: ftcapn}\nmethod: [{name: monte_carlo, n_samples: 9}]\n")
    r = _invoke("validate", str(path))
    assert r.exit_code == 2
    assert "method: unknown key (did you mean 'methods'?)" in r.output


def _linear(report_times):
    return {"model": {"name": "linear_gaussian"},
            "inputs": [{"name": "x1", "dist": "normal", "mean": 0.0, "std": 1.0}],
            "report_times": report_times,
            "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 200}]}


def test_a_report_time_past_the_grid_is_an_error_naming_it(write_config, tmp_path):
    out = tmp_path / "out"
    path = str(write_config(_linear([0.5, 3.0])))
    r = _invoke("run", path, "--out", str(out), "-q")
    assert r.exit_code == 2
    assert ("report_times[1]: 3 s is outside the model's time grid [0, 1] s" in r.output)
    assert "Traceback" not in r.output and not out.exists()
    # the config's rule, checked where the config is validated: validate says so too
    r = _invoke("validate", path)
    assert r.exit_code == 2
    assert "report_times[1]: 3 s is outside the model's time grid [0, 1] s" in r.output


def test_a_single_method_run_says_what_its_intervals_are(write_config, tmp_path):
    r = _invoke("run", str(write_config(_linear([0.5]))), "--out", str(tmp_path), "-q")
    assert r.exit_code == 0, r.output
    # the key names the default interval method (Hall's) and where the others are chosen
    key = " ".join(r.output.split("Key (all of it: docs/statistics.md):")[1].split())
    assert "95% interval; Monte Carlo's are skew-corrected (Hall) influence-function " \
        "intervals by default (a method's intervals: setting names the others)" in key
    summary = " ".join((tmp_path / "config_summary.md").read_text().split())
    assert summary.count("skew-corrected (Hall)") == 1


def test_the_listing_is_also_right_for_a_callable_model():
    out = _invoke("models", "callable").output
    assert "  function: " in out and "module:function" in out


def test_a_function_returning_other_outputs_is_told_how_to_declare_them(write_config,
                                                                           tmp_path):
    """The commonest first mistake with a callable model: the function returns its own names
    and the config lists none (default [y]). The message names what it returned and the
    ``outputs`` entry for each, a series where the value is (n, T) on the returned grid."""
    cfg = {"model": {"name": "callable", "function": "tests.fixtures_models:series_and_scalar",
                     "inputs": ["a"]},
           "inputs": [{"name": "a", "dist": "normal", "std": 1.0}],
           "methods": [{"name": "monte_carlo", "n_samples": 20}]}
    r = _invoke("run", str(write_config(cfg)), "--out", str(tmp_path / "out"), "-q")
    assert r.exit_code == 1
    assert ("did not return output 'y': it returned 'path', 'total'" in r.output
            and "outputs: [{name: path, kind: series}, total]" in r.output), r.output
    assert "Traceback" not in r.output
    fixed = dict(cfg, model=dict(cfg["model"], outputs=[{"name": "path", "kind": "series"},
                                                       "total"]))
    r = _invoke("run", str(write_config(fixed, "fixed.yaml")), "--out", str(tmp_path / "ok"),
                "-q")
    assert r.exit_code == 0, r.output


def test_a_callable_whose_inputs_are_not_declared_is_told_where(write_config, tmp_path):
    """The other first mistake: the config's inputs named, the model's `inputs` left at its
    default [x1, x2]. Exit 2, and the message gives the `model.inputs` line for this config."""
    cfg = {"model": {"name": "callable", "function": "tests.fixtures_models:series_and_scalar",
                     "outputs": [{"name": "path", "kind": "series"}, "total"]},
           "inputs": [{"name": "a", "dist": "normal", "std": 1.0}],
           "methods": [{"name": "monte_carlo", "n_samples": 20}]}
    r = _invoke("run", str(write_config(cfg)), "--out", str(tmp_path / "out"), "-q")
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert "model 'callable' has no input 'a'" in r.output
    assert "for this config, model.inputs: [a]" in r.output, r.output
    fixed = dict(cfg, model=dict(cfg["model"], inputs=["a"]))
    r = _invoke("run", str(write_config(fixed, "fixed.yaml")), "--out", str(tmp_path / "ok"),
                "-q")
    assert r.exit_code == 0, r.output
