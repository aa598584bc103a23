"""The regression gate: baselines, the comparison, and `uqguide check / baseline / run --check`.

Tolerances under test come from the gate itself (4 combined standard errors for Monte Carlo, the
baseline's relative tolerance for PCE); the cases are built so the expected verdict follows from
a closed form (linear_gaussian: exact shifts of mean and std) or is far from the threshold.
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from uqguide.gate.baseline import (make_baseline, parse_baseline, read_baseline, sealed,
                                   to_jsonable, write_baseline)
from uqguide.cli import main
from uqguide.config.run_config import validate_config
from uqguide.errors import ResultError
from uqguide.gate.check import check_result
from uqguide.driver.propagate import run
from uqguide.results.result import write_hdf5


def linear_config(seed: int = 1, a11: float = 1.0, n: int = 2000) -> dict:
    """y = A x with x ~ N(1, 1): mean of y1 = a11 + 1.5, std of y1 = sqrt(a11^2 + 4.25)."""
    return {
        "model": {"name": "linear_gaussian", "coefficients": [[a11, 2.0, -0.5], [0.5, 0.0, 1.5]],
                  "n_times": 5},
        "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 1.0, "std": 1.0}
                   for i in (1, 2, 3)],
        "outputs": ["y", "ramp"],
        "report_times": [0.0, 0.5, 1.0],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": n}],
        "seed": seed,
    }


def run_dict(cfg: dict):
    return run(validate_config(cfg))


FTCAPN_TABLE3 = {
    "model": {"name": "ftcapn"},
    "inputs": [{"name": n, "dist": "normal", "mean": 0.0, "std": s} for n, s in
               [("dx", 1.5), ("dy", 1.5), ("dz", 1.5), ("dvx", 0.3), ("dvy", 0.3), ("dvz", 0.3),
                ("b_w", 1e-5)]],
    "outputs": ["omega_s", "zem", "t_stop"],
    "report_times": [0, 20, 40, 60],
    "methods": [{"name": "monte_carlo", "label": "mc200", "n_samples": 200}],
    "seed": 1,
}


@pytest.fixture(scope="module")
def base_result():
    return run_dict(linear_config(seed=1))


@pytest.fixture(scope="module")
def base(base_result):
    return parse_baseline(make_baseline(base_result))


# ---------------------------------------------------------------------------- verdicts
def test_same_run_passes_exactly(base_result, base):
    rep = check_result(base_result, base)
    assert rep.passed
    compared = [r for r in rep.rows if not r.skipped]
    assert all(r.value == r.baseline or (math.isnan(r.value) and math.isnan(r.baseline))
               for r in compared)


def test_reseeded_runs_pass(base):
    """20 reseeded reruns: each statistic fails with probability ~6e-5 at 4 sigma (normal tail),
    so over all comparisons the expected count is below 0.1; 2 or more would be a broken SE."""
    n_rows = n_fail = 0
    for seed in range(2, 22):
        rep = check_result(run_dict(linear_config(seed=seed)), base)
        n_rows += len(rep.rows)
        n_fail += len(rep.failures)
    assert n_rows == 20 * 32  # y: 2 components x 4 statistics; ramp: 3 times x 2 x 4
    assert n_fail <= 1


def test_changed_coefficient_fails_and_names_the_quantity(base):
    # a11 1 -> 1.5: the mean of y1 = a11 + 1.5 moves by 0.5; its SE is 2.29/sqrt(2000) = 0.051
    # before and 2.55/sqrt(2000) = 0.057 after, combined 0.077: a shift of 6.5 combined SE.
    rep = check_result(run_dict(linear_config(seed=2, a11=1.5)), base)
    assert not rep.passed
    names = {f.quantity for f in rep.failures}
    assert "mc: mean of y[y1]" in names
    assert "mc: mean of ramp[y1] at t=1 s" in names
    assert not any("[y2]" in q for q in names), "y2 does not depend on a11"
    text = rep.render()
    assert text.startswith("REGRESSION: ")
    line = next(ln for ln in text.splitlines() if ln.startswith("mc: mean of y[y1]"))
    f = next(r for r in rep.failures if r.quantity == "mc: mean of y[y1]")
    # value, baseline and tolerance printed on the row of the failing quantity
    for v in (f.value, f.baseline, f.tolerance):
        assert f"{v:.5g}" in line
    assert "model.coefficients[0][0]: 1.0 -> 1.5" in text


def test_perturbed_ftcapn_navigation_constant_fails_reseed_passes(write_config, tmp_path):
    """FTCAPN N 3 -> 3.3 speeds the LOS-rate decay: the mean LOS rate at 20-60 s moves by many
    standard errors (7e-4 vs 8e-4 rad/s at 20 s, SE 4e-6); a reseeded run of N = 3 passes."""
    runner = CliRunner()
    cfg = write_config(FTCAPN_TABLE3, "ft.yaml")
    res = runner.invoke(main, ["run", str(cfg), "--out", str(tmp_path / "a")])
    assert res.exit_code == 0, res.output
    b = tmp_path / "ft.json"
    assert runner.invoke(main, ["baseline", str(tmp_path / "a" / "ft.h5"), "-o", str(b)]
                         ).exit_code == 0
    res = runner.invoke(main, ["run", str(cfg), "--seed", "2", "--out", str(tmp_path / "b"),
                               "--check", str(b)])
    assert res.exit_code == 0, res.output
    assert "PASS: " in res.output
    perturbed = copy.deepcopy(FTCAPN_TABLE3)
    perturbed["model"]["N"] = 3.3
    perturbed["seed"] = 2
    res = runner.invoke(main, ["run", str(write_config(perturbed, "ft.yaml")), "--out",
                               str(tmp_path / "c"), "--check", str(b)])
    assert res.exit_code == 1, res.output
    assert "REGRESSION: " in res.output
    assert "mc200: mean of omega_s at t=20 s" in res.output
    assert "model.N: 3.0 -> 3.3" in res.output
    # the same verdict from `uqguide check` on the written result
    res = runner.invoke(main, ["check", str(tmp_path / "c" / "ft.h5"), "--baseline", str(b)])
    assert res.exit_code == 1
    assert "mc200: mean of omega_s at t=20 s" in res.output
    # 1000 standard errors would let the same change through, so the gate refuses to be
    # widened that far (exit 2, nothing checked); at its limit of 10 it still fails the change
    for sigmas, code in (("1000", 2), ("1e300", 2), ("10", 1)):
        res = runner.invoke(main, ["check", str(tmp_path / "c" / "ft.h5"), "--baseline",
                                   str(b), "--sigmas", sigmas])
        assert res.exit_code == code, (sigmas, res.output)
    assert "must be a number in (0, 10]" in runner.invoke(
        main, ["check", str(tmp_path / "c" / "ft.h5"), "--baseline", str(b),
               "--sigmas", "1000"]).output


def test_zero_spread_skips_shape_statistics_and_nan_equals_nan(base_result, base):
    rep = check_result(base_result, base)
    t0 = [r for r in rep.rows if r.output == "ramp" and r.time == 0.0]
    # ramp = t y is identically 0 at t = 0: mean and std compared (round-off floor), skewness
    # and kurtosis skipped with a note
    assert {r.stat for r in t0 if r.skipped} == {"skewness", "kurtosis"}
    assert all(r.passed and "std ~ 0" in r.note for r in t0 if r.skipped)
    assert {r.basis for r in t0 if r.stat == "mean"} == {"round-off floor (no spread)"}
    assert "skipped (std ~ 0)" in rep.summary()


def test_nan_in_one_only_fails(base_result):
    data = make_baseline(base_result)
    pts = data["methods"]["mc"]["outputs"]["y"]["points"]
    pts[0]["mean"] = None
    rep = check_result(base_result, parse_baseline(data))
    (f,) = rep.failures
    assert f.quantity == "mc: mean of y[y1]" and f.note == "NaN in the baseline"


def test_pce_statistics_use_the_relative_tolerance(base_result):
    """A PCE estimate (moments_method exact) is judged on pce_rtol: a mean 1% off passes at the
    default 2%, 5% off fails; --pce-rtol overrides the baseline's value."""
    pce = copy.deepcopy(base_result)
    for s in pce.runs[0].estimate.stats.values():
        s.moments_method, s.sem, s.ci = "exact", None, {}
    base = parse_baseline(make_baseline(pce))
    assert base.methods["mc"].outputs["y"].uncertainty == "relative_tolerance"
    assert base.methods["mc"].outputs["y"].points[0].mean_se is None
    for factor, ok in ((1.01, True), (1.05, False)):
        moved = copy.deepcopy(pce)
        moved.runs[0].estimate.stats["y"].mean = pce.runs[0].estimate.stats["y"].mean * factor
        rep = check_result(moved, base)
        assert rep.passed is ok
        assert all(r.basis.startswith("2% of ") for r in rep.rows if r.output == "y")
    rep = check_result(moved, base, pce_rtol=0.1)
    assert rep.passed


def test_moved_end_of_grid_is_matched_to_the_last_step_with_a_note(base_result, base):
    shorter = copy.deepcopy(base_result)
    shorter.time = shorter.time * 1.25  # same number of steps, last one at 1.25 s
    rep = check_result(shorter, base)
    end = [r for r in rep.rows if r.output == "ramp" and r.time == 1.0]
    assert end and all("last step at t=1.25 s" in r.note for r in end)
    assert all(r.passed for r in end)  # statistics unchanged: only the grid moved


# ---------------------------------------------------------------------------- the file
def test_baseline_file_is_readable_and_exact(base_result, tmp_path):
    p = write_baseline(base_result, tmp_path / "b.json")
    text = p.read_text()
    data = json.loads(text)
    assert data["format"] == "uqguide-baseline" and data["model"] == "linear_gaussian"
    assert data["config"]["seed"] == 1 and "numpy" in data["versions"]
    points = data["methods"]["mc"]["outputs"]["ramp"]["points"]
    assert [p["time"] for p in points[::2]] == [0.0, 0.5, 1.0]
    assert [p["at"] for p in points[::2]] == ["report", "report", "end"]
    # one line per point, NaN written as null
    line = next(ln for ln in text.splitlines() if '"time": 0.0, "component": "y1"' in ln)
    assert '"skewness": null' in line and '"mean_se": ' in line
    # numbers read back bit for bit
    s = base_result.run("mc").estimate.stats["y"]
    got = read_baseline(p).methods["mc"].outputs["y"].points
    assert [g.mean for g in got] == list(s.mean) and [g.kurtosis for g in got] == list(s.kurtosis)
    # the standard error of the std is the bootstrap half-width over 1.96
    lo, hi = s.ci["std"][:, 0]
    assert got[0].std_se == pytest.approx((hi - lo) / (2 * 1.959963984540054), rel=1e-12)
    assert got[0].mean_se == pytest.approx(s.std[0] / np.sqrt(2000), rel=1e-12)


@pytest.mark.parametrize("content, message", [
    ('{"format": "uqguide-baseline", "format_version": 1, "name": ',
     "baseline is not valid JSON (line 1, column"),
    ("[1, 2]", "not a uqguide baseline"),
    ('{"format": "uqguide-baseline", "format_version": 7}', "format_version 7 is not supported"),
    ('{"format": "uqguide-baseline", "format_version": 2, "name": "x"}',
     "invalid baseline at model: Field required"),
    ('{"format": "uqguide-baseline", "format_version": 1, "name": "x"}',
     "whose digest refuses edits by hand"),
])
def test_corrupt_baseline_is_exit_2(base_result, tmp_path, content, message):
    h5 = write_hdf5(base_result, tmp_path / "r.h5")
    b = tmp_path / "b.json"
    b.write_text(content)
    res = CliRunner().invoke(main, ["check", str(h5), "--baseline", str(b)])
    assert res.exit_code == 2, res.output
    assert res.stderr.startswith(f"error: {b}: ")
    assert message in res.stderr


def test_invalid_value_in_a_point_names_its_place(base_result):
    data = make_baseline(base_result)
    data["methods"]["mc"]["outputs"]["y"]["points"][1]["std"] = "big"
    with pytest.raises(ResultError, match=r"invalid baseline at methods\.mc\.outputs\.y\."
                                          r"points\.1\.std"):
        parse_baseline(data)


def test_mismatched_baseline_is_exit_2(base_result, tmp_path, write_config):
    h5 = write_hdf5(base_result, tmp_path / "r.h5")
    runner = CliRunner()
    cases = {}
    other = run_dict({"model": {"name": "lognormal"}, "inputs": [
        {"name": f"x{i}", "dist": "normal", "std": 1.0} for i in (1, 2, 3)],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 100}]})
    cases["baseline is for model 'lognormal', the result is model 'linear_gaussian'"] = \
        make_baseline(other)
    d = make_baseline(base_result)
    d["methods"]["mc"]["outputs"]["velocity"] = d["methods"]["mc"]["outputs"]["y"]
    cases["the result has no output 'velocity'"] = d
    d = make_baseline(base_result)
    d["methods"]["mc1000"] = d["methods"].pop("mc")
    cases["the result has no method labelled 'mc1000' (it has: mc)"] = d
    d = make_baseline(base_result)
    d["methods"]["mc"]["outputs"]["y"]["unit"] = "m"
    cases["output 'y' is scalar [m] with components ['y1', 'y2'] in the baseline"] = d
    for message, data in cases.items():
        b = tmp_path / "b.json"
        b.write_text(json.dumps(sealed(to_jsonable(data))))  # as if written so: not an edit
        res = runner.invoke(main, ["check", str(h5), "--baseline", str(b)])
        assert res.exit_code == 2, (message, res.output)
        assert message in res.stderr
    # run --check refuses a mismatched baseline before running anything
    cfg = write_config(linear_config(), "lin.yaml")
    res = runner.invoke(main, ["run", str(cfg), "--out", str(tmp_path / "o"), "--check", str(b)])
    assert res.exit_code == 2
    assert "output 'y' is scalar [m]" in res.stderr
    assert not (tmp_path / "o" / "lin.h5").exists()


def test_unusable_result_file_is_exit_2(base_result, tmp_path):
    b = write_baseline(base_result, tmp_path / "b.json")
    runner = CliRunner()
    res = runner.invoke(main, ["check", str(tmp_path / "none.h5"), "--baseline", str(b)])
    assert res.exit_code == 2 and "result file not found" in res.stderr
    res = runner.invoke(main, ["check", str(b), "--baseline", str(b)])
    assert res.exit_code == 2 and "unreadable or incomplete result file" in res.stderr
    res = runner.invoke(main, ["baseline", str(b), "-o", str(tmp_path / "c.json")])
    assert res.exit_code == 2


def test_baseline_command_writes_and_refuses_to_overwrite(base_result, tmp_path):
    h5 = write_hdf5(base_result, tmp_path / "r.h5")
    out = tmp_path / "sub" / "b.json"
    runner = CliRunner()
    res = runner.invoke(main, ["baseline", str(h5), "-o", str(out), "--pce-rtol", "0.05"])
    assert res.exit_code == 0 and res.output == f"wrote {out}\n"
    assert read_baseline(out).tolerances.pce_rtol == 0.05
    res = runner.invoke(main, ["baseline", str(h5), "-o", str(out)])
    assert res.exit_code == 2 and "pass --force to replace it" in res.stderr
    assert runner.invoke(main, ["baseline", str(h5), "-o", str(out), "--force"]).exit_code == 0
    assert read_baseline(out).tolerances.pce_rtol == 0.02
    res = runner.invoke(main, ["check", str(h5), "--baseline", str(out), "--all"])
    assert res.exit_code == 0
    assert "mc: kurtosis of ramp[y2] at t=1 s" in res.output  # --all lists passing rows too


def test_check_without_baseline_option_is_usage_error(tmp_path):
    res = CliRunner().invoke(main, ["check", str(tmp_path / "r.h5")])
    assert res.exit_code == 2
    assert "give --baseline BASELINE.json, --requirements, or both" in res.output


def test_yaml_config_round_trip_keeps_baseline_config(base_result, tmp_path):
    """The baseline's config is the resolved config of the result (what the run really used)."""
    b = read_baseline(write_baseline(base_result, tmp_path / "b.json"))
    assert yaml.safe_dump(b.config) == yaml.safe_dump(base_result.config)


@pytest.mark.parametrize("command", ["check", "baseline"])
@pytest.mark.parametrize("value, ok", [("0.2", True), ("0.21", False), ("2", False),
                                       ("nan", False), ("0", False)])
def test_check_and_baseline_accept_the_same_pce_rtol_range(command, value, ok, tmp_path):
    """``check --pce-rtol 2`` was accepted while ``baseline --pce-rtol 2`` was refused: one range,
    (0, 0.2], for both; outside it, exit 2 naming the option, before any file is read."""
    from uqguide.gate.tolerances import tolerance_problem

    assert (tolerance_problem("--pce-rtol", value) is None) == ok
    if not ok:
        args = ([command, str(tmp_path / "r.h5"), "--baseline", str(tmp_path / "b.json")]
                if command == "check" else [command, str(tmp_path / "r.h5"), "-o",
                                            str(tmp_path / "b.json")])
        res = CliRunner().invoke(main, args + ["--pce-rtol", value])
        assert res.exit_code == 2 and "--pce-rtol" in res.output and "(0, 0.2]" in res.output


def _edited(baseline_path, tmp_path, edit):
    data = json.loads(baseline_path.read_text())
    edit(data)
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(data))
    return path


def _sample_output(data):
    for m in data["methods"].values():
        for o in m["outputs"].values():
            if o["uncertainty"] == "standard_error":
                return m, o
    raise AssertionError("no Monte Carlo output in the baseline")


def test_hand_loosened_error_bars_are_refused(tmp_path):
    """Two hand edits that let a real regression through: every non-mean standard error set to
    1e300 (11 of 90 statistics still failed), and n_used 1 with mean_se = std (2 of 90)."""
    golden = Path(__file__).parent / "golden" / "ftcapn_table3.baseline.json"

    def huge_errors(data):
        for p in _sample_output(data)[1]["points"]:
            for k in ("std_se", "skewness_se", "kurtosis_se"):
                p[k] = 1e300

    def one_run(data):
        o = _sample_output(data)[1]
        o["n_used"] = 1
        for p in o["points"]:
            p["mean_se"] = p["std"]

    def more_runs_than_made(data):
        m, o = _sample_output(data)
        o["n_used"] = m["n_runs"] + 1
        for p in o["points"]:
            p["mean_se"] = p["std"] / (m["n_runs"] + 1) ** 0.5

    for edit, why in ((huge_errors, "std_se"), (one_run, "n_used"),
                      (more_runs_than_made, "n_used")):
        with pytest.raises(ResultError, match=why):
            read_baseline(_edited(golden, tmp_path, edit))
    read_baseline(golden)  # the file as written passes


def test_a_baseline_edited_by_hand_is_refused(base_result, tmp_path):
    """Any change after writing, even one the other checks cannot see (a mean moved within its
    own error bar, a tolerance widened within its range), is refused: regenerating a baseline is
    the only way to change it."""
    b = write_baseline(base_result, tmp_path / "b.json")
    read_baseline(b)
    for edit in (lambda d: d["methods"]["mc"]["outputs"]["y"]["points"][0].update(
                     mean=d["methods"]["mc"]["outputs"]["y"]["points"][0]["mean"] * (1 + 1e-9)),
                 lambda d: d["tolerances"].update(pce_rtol=0.2),
                 lambda d: d.update(format_version=1)):
        data = json.loads(b.read_text())
        edit(data)
        edited = tmp_path / "edited.json"
        edited.write_text(json.dumps(data))
        with pytest.raises(ResultError, match="changed after it was written|edits by hand"):
            read_baseline(edited)
        res = CliRunner().invoke(main, ["check", str(write_hdf5(base_result, tmp_path / "r.h5")),
                                        "--baseline", str(edited)])
        assert res.exit_code == 2, res.output
