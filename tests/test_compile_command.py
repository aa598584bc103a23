"""``uqguide compile``: each study's model runs once with its kernel, so that the compile is paid
up front and on purpose; a kernel already in the cache is only loaded."""

from __future__ import annotations

import re

import pytest
import yaml
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.commands.compile_kernels import compile_kernels, format_compiled
from uqguide.models import kernels


def _lognormal(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text(yaml.safe_dump({
        "model": {"name": "lognormal", "a": [0.3]},
        "inputs": [{"name": "x1", "dist": "normal", "mean": 0.0, "std": 1.0}],
        "methods": [{"name": "monte_carlo", "n_samples": 10}]}))
    return path


def test_each_distinct_model_runs_once_then_the_statistics_kernel(tmp_path):
    # ftcapn_table3 is ftcapn_nominal's model with the same parameters: met once.
    rows = compile_kernels(["ftcapn_nominal", "ftcapn_table3", _lognormal(tmp_path)])
    assert [(r.study, r.model) for r in rows] == [
        ("ftcapn_nominal", "ftcapn"), ("mine", "lognormal"), ("-", "moment sums")]
    assert rows[0].kernel == "numba"
    assert rows[1].kernel == ""             # no kernel to choose: nothing is compiled
    assert all(0.0 <= r.compile_s <= r.total_s for r in rows)
    # what it prints is CPU (the docs' CPU-s), labelled so, with the compile's wall time last
    assert all(0.0 <= r.compile_cpu_s <= r.total_cpu_s for r in rows)
    text = format_compiled(rows).splitlines()
    assert text[0].split()[-4:] == ["compile", "CPU-s", "run", "CPU-s"]
    assert re.match(r"compiled in \d+\.\d CPU-s \(\d+\.\d s wall\); ", text[-1]), text[-1]
    # a second call finds everything in this process or the cache: no compile at all
    assert sum(r.compile_s for r in compile_kernels(["ftcapn_nominal"])) == 0.0


def test_the_deprecated_numpy_kernel_is_the_compiled_one(tmp_path, monkeypatch):
    # UQGUIDE_KERNEL=numpy once forced the NumPy references (now test oracles): it is ignored
    monkeypatch.setattr(kernels, "_warned", set())
    monkeypatch.setenv(kernels.KERNEL_ENV, "numpy")
    with pytest.warns(DeprecationWarning, match="UQGUIDE_KERNEL is deprecated and ignored"):
        out = CliRunner().invoke(main, ["compile", "gmm_nominal"])
    assert out.exit_code == 0, out.output
    line = next(ln for ln in out.output.splitlines() if ln.startswith("gmm_nominal"))
    assert line.split()[1:3] == ["gmm_proximity", "numba"]


def test_an_unknown_study_is_exit_2_naming_it():
    out = CliRunner().invoke(main, ["compile", "ftcapn_tabel3"])
    assert out.exit_code == 2
    assert "ftcapn_tabel3" in out.output and "Traceback" not in out.output
