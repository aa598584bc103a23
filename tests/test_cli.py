"""The command line: outputs, files and exit codes."""

from __future__ import annotations

from pathlib import Path

import pytest
import numpy as np
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.config.registry import MODELS
from uqguide.results.result import read_hdf5


def test_run_prints_tables_and_writes_files(write_config, lognormal_config, tmp_path):
    path = write_config(lognormal_config, "logn.yaml")
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(path), "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "Cost" in res.output and "y [1] (scalar)" in res.output
    # the cost table's times say which clock (their column names, API, only say seconds)
    assert "Cost (model_s, fit_s: s wall, model_s summed over the workers)" in res.output
    for f in ("logn.h5", "logn_stats.csv", "logn_cost.csv", "logn_summary.md"):
        assert (out / f).is_file()
    assert "model_s, fit_s: s wall" in (out / "logn_summary.md").read_text()
    assert f"wrote {out / 'logn.h5'}" in res.output


def test_same_config_and_seed_twice_identical_and_seed_override(write_config, lognormal_config,
                                                                tmp_path):
    path = write_config(lognormal_config)
    runner = CliRunner()
    for d in ("a", "b"):
        assert runner.invoke(main, ["run", str(path), "--out", str(tmp_path / d)]).exit_code == 0
    assert runner.invoke(main, ["run", str(path), "--out", str(tmp_path / "c"),
                                "--seed", "99"]).exit_code == 0
    a, b, c = (read_hdf5(tmp_path / d / "config.h5").run("mc") for d in "abc")
    for k in ("mean", "std", "skewness", "kurtosis"):
        np.testing.assert_array_equal(a.estimate.stats["y"].stat(k), b.estimate.stats["y"].stat(k))
    assert a.estimate.stats["y"].mean[0] != c.estimate.stats["y"].mean[0]
    assert read_hdf5(tmp_path / "c" / "config.h5").config["seed"] == 99


def test_models_lists_every_registered_model():
    res = CliRunner().invoke(main, ["models"])
    assert res.exit_code == 0, res.output
    for name in MODELS:
        assert f"\n{name}: " in "\n" + res.output


def test_simulate_runs_a_model_without_a_paper_scenario_at_the_inputs_means(
        write_config, lognormal_config, tmp_path):
    """``uqguide simulate`` refused any model without a paper scenario: it now runs it at the
    uncertain inputs' means (y = exp(sum a_i x_i) is 1 at x = 0) and plots each series."""
    res = CliRunner().invoke(main, ["simulate", str(write_config(lognormal_config))])
    assert res.exit_code == 0, res.output
    assert res.output.splitlines() == ["inputs (uncertain ones at their mean): x1 = 0, x2 = 0, "
                                       "x3 = 0", "y = 1"]
    cfg = {"name": "sim", "model": {"name": "callable",
                                    "function": "tests.fixtures_models:series_and_scalar",
                                    "inputs": ["a", "b"], "outputs": [
                                        {"name": "path", "kind": "series", "unit": "m"}, "total"]},
           "inputs": [{"name": "a", "dist": "uniform", "low": 1.0, "high": 3.0},
                      {"name": "b", "dist": "normal", "mean": 0.5, "std": 2.0}],
           "methods": [{"name": "monte_carlo", "n_samples": 10}]}
    res = CliRunner().invoke(main, ["simulate", str(write_config(cfg)), "--figures",
                                    str(tmp_path / "figs")])
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    assert lines[1] == "total = 2.5"  # a = 2 (the uniform's mean), b = 0.5
    assert lines[2] == "series over 5 steps, t = 0 .. 1 s:"
    assert lines[4].split() == ["path", "[m]", "0", "2", "0", "2"]  # path = a t
    assert lines[-1] == f"wrote {tmp_path / 'figs' / 'sim_nominal.png'}"
    assert (tmp_path / "figs" / "sim_nominal.png").stat().st_size > 0


def test_callable_model_with_series_runs_through_the_cli(write_config, tmp_path):
    cfg = {
        "model": {"name": "callable", "function": "tests.fixtures_models:series_and_scalar",
                  "inputs": ["a", "b"],
                  "outputs": [{"name": "path", "kind": "series"}, "total"]},
        "inputs": [{"name": "a", "dist": "normal", "std": 1.0},
                   {"name": "b", "dist": "normal", "std": 2.0}],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 2000}],
        "seed": 1,
    }
    res = CliRunner().invoke(main, ["run", str(write_config(cfg)), "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    r = read_hdf5(tmp_path / "config.h5")
    s = r.run("mc").estimate.stats
    # total = a + b: std sqrt(5) within 4 SE (SE of std for a Gaussian: std / sqrt(2n))
    assert abs(s["total"].std[0] - np.sqrt(5)) < 4 * np.sqrt(5) / np.sqrt(2 * 2000)
    np.testing.assert_allclose(s["path"].std[:, 0], r.time * s["path"].std[-1, 0], rtol=1e-12)


def test_callable_model_that_cannot_be_imported_is_exit_2(write_config):
    cfg = {"model": {"name": "callable", "function": "nosuchpkg.mod:f", "inputs": ["a"]},
           "inputs": [], "methods": [{"name": "monte_carlo", "n_samples": 1}]}
    res = CliRunner().invoke(main, ["validate", str(write_config(cfg))])
    assert res.exit_code == 2
    assert res.stderr.startswith("error: model.function: cannot import module 'nosuchpkg.mod'")


def test_reference_with_zero_variance_output_prints_without_a_verdict(write_config, tmp_path):
    # an output constant over every run (e.g. 'collided' = 0 in every MC run) has no reference
    # interval and no skewness: the table says it is constant instead of crashing or printing
    # round-off intervals
    cfg = {
        "model": {"name": "linear_gaussian", "coefficients": [[1.0, 0.0], [0.0, 0.0]]},
        "inputs": [{"name": "x1", "dist": "normal", "std": 1.0}],
        "methods": [{"name": "monte_carlo", "label": "ref", "n_samples": 200},
                    {"name": "monte_carlo", "label": "other", "n_samples": 100}],
        "reference": "ref",
        "seed": 1,
    }
    res = CliRunner().invoke(main, ["run", str(write_config(cfg)), "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    rows = [line.split() for line in res.output.splitlines()]
    constant = [row[2:] for row in rows if row[:2] in (["y2", "ref"], ["y2", "other"])]
    assert constant[:2] == [["0", "(constant)", "0", "(constant)", "-", "-"]] * 2
    assert "[>= 0" not in res.output


@pytest.mark.slow
def test_a_bad_config_with_workers_exits_2_and_leaves_no_worker_behind(tmp_path):
    """``--workers`` starts the pool before the config is read; a config that fails still
    exits 2 with the field named, no traceback and nothing written, and the workers end with
    the command (it returns; a worker left running would hold its pipes open)."""
    import subprocess
    import sys
    from pathlib import Path

    bad = tmp_path / "bad.yaml"
    bad.write_text("model: {name: ftcapn}\ninputs: []\n"
                   "methods: [{name: monte_carlo, n_samples: -3}]\n")
    p = subprocess.run([sys.executable, "-m", "uqguide.cli", "run", str(bad), "--workers", "2",
                        "--out", str(tmp_path / "out")], capture_output=True, text=True,
                       timeout=120, cwd=Path(__file__).resolve().parents[1])
    assert p.returncode == 2, p.stderr
    assert "methods[0].n_samples" in p.stderr and "Traceback" not in p.stderr
    assert not (tmp_path / "out").exists()


def test_another_config_of_the_same_name_is_refused_unless_forced(write_config, lognormal_config,
                                                                  tmp_path):
    """Two different studies named alike used to both exit 0, the second silently replacing the
    first's result and tables."""
    out = tmp_path / "out"
    first = write_config({**lognormal_config, "name": "study"}, "first.yaml")
    other = write_config({**lognormal_config, "name": "study", "seed": 8}, "other.yaml")
    runner = CliRunner()
    assert runner.invoke(main, ["run", str(first), "--out", str(out)]).exit_code == 0
    before = (out / "study.h5").read_bytes()
    res = runner.invoke(main, ["run", str(other), "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert "another config named 'study'" in res.output and "--force" in res.output
    assert "Traceback" not in res.output
    assert (out / "study.h5").read_bytes() == before
    # the same config again may overwrite its own result (same numbers)
    assert runner.invoke(main, ["run", str(first), "--out", str(out)]).exit_code == 0
    res = runner.invoke(main, ["run", str(other), "--out", str(out), "--force"])
    assert res.exit_code == 0, res.output
    assert read_hdf5(out / "study.h5").config["seed"] == 8


def test_a_foreign_file_at_the_result_name_is_refused_unless_forced(write_config,
                                                                    lognormal_config, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "study.h5").write_text("the user's notes, not a result")
    path = write_config({**lognormal_config, "name": "study"})
    res = CliRunner().invoke(main, ["run", str(path), "--out", str(out)])
    assert res.exit_code == 2 and "not a readable uqguide result" in res.output, res.output
    assert (out / "study.h5").read_text() == "the user's notes, not a result"


@pytest.mark.slow
def test_the_table3_run_fits_a_160_column_terminal(tmp_path):
    """Issue 47: tables ran to 300 characters and the legend was one 1,900-character line."""
    config = Path(__file__).resolve().parents[1] / "configs" / "ftcapn_table3.yaml"
    res = CliRunner().invoke(main, ["run", str(config), "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    wide = [line for line in res.output.splitlines() if len(line) > 160]
    assert wide == []
    assert "Key (all of it: docs/statistics.md):" in res.output


def test_a_wide_table_is_printed_in_blocks_that_keep_their_keys():
    import pandas as pd

    from uqguide.report.tables import fit_columns

    df = pd.DataFrame({"label": ["mc", "apce"], **{f"s{i}": ["x" * 30] * 2 for i in range(9)}})
    text = fit_columns(df, ["label"], width=100)
    blocks = text.split("\n\n")
    assert len(blocks) == 3 and max(map(len, text.splitlines())) <= 100
    assert all(b.splitlines()[1].split()[0] == "mc" for b in blocks)
    assert [c for b in blocks for c in b.splitlines()[0].split()[1:]] == list(df.columns[1:])
    assert fit_columns(df, ["label"], width=1000) == df.to_string(index=False)
