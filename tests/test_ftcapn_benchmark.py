"""benchmarks/throughput.py: one tiny FTCAPN row, case discovery and the command line."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "throughput.py"


@pytest.fixture(scope="module")
def tp():
    spec = importlib.util.spec_from_file_location("throughput", PATH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_ftcapn_case_runs_and_formats(tp):
    case = next(c for c in tp.discover_cases() if c["model"] == "ftcapn")
    case = {**case, "params": {"threads": 1}}
    row = tp.run_case(case, 64, bootstrap=20)
    assert row["runs"] == 64 and row["failed"] == 0 and row["batch"] == 64
    assert row["wall_s"] == pytest.approx(row["sim_s"] + row["stats_s"], rel=1e-9)
    assert row["samples_per_s"] == pytest.approx(64 / row["wall_s"])
    assert row["peak_mb"] > 0
    text = tp.format_table([row])
    assert "ftcapn table3" in text and "samples/s" in text.splitlines()[0]
    # roofline: every figure follows from the row's CPU time, step count and the floor
    roof = tp.roofline_row(row)
    assert roof["samples_per_cpu_s"] == pytest.approx(64 / row["sim_cpu_s"])
    assert roof["ns_per_step"] == pytest.approx(1e9 * row["sim_cpu_s"] / (64 * row["steps"]))
    assert roof["ratio"] == pytest.approx(roof["ns_per_step"] / roof["floor_ns"])
    # Table 3 runs stop at 77.0-77.2 s with dt = 0.5 s: 155-156 steps
    assert 154 < row["steps"] < 157


def test_cases_modules_are_discovered(tp, tmp_path, monkeypatch):
    extra = tmp_path / "cases_extra.py"
    extra.write_text("CASES = [{'label': 'x', 'model': 'ishigami', 'params': {}, 'inputs': [], "
                     "'outputs': [], 'batches': [10]}]\n")
    monkeypatch.setattr(tp, "HERE", tmp_path)
    labels = [c["label"] for c in tp.discover_cases()]
    assert labels[0] == "ftcapn table3" and "x" in labels


def test_command_line_filters_and_overrides(tp, capsys):
    assert tp.main(["--no-scale", "--model", "ftcapn", "--batches", "32", "--param", "threads=1",
                    "--bootstrap", "0", "--no-memory"]) == 0
    out = capsys.readouterr().out.splitlines()
    # the run table (header, rule, one row), a blank line, then the roofline table
    assert out[2].split()[:3] == ["ftcapn", "table3", "ftcapn"] and out[3] == ""
    assert out[4].startswith("roofline: peak") and len(out) == 8
    assert out[7].split()[:3] == ["ftcapn", "table3", "32"]
    with pytest.raises(SystemExit):
        tp.main(["--model", "no_such_model"])
