"""``uqguide check --sensitivity``: a baseline of format 4 holds the Sobol' indices with their
intervals; a rerun with another seed passes, a change of what drives the variance fails, a
baseline without indices cannot be checked for them (exit 2)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.config.run_config import validate_config
from uqguide.driver.propagate import run
from uqguide.gate.baseline import BASELINE_VERSION, make_baseline, parse_baseline, sealed, \
    to_jsonable
from uqguide.gate.check import check_result
from uqguide.results.result import write_hdf5


def _ishigami(seed: int, a: float = 7.0) -> dict:
    return {
        "model": {"name": "ishigami", "a": a},
        "inputs": [{"name": f"x{i}", "dist": "uniform", "low": -np.pi, "high": np.pi}
                   for i in (1, 2, 3)],
        "outputs": ["y"],
        "methods": [{"name": "sobol_saltelli", "label": "s", "n_base": 512, "chunk_size": 128,
                     "bootstrap": 100, "sampling": "random"}],
        "seed": seed,
    }


@pytest.fixture(scope="module")
def base():
    result = run(validate_config(_ishigami(1)))
    return result, parse_baseline(sealed(to_jsonable(make_baseline(result))))


def test_the_baseline_holds_the_indices_with_their_intervals(base):
    result, baseline = base
    st = result.run("s").estimate.stats["y"]
    m = baseline.methods["s"]
    assert baseline.format_version == BASELINE_VERSION == 4
    assert (m.sample_runs, m.sample_failed) == (1024, 0) and m.outputs["y"].n_used == 1024
    got = m.outputs["y"].points[0].indices
    assert got["total:x3"] == [st.sobol_total[0, 2], *st.sobol_total_ci[:, 0, 2]]
    assert set(got) == {f"{k}:x{i}" for k in ("first", "total") for i in (1, 2, 3)}


def test_a_reseeded_rerun_passes_and_a_changed_budget_fails(base):
    _, baseline = base
    again = check_result(run(validate_config(_ishigami(2))), baseline, sensitivity=True)
    assert again.passed, again.render()
    assert sum(r.stat.startswith("S") for r in again.rows) == 6
    # a = 4 instead of 7: x2's share falls from 0.44 to 0.21, mean and variance move too
    changed = check_result(run(validate_config(_ishigami(2, a=4.0))), baseline,
                           sensitivity=True)
    failed = {r.stat for r in changed.failures}
    assert {"S1[x2]", "ST[x2]"} <= failed, changed.render()


def test_without_the_flag_the_indices_are_counted_in_a_note(base):
    result, baseline = base
    report = check_result(result, baseline)
    assert not any(r.stat.startswith("S") for r in report.rows)
    assert "the baseline's 6 Sobol' indices are not checked (check them with --sensitivity)" \
        in report.notes


def _without_indices(result, path):
    """``result``'s baseline with its Sobol' indices taken out, written to ``path``."""
    data = to_jsonable(make_baseline(result))
    for p in data["methods"]["s"]["outputs"]["y"]["points"]:
        del p["indices"]
    del data["methods"]["s"]["outputs"]["y"]["sobol_estimator"]
    path.write_text(json.dumps(sealed(data)))
    return path


def test_a_baseline_without_indices_is_exit_2_with_sensitivity(base, tmp_path):
    result, _ = base
    b = _without_indices(result, tmp_path / "b.json")
    h5 = write_hdf5(result, tmp_path / "r.h5")
    res = CliRunner().invoke(main, ["check", str(h5), "--baseline", str(b), "--sensitivity"])
    assert res.exit_code == 2, res.output
    assert res.stderr.strip() == (
        f"error: {b}: --sensitivity: the baseline holds no Sobol' index to check (its result "
        f"had no Sobol' indices); write it again from a result with indices (`uqguide "
        f"baseline RESULT -o FILE --force`)")


def test_run_checks_the_indices_too_and_refuses_before_running_without_them(base, tmp_path):
    import yaml

    result, _ = base
    cfg = tmp_path / "ishigami.yaml"
    cfg.write_text(yaml.safe_dump(_ishigami(2)))
    good = tmp_path / "good.json"
    good.write_text(json.dumps(sealed(to_jsonable(make_baseline(result)))))
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out), "-q", "--check",
                                    str(good), "--check-sensitivity"])
    assert res.exit_code == 0, res.output
    # the indices were compared (without the flag a note says they are not)
    assert "PASS: " in res.output and "Sobol' indices are not checked" not in res.output
    # the same baseline without its indices: exit 2 before a run folder is made
    bare = _without_indices(result, tmp_path / "bare.json")
    other = tmp_path / "other"
    res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(other), "-q", "--check",
                                    str(bare), "--check-sensitivity"])
    assert res.exit_code == 2 and "--sensitivity: the baseline holds no Sobol' index" \
        in res.stderr
    assert not other.exists()
    res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(other), "-q",
                                    "--check-sensitivity"])
    assert res.exit_code == 2 and "--check BASELINE.json" in res.output
