"""Every config error path: exit code 2, one line naming the field, the value and what is
allowed, no traceback, nothing written."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.api import load_config
from uqguide.errors import ConfigError

GOOD = """
model: {name: lognormal, a: [0.3, 0.2]}
inputs:
  - {name: x1, dist: normal, mean: 0.0, std: 1.0}
  - {name: x2, dist: normal, mean: 0.0, std: 1.0}
methods:
  - {name: monte_carlo, label: mc, n_samples: 100}
seed: 1
"""

# (defect, replacement applied to GOOD, the exact first line of stderr after "error: ")
CASES = [
    ("unknown_top_key", ("seed: 1", "seed: 1\nsede: 2"),
     "sede: unknown key (did you mean 'seed'?); allowed keys: name, description, model, data, "
     "inputs, correlations, outputs, report_times, methods, reference, seed, batch_size, "
     "max_failed_fraction, strict, pce_failure_policy, quantiles, events, requirements, groups, "
     "max_steps, max_memory, "
     "timeout_s"),
    ("seed_wrong_type", ("seed: 1", "seed: abc"),
     "seed: Input should be a valid integer, unable to parse string as an integer (got 'abc')"),
    ("seed_negative", ("seed: 1", "seed: -4"),
     "seed: Input should be greater than or equal to 0 (got -4)"),
    ("unknown_model", ("name: lognormal", "name: lognormall"),
     "model.name: unknown model 'lognormall' (did you mean 'lognormal'?); allowed: borehole, "
     "callable, {models}"),
    ("unknown_model_param", ("a: [0.3, 0.2]", "a: [0.3, 0.2], b: 1"),
     "model.b: unknown key; allowed keys: name, isolate, a"),
    ("model_param_wrong_type", ("a: [0.3, 0.2]", "a: seven"),
     "model.a: Input should be a valid list (got 'seven')"),
    ("unknown_method", ("name: monte_carlo", "name: monte_carl"),
     "methods[0].name: unknown method 'monte_carl' (did you mean 'monte_carlo'?); allowed: "
     "{methods}"),
    ("nonpositive_samples", ("n_samples: 100", "n_samples: 0"),
     "methods[0].n_samples: Input should be greater than or equal to 1 (got 0)"),
    ("saltelli_one_base_row", ("name: monte_carlo, label: mc, n_samples: 100",
                               "name: sobol_saltelli, label: mc, n_base: 1"),
     "methods[0].n_base: Input should be greater than or equal to 2 (got 1)"),
    ("unknown_sampling", ("n_samples: 100", "n_samples: 100, sampling: halton"),
     "methods[0].sampling: unknown value 'halton'; allowed: random, lhs, sobol"),
    ("unknown_distribution", ("dist: normal, mean: 0.0, std: 1.0}\n  - {name: x2",
                              "dist: gauss, mean: 0.0, std: 1.0}\n  - {name: x2"),
     "inputs[0].dist: unknown distribution (got 'gauss'); allowed: normal, uniform, lognormal, "
     "truncnormal"),
    ("nonpositive_sigma", ("std: 1.0}\n  - {name: x2", "std: -1.5}\n  - {name: x2"),
     "inputs[0].std: Input should be greater than 0 (got -1.5)"),
    ("missing_sigma", ("mean: 0.0, std: 1.0}\n  - {name: x2", "mean: 0.0}\n  - {name: x2"),
     "inputs[0].std: required field is missing"),
    ("missing_methods", ("methods:\n  - {name: monte_carlo, label: mc, n_samples: 100}\n", ""),
     "methods: required field is missing"),
    ("unknown_input", ("{name: x2,", "{name: x9,"),
     "inputs[1].name: model 'lognormal' has no input 'x9'; allowed: x1, x2"),
    ("duplicate_input", ("{name: x2,", "{name: x1,"),
     "inputs[1].name: 'x1' is already inputs[0]"),
    ("unknown_output", ("seed: 1", "seed: 1\noutputs: [yy]"),
     "outputs[0]: model 'lognormal' has no output 'yy' (did you mean 'y'?); allowed: y"),
    ("reference_not_a_label", ("seed: 1", "seed: 1\nreference: mc2"),
     "reference: 'mc2' is not a method label (did you mean 'mc'?); allowed: mc"),
    ("duplicate_label", ("n_samples: 100}", "n_samples: 100}\n  - {name: monte_carlo, "
                         "label: mc, n_samples: 10}"),
     "methods[1].label: 'mc' is used twice; give each method a unique label"),
    ("uniform_reversed", ("dist: normal, mean: 0.0, std: 1.0}\n  - {name: x2",
                          "dist: uniform, low: 2, high: 1}\n  - {name: x2"),
     "inputs[0]: high must be greater than low, got low=2.0, high=1.0"),
    ("negative_report_time", ("seed: 1", "seed: 1\nreport_times: [0, -3]"),
     "report_times[1]: must be a finite time >= 0 s (got -3.0)"),
    ("correlation_not_pd", ("seed: 1", "seed: 1\ncorrelations:\n  - {inputs: [x1, x2], "
                            "matrix: [[1, 2], [2, 1]]}"),
     "correlations[0].matrix: must be positive definite"),
    # a boolean in a number field is named at that field (was ": seed must be ...")
    ("seed_boolean", ("seed: 1", "seed: true"),
     "seed: must be a number, not a boolean (got True)"),
    ("input_parameter_boolean", ("mean: 0.0, std: 1.0}\n  - {name: x2",
                                 "mean: yes, std: 1.0}\n  - {name: x2"),
     "inputs[0].mean: must be a number, not a boolean (got True)"),
    ("event_threshold_boolean", ("seed: 1", "seed: 1\nevents: [{name: e, output: y, below: on}]"),
     "events[0].below: must be a number, not a boolean (got True)"),
    # the value once, with the units allowed
    ("memory_unknown_unit", ("seed: 1", "seed: 1\nmax_memory: 4 XB"),
     "max_memory: must be a number of bytes or a size like '4 GB' (units: B, kB, MB, GB, TB, "
     "KiB, MiB, GiB, TiB) (got '4 XB')"),
    # one message for every wrong type, at the key (was max_memory.int)
    ("memory_list", ("seed: 1", "seed: 1\nmax_memory: [1]"),
     "max_memory: must be a number of bytes or a size like '4 GB' (units: B, kB, MB, GB, TB, "
     "KiB, MiB, GiB, TiB) (got [1])"),
    ("memory_mapping", ("seed: 1", "seed: 1\nmax_memory: {gb: 4}"),
     "max_memory: must be a number of bytes or a size like '4 GB' (units: B, kB, MB, GB, TB, "
     "KiB, MiB, GiB, TiB) (got {{'gb': 4}})"),  # (braces doubled: format)
    # the keys allowed are the input's, for its dist (were the top level's)
    ("unknown_input_key", ("std: 1.0}\n  - {name: x2", "std: 1.0, foo: 1}\n  - {name: x2"),
     "inputs[0].foo: unknown key; allowed keys: name, dist, mean, std"),
    ("key_of_another_dist", ("dist: normal, mean: 0.0, std: 1.0}\n  - {name: x2",
                             "dist: uniform, low: 0, high: 1, std: 1.0}\n  - {name: x2"),
     "inputs[0].std: unknown key; allowed keys: name, dist, low, high"),
    ("unknown_event_key", ("seed: 1", "seed: 1\nevents: [{name: e, output: y, below: 1, "
                                      "when: 2}]"),
     "events[0].when: unknown key; allowed keys: name, output, component, below, above"),
    # an unknown key beside a missing required one is named, not the missing one
    ("misspelt_required_method_key", ("label: mc, n_samples: 100", "n_sampels: 100"),
     "methods[0].n_sampels: unknown key (did you mean 'n_samples'?); allowed keys: name, label, "
     "n_samples, sampling, chunk_size, intervals, bootstrap, bootstrap_times, sensitivity, "
     "stop_when"),
    ("unknown_key_for_required_one", ("label: mc, n_samples: 100", "runs: 100"),
     "methods[0].runs: unknown key; required key missing: n_samples; allowed keys: name, label, "
     "n_samples, sampling, chunk_size, intervals, bootstrap, bootstrap_times, sensitivity, "
     "stop_when"),
]


@pytest.mark.parametrize("defect,edit,message", CASES, ids=[c[0] for c in CASES])
def test_config_error_exit_2_with_one_clear_line(write_config, tmp_path, defect, edit, message):
    from uqguide.config.registry import METHODS, MODELS

    old, new = edit
    assert old in GOOD, f"test case {defect} does not apply"
    path = write_config(GOOD.replace(old, new, 1))
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["run", str(path), "--out", str(out)])
    assert result.exit_code == 2, result.output
    expected = message.format(
        models=", ".join(m for m in sorted(MODELS) if m not in ("borehole", "callable")),
        methods=", ".join(sorted(METHODS)))
    assert result.stderr.strip().splitlines() == [f"error: {expected}"]
    assert "Traceback" not in result.output
    assert not out.exists(), "a failed validation must not write anything"


@pytest.mark.parametrize("text,message", [
    ("model: {name: lognormal\n", "invalid YAML at line 2, column 1"),
    ("- just\n- a list\n", "the config must be a mapping"),
])
def test_unreadable_configs_exit_2(write_config, text, message):
    result = CliRunner().invoke(main, ["validate", str(write_config(text))])
    assert result.exit_code == 2
    assert message in result.stderr
    assert "Traceback" not in result.output


def test_missing_file_exit_2(tmp_path):
    result = CliRunner().invoke(main, ["validate", str(tmp_path / "nope.yaml")])
    assert result.exit_code == 2
    assert result.stderr.strip() == f"error: {tmp_path / 'nope.yaml'}: config file not found"


def test_good_config_validates(write_config):
    result = CliRunner().invoke(main, ["validate", str(write_config(GOOD))])
    assert result.exit_code == 0, result.output
    assert "OK — model lognormal, 2 uncertain inputs (x1, x2)" in result.output


@pytest.mark.parametrize("output", ["a/b", "..", ".", "y z", {"name": "c/d", "kind": "series"}],
                         ids=["slash", "dotdot", "dot", "space", "mapping-form"])
def test_a_callable_output_that_cannot_name_a_file_is_refused_at_load(output):
    """An output name becomes an HDF5 path component and a figure file name: ``a/b`` used to be
    accepted, and ``plot`` / ``report`` then could not read the result."""
    cfg = {"name": "t", "inputs": [{"name": "x1", "dist": "normal", "std": 1.0}],
           "model": {"name": "callable", "function": "uqguide.models.callable:example_function",
                     "outputs": [output]},
           "methods": [{"name": "monte_carlo", "n_samples": 10}]}
    with pytest.raises(ConfigError) as e:
        load_config(cfg)
    assert e.value.field == "model.outputs"
    name = output if isinstance(output, str) else output["name"]
    assert repr(name) in str(e.value) and "letters, digits" in str(e.value)


@pytest.mark.parametrize("label", ["..", ".", "a/b", "mc 1"])
def test_a_method_label_that_cannot_name_a_group_or_file_is_refused(label):
    """A label names the method's HDF5 group and its files: '.' and '..' passed the old
    character pattern."""
    cfg = {"name": "t", "model": {"name": "lognormal", "a": [0.3]},
           "inputs": [{"name": "x1", "dist": "normal", "std": 1.0}],
           "methods": [{"name": "monte_carlo", "n_samples": 10, "label": label}]}
    with pytest.raises(ConfigError) as e:
        load_config(cfg)
    assert e.value.field == "methods[0].label" and "not only dots" in str(e.value)


@pytest.mark.parametrize("edit,field", [
    ({"seed": True}, "seed"),
    ({"max_memory": [1]}, "max_memory"),
    ({"inputs": [{"name": "x1", "dist": "normal", "std": 1.0, "foo": 1}]}, "inputs[0].foo"),
    ({"methods": [{"name": "monte_carlo", "runs": 100}]}, "methods[0].runs"),
], ids=["bool", "union", "input-key", "unknown-beside-missing"])
def test_the_python_api_names_the_same_field(edit, field):
    """``load_config`` of a mapping raises the ConfigError the CLI prints, its field the path."""
    cfg = {"model": {"name": "lognormal", "a": [0.3]},
           "inputs": [{"name": "x1", "dist": "normal", "std": 1.0}],
           "methods": [{"name": "monte_carlo", "n_samples": 10}]} | edit
    with pytest.raises(ConfigError) as e:
        load_config(cfg)
    assert e.value.field == field and str(e.value).startswith(f"{field}: ")


def test_a_mapping_in_a_union_is_judged_by_its_own_fields(write_config):
    """``outputs: [{name: y, kind: serie}]`` (a string or a mapping) names the mapping's bad
    value and its near choice, not the string branch ("Input should be a valid string")."""
    text = ("model: {name: callable, function: 'tests.failing_models:clean_sum', inputs: [a, b], "
            "outputs: [{name: y, kind: serie}]}\n"
            "inputs: [{name: a, dist: normal, mean: 0, std: 1}]\n"
            "methods: [{name: monte_carlo, n_samples: 10}]\n")
    result = CliRunner().invoke(main, ["validate", str(write_config(text))])
    assert result.exit_code == 2, result.output
    assert result.stderr.strip() == ("error: model.outputs[0].kind: unknown value 'serie' (did "
                                     "you mean 'series'?); allowed: scalar, series")
