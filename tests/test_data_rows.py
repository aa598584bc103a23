"""``data:`` in place of ``model:`` (runs already made), ``uqguide.fit`` and ``uqguide suggest``.

The closed-form case: ``y = 1 + 2 a + 3 b + a b`` with ``a ~ U(-1, 1)``, ``b ~ N(0, 1)``. A
regression PCE whose basis holds this polynomial reproduces it from any rows up to round-off,
so its four moments must equal the exact ones (computed here by an independent Gauss rule) to
round-off; Monte Carlo on the rows must give the rows' own sample moments.
"""

from __future__ import annotations

import csv
import logging
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import uqguide
from uqguide.cli import main
from uqguide.errors import ConfigError

INPUTS = [{"name": "a", "dist": "uniform", "low": -1.0, "high": 1.0},
          {"name": "b", "dist": "normal", "mean": 0.0, "std": 1.0}]
PCE = {"name": "pce_adaptive", "label": "pce", "degree_max": 3, "surrogate_draws": 1000}


def poly(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return 1 + 2 * a + 3 * b + a * b


def exact_moments() -> tuple[float, float, float, float]:
    """Mean, std, skewness, kurtosis of ``poly`` by a tensor Gauss rule (exact: y^4 has
    degree 8 in each variable, a 10-point rule integrates degree 19)."""
    ga, wa = np.polynomial.legendre.leggauss(10)
    gb, wb = np.polynomial.hermite_e.hermegauss(10)
    wa, wb = wa / 2, wb / math.sqrt(2 * math.pi)
    A, B = np.meshgrid(ga, gb, indexing="ij")
    W = np.outer(wa, wb)
    y = poly(A, B)
    m = float((W * y).sum())
    v = float((W * (y - m) ** 2).sum())
    return (m, math.sqrt(v), float((W * (y - m) ** 3).sum()) / v**1.5,
            float((W * (y - m) ** 4).sum()) / v**2)


def rows(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = np.column_stack([rng.uniform(-1, 1, n), rng.standard_normal(n)])
    return x, poly(x[:, 0], x[:, 1])


def write_csv(path: Path, x: np.ndarray, y: np.ndarray, names=("a", "b", "y")) -> Path:
    lines = [",".join(names)] + [",".join(repr(v) for v in r)
                                 for r in np.column_stack([x, y]).tolist()]
    path.write_text("\n".join(lines) + "\n")
    return path


def config(tmp_path: Path, data: str = "runs.csv", methods=None, **more) -> Path:
    cfg = {"data": data, "inputs": INPUTS, "methods": methods or [PCE], **more}
    p = tmp_path / "data.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


def four(result, label: str, output: str = "y") -> np.ndarray:
    st = result.run(label).estimate.stats[output]
    return np.array([float(np.ravel(st.stat(k))[0])
                     for k in ("mean", "std", "skewness", "kurtosis")])


# ---------------------------------------------------------------------------- closed forms
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_pce_of_the_rows_gives_the_exact_moments(tmp_path, seed):
    x, y = rows(40, seed)
    write_csv(tmp_path / "runs.csv", x, y)
    result = uqguide.run(config(tmp_path))
    # round-off of a least-squares fit of 40 rows: a few hundred ulps of the moments
    assert np.allclose(four(result, "pce"), exact_moments(), rtol=0, atol=1e-10)
    assert result.run("pce").estimate.diagnostics["sampling"] == "data"
    assert result.run("pce").n_runs == 40


@pytest.mark.parametrize("seed", [3, 4, 5])
def test_monte_carlo_of_the_rows_is_their_sample_statistics(tmp_path, seed):
    x, y = rows(200, seed)
    write_csv(tmp_path / "runs.csv", x, y)
    result = uqguide.run(config(tmp_path, methods=[{"name": "monte_carlo", "label": "mc"}]))
    st = result.run("mc").estimate.stats["y"]
    assert float(st.mean[0]) == pytest.approx(y.mean(), rel=1e-13)
    assert float(st.std[0]) == pytest.approx(y.std(), rel=1e-12)
    # the exact mean within 4 of its standard errors (a false alarm once in 16,000 seeds)
    assert abs(float(st.mean[0]) - exact_moments()[0]) < 4 * float(st.sem[0])
    assert result.run("mc").n_runs == 200


# ---------------------------------------------------------------------------- fit
def test_fit_gives_the_numbers_of_the_config_bit_for_bit(tmp_path):
    import pandas as pd
    import xarray as xr

    x, y = rows(40, 7)
    write_csv(tmp_path / "runs.csv", x, y)
    from_file = uqguide.run(config(tmp_path))
    ref = four(from_file, "pce")
    sobol = from_file.run("pce").estimate.stats["y"].sobol_total
    from_arrays = uqguide.fit(x, y, inputs=INPUTS, method=PCE)
    assert np.array_equal(four(from_arrays, "pce"), ref)
    assert np.array_equal(from_arrays.run("pce").estimate.stats["y"].sobol_total, sobol)
    frame = pd.DataFrame({"b": x[:, 1], "a": x[:, 0]})  # by name, in any order
    assert np.array_equal(four(uqguide.fit(frame, pd.DataFrame({"y": y}), inputs=INPUTS,
                                           method=PCE), "pce"), ref)
    ds = xr.Dataset({"a": ("run", x[:, 0]), "b": ("run", x[:, 1]), "y": ("run", y)})
    assert np.array_equal(four(uqguide.fit(ds[["a", "b"]], ds[["y"]], inputs=INPUTS,
                                           method=PCE), "pce"), ref)
    assert from_arrays.surrogate("pce").names == ["y"]
    with pytest.raises(ConfigError, match=r"given from Python \(uqguide.fit\) and are not "
                                          r"stored"):
        uqguide.load_config(from_arrays.config)


def test_fit_refuses_bad_rows_with_a_uqguide_error():
    x, y = rows(40, 8)
    x[5, 0] = 1.5
    with pytest.raises(ConfigError, match=r"row 6, column 'a': 1\.5 is outside the support"):
        uqguide.fit(x, y, inputs=INPUTS)


# ---------------------------------------------------------------------------- bad data
def _bad(tmp_path, edit, methods=None, data="runs.csv", **more):
    x, y = rows(40, 9)
    lines = write_csv(tmp_path / "runs.csv", x, y).read_text().splitlines()
    text = edit(lines)
    if text is not None:
        (tmp_path / "runs.csv").write_text(text)
    return CliRunner().invoke(main, ["validate", str(config(tmp_path, data, methods, **more))])


def _set(lines, line, col, value):
    cells = lines[line - 1].split(",")
    cells[col] = value
    lines[line - 1] = ",".join(cells)
    return "\n".join(lines) + "\n"


BAD = [
    ("missing_input", lambda L: "\n".join(l.split(",", 1)[1] for l in L) + "\n", {},
     "data: runs.csv: no column 'a' for inputs[0] (columns: b, y)"),
    ("missing_output", None, {"outputs": ["z"]},
     "data: runs.csv: no column 'z' (or z[0], z[1], ...) for outputs[0]; output columns: y"),
    ("nan_input", lambda L: _set(L, 5, 1, "nan"), {},
     "data: runs.csv: row 4 (line 5), column 'b': input is nan; every run's inputs must be "
     "known numbers (a failed run is a row of NaN outputs)"),
    ("outside_support", lambda L: _set(L, 3, 0, "-1.25"), {},
     "data: runs.csv: row 2 (line 3), column 'a': -1.25 is outside the support [-1, 1] of "
     "inputs[0] uniform(low=-1, high=1) (1 row is outside)"),
    ("repeated_row", lambda L: "\n".join(L + [L[7]]) + "\n", {},
     "data: runs.csv: row 41 (line 42) repeats the inputs of row 7 (line 8)"),
    ("not_a_number", lambda L: _set(L, 9, 2, "oops"), {},
     "data: runs.csv: row 8 (line 9), column 'y': 'oops' is not a number"),
    ("too_few_rows", lambda L: "\n".join(L[:12]) + "\n", {},
     "data: runs.csv: 11 usable rows; methods[0] (pce) needs at least 20 for 2 inputs"),
    ("too_few_good_rows", lambda L: _set(L[:21], 21, 2, "nan"), {},
     "data: runs.csv: 19 usable rows (1 of 20 has NaN outputs); methods[0] (pce) needs at "
     "least 20 for 2 inputs"),
    ("quadrature_refused", None, {"methods": [{"name": "pce_tensor", "m": 3}]},
     "methods[0].name: pce_tensor cannot take its design from data: runs.csv (its quadrature "
     "needs its own tensor grid of Gauss nodes); with data: use monte_carlo or pce_adaptive"),
    ("subset_refused", None, {"methods": [{"name": "subset_simulation"}]},
     "methods[0].name: subset_simulation cannot take its design from data: runs.csv"),
    ("size_given", None, {"methods": [{"name": "monte_carlo", "n_samples": 100}]},
     "methods[0].n_samples: 100, but with data: the design is the 40 rows of runs.csv; leave "
     "n_samples out"),
    ("unknown_suffix", None, {"data": "runs.xlsx"},
     "data: runs.xlsx: unknown file type '.xlsx'; allowed: .csv, .parquet, .h5, .hdf5, .npz"),
    ("not_found", None, {"data": "nowhere.csv"},
     "data: nowhere.csv: file not found (a path is relative to the config file's folder)"),
    ("model_and_data", None, {"model": {"name": "ishigami"}},
     "data: give either model: (a simulator to run) or data: (a file of runs already made), "
     "not both"),
]


@pytest.mark.parametrize("case,edit,more,message", BAD, ids=[b[0] for b in BAD])
def test_bad_data_is_one_line_exit_2(tmp_path, case, edit, more, message):
    more = dict(more)
    methods = more.pop("methods", None)
    data = more.pop("data", "runs.csv")
    res = _bad(tmp_path, edit or (lambda L: None), methods, data, **more)
    assert res.exit_code == 2, res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"error: {message}"), lines[0]


# ---------------------------------------------------------------------------- failed rows
def test_nan_outputs_are_failed_runs_counted_never_dropped(tmp_path, caplog):
    x, y = rows(60, 10)
    y[[3, 17, 42]] = np.nan
    write_csv(tmp_path / "runs.csv", x, y)
    with caplog.at_level(logging.WARNING):
        result = uqguide.run(config(tmp_path, methods=[PCE, {"name": "monte_carlo",
                                                             "label": "mc"}]))
    assert "3 of 60 rows have NaN or infinite outputs (rows 4, 18, 43)" in caplog.text
    for label in ("pce", "mc"):
        run = result.run(label)
        assert run.n_runs == 60 and run.n_failed == 3
        assert set(run.reasons[run.failed]) == {"non-finite y in runs.csv"}
    ok = np.isfinite(y)
    assert float(result.run("mc").estimate.stats["y"].mean[0]) == pytest.approx(y[ok].mean(),
                                                                               rel=1e-13)
    # the PCE's fit is exact, but its moments over the whole space are not those conditional
    # on success: withheld, the mean of its successful rows given (+mc)
    assert np.isnan(four(result, "pce")).all()
    pce = result.run("pce").estimate
    assert float(pce.stats["y"].fallback["mean"][0]) == pytest.approx(y[ok].mean(), rel=1e-13)
    assert pce.surrogate(np.array([[0.5, 0.1]]))["y"][0, 0] == pytest.approx(
        float(poly(0.5, 0.1)), abs=1e-10)


def test_rows_flagged_failed_carry_their_own_reason_in_every_format(tmp_path):
    """The ``failed``/``reason`` columns of a command's outputs file, in a data file: a flagged
    row fails with the user's words (a finite value beside the flag does not make it a run),
    a flag without words gets one, and the statistics are those of the other rows."""
    import h5py

    x, y = rows(40, 13)
    flag = np.zeros(40, dtype=int)
    flag[[2, 9, 30]] = 1
    why = np.array([""] * 40, dtype=object)
    why[[2, 9]] = "solver diverged"
    y_file = y.copy()
    y_file[2] = np.nan  # one flagged row has no output at all, the others keep theirs
    lines = ["a,b,y,failed,reason"] + [
        f"{float(x[i, 0])!r},{float(x[i, 1])!r},"
        f"{'' if np.isnan(y_file[i]) else repr(float(y_file[i]))},"
        f"{flag[i] or ''},{why[i]}" for i in range(40)]
    (tmp_path / "runs.csv").write_text("\n".join(lines) + "\n")
    np.savez(tmp_path / "runs.npz", a=x[:, 0], b=x[:, 1], y=y_file, failed=flag,
             reason=why.astype(str))
    with h5py.File(tmp_path / "runs.h5", "w") as f:
        for k, v in {"a": x[:, 0], "b": x[:, 1], "y": y_file, "failed": flag}.items():
            f[k] = v
        f["reason"] = why.astype(str).astype(bytes)
    ok = flag == 0
    for name in ("runs.csv", "runs.npz", "runs.h5"):
        run = uqguide.run(config(tmp_path, name, methods=[{"name": "monte_carlo", "label": "mc"}],
                                 max_failed_fraction=0.1)).run("mc")
        np.testing.assert_array_equal(run.failed, ~ok)
        assert list(run.reasons[~ok]) == ["solver diverged", "solver diverged",
                                          f"marked failed in {name}"], name
        assert float(run.estimate.stats["y"].mean[0]) == pytest.approx(y[ok].mean(), rel=1e-13)
    bad = lines[:]
    bad[5] = bad[5].rsplit(",", 2)[0] + ",2,"
    (tmp_path / "runs.csv").write_text("\n".join(bad) + "\n")
    with pytest.raises(ConfigError, match=r"row 5 \(line 6\), column 'failed': 2 is not 0 or 1"):
        uqguide.load_config(config(tmp_path))


# ---------------------------------------------------------------------------- goodness of fit
def test_rows_from_another_distribution_are_warned_not_refused(tmp_path, caplog):
    x, y = rows(200, 11)
    x[:, 1] *= 0.5  # b drawn with std 0.5, the config says 1
    write_csv(tmp_path / "runs.csv", x, poly(x[:, 0], x[:, 1]))
    mc = [{"name": "monte_carlo", "label": "mc"}]
    with caplog.at_level(logging.WARNING):
        uqguide.load_config(config(tmp_path, methods=mc))
    assert "column 'b' does not look like draws from normal(mean=0, std=1)" in caplog.text
    assert "column 'a'" not in caplog.text
    caplog.clear()
    x, y = rows(200, 11)
    write_csv(tmp_path / "runs.csv", x, y)
    with caplog.at_level(logging.WARNING):
        uqguide.load_config(config(tmp_path, methods=mc))
    assert "does not look like" not in caplog.text


# ---------------------------------------------------------------------------- formats
def test_hdf5_and_npz_give_the_numbers_of_the_csv(tmp_path):
    import h5py

    x, y = rows(40, 12)
    write_csv(tmp_path / "runs.csv", x, y)
    ref = four(uqguide.run(config(tmp_path)), "pce")
    np.savez(tmp_path / "runs.npz", a=x[:, 0], b=x[:, 1], y=y)
    with h5py.File(tmp_path / "runs.h5", "w") as f:
        for k, v in {"a": x[:, 0], "b": x[:, 1], "y": y}.items():
            f[k] = v
    for name in ("runs.npz", "runs.h5"):
        assert np.array_equal(four(uqguide.run(config(tmp_path, name)), "pce"), ref)


def test_a_series_from_step_columns_with_its_time_grid(tmp_path):
    x, y = rows(50, 13)
    t = np.array([0.0, 0.5, 2.0])
    path = y[:, None] * t[None, :]
    cols = np.column_stack([x, y, path])
    header = "a,b,y,path[0],path[1],path[2]"
    (tmp_path / "runs.csv").write_text(header + "\n" + "\n".join(
        ",".join(repr(v) for v in r) for r in cols.tolist()) + "\n")
    result = uqguide.run(config(tmp_path, {"path": "runs.csv", "time": t.tolist()},
                                [{"name": "monte_carlo", "label": "mc"}]))
    assert np.array_equal(result.time, t)
    st = result.run("mc").estimate.stats["path"]
    assert np.allclose(st.mean[:, 0], y.mean() * t, rtol=1e-13)
    assert result.config["data"]["time"] == t.tolist()


# ---------------------------------------------------------------------------- validation
def test_held_out_rows_validate_the_fit(tmp_path):
    x, y = rows(60, 14)
    write_csv(tmp_path / "runs.csv", x, y)
    pce = {**PCE, "validation": {"n_samples": 15, "design": "random"}}
    run = uqguide.run(config(tmp_path, methods=[pce])).run("pce")
    d = run.estimate.diagnostics
    assert d["n_validation"] == 15 and d["n_runs"] == 45 and run.n_runs == 60
    assert d["validation_error.y"] < 1e-20  # the exact polynomial predicts the held-out rows


# ---------------------------------------------------------------------------- downstream
def test_the_result_file_keeps_the_surrogate_without_the_data_file(tmp_path, monkeypatch):
    x, y = rows(40, 15)
    write_csv(tmp_path / "runs.csv", x, y)
    written = uqguide.run(config(tmp_path, name="fitted"), out=tmp_path / "out")
    (tmp_path / "runs.csv").unlink()
    monkeypatch.chdir(tmp_path / "out")
    back = uqguide.read_result("fitted.h5")
    assert back.config["data"]["path"] == "runs.csv" and back.config["model"] is None
    u = np.array([[0.25, 0.5]])
    sur = back.surrogate("pce")
    assert sur.at_unit(u, ["y"])["y"].ravel() == pytest.approx(
        written.surrogate("pce").at_unit(u, ["y"])["y"].ravel(), rel=1e-15)
    assert sur.at_unit(u, ["y"])["y"].ravel()[0] == pytest.approx(poly(-0.5, 0.0), abs=1e-12)


def test_a_changed_data_file_is_refused_by_its_stored_config(tmp_path):
    from uqguide.config.run_config import validate_config

    x, y = rows(40, 16)
    write_csv(tmp_path / "runs.csv", x, y)
    result = uqguide.run(config(tmp_path))
    write_csv(tmp_path / "runs.csv", x, y + 1)
    with pytest.raises(ConfigError, match="the file changed since this config was stored"):
        validate_config(result.config, str(tmp_path / "stored"))


# ---------------------------------------------------------------------------- suggest
def test_suggest_fills_the_empty_half_and_the_loop_closes(tmp_path):
    rng = np.random.default_rng(17)
    x = np.column_stack([rng.uniform(-1, 0, 60), rng.standard_normal(60)])  # a in [-1, 0]
    write_csv(tmp_path / "runs.csv", x, poly(x[:, 0], x[:, 1]))
    cfg = config(tmp_path, methods=[PCE])
    checked = CliRunner().invoke(main, ["validate", str(cfg)])
    assert f"{cfg}: OK — data runs.csv (60 rows), 2 uncertain inputs (a, b)" in checked.output
    out = tmp_path / "next.csv"
    res = CliRunner().invoke(main, ["suggest", str(cfg), "--n", "8", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert res.output == f"wrote {out} (8 runs)\n"
    lines = out.read_text().splitlines()
    assert lines[0] == "a,b" and len(lines) == 9
    new = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    assert (new[:, 0] > 0).all()  # the largest holes: the half the file never ran
    again = tmp_path / "again.csv"
    CliRunner().invoke(main, ["suggest", str(cfg), "--n", "8", "--out", str(again)])
    assert again.read_text() == out.read_text()  # same config and seed, same points
    refused = CliRunner().invoke(main, ["suggest", str(cfg), "--n", "8", "--out", str(out)])
    assert refused.exit_code == 2 and "exists" in refused.stderr
    # the loop: run them elsewhere, append, fit again
    both = np.vstack([x, new])
    write_csv(tmp_path / "runs.csv", both, poly(both[:, 0], both[:, 1]))
    assert uqguide.run(cfg).run("pce").n_runs == 68


def test_suggest_needs_data(tmp_path, write_config, lognormal_config):
    res = CliRunner().invoke(main, ["suggest", str(write_config(lognormal_config)), "--n",
                                    "3", "--out", str(tmp_path / "n.csv")])
    assert res.exit_code == 2
    assert "suggest extends the rows of a data file" in res.stderr


@pytest.mark.slow
def test_workers_report_plots_and_the_gate_work_on_a_data_result(tmp_path):
    x, y = rows(80, 20)
    write_csv(tmp_path / "runs.csv", x, y)
    cfg = config(tmp_path, methods=[PCE, {"name": "monte_carlo", "label": "mc"}], name="d")
    runner = CliRunner()
    serial = runner.invoke(main, ["run", str(cfg), "--out", str(tmp_path / "a"), "-q"])
    pool = runner.invoke(main, ["run", str(cfg), "--out", str(tmp_path / "b"), "-q",
                                "--workers", "2"])
    assert serial.exit_code == 0 and pool.exit_code == 0, serial.output + pool.output
    a, b = uqguide.read_result(tmp_path / "a" / "d.h5"), uqguide.read_result(tmp_path / "b" /
                                                                          "d.h5")
    for label in ("pce", "mc"):
        assert np.array_equal(four(a, label), four(b, label))
    h5 = str(tmp_path / "a" / "d.h5")
    base = str(tmp_path / "base.json")
    for args in (["baseline", h5, "-o", base], ["check", h5, "--baseline", base],
                 ["report", h5], ["plot", h5]):
        res = runner.invoke(main, args)
        assert res.exit_code == 0, (args, res.output)
    assert (tmp_path / "a" / "d_report.md").read_text().count("Sobol")


# ---------------------------------------------------------------------------- acceptance
ISHIGAMI = [{"name": f"x{i}", "dist": "uniform", "low": -math.pi, "high": math.pi}
            for i in (1, 2, 3)]


def ishigami_exact() -> np.ndarray:
    """Mean and std in closed form (Ishigami & Homma); skewness 0 (y - mean is a sum of
    independent symmetric terms); kurtosis by an 80-point Gauss-Legendre tensor rule, exact to
    round-off for this entire function."""
    from uqguide.models.benchmarks import Ishigami

    ex = Ishigami().exact()
    g, w = np.polynomial.legendre.leggauss(80)
    g, w = g * math.pi, w / 2
    X1, X2, X3 = np.meshgrid(g, g, g, indexing="ij")
    W = w[:, None, None] * w[None, :, None] * w[None, None, :]
    y = np.sin(X1) + 7 * np.sin(X2) ** 2 + 0.1 * X3**4 * np.sin(X1)
    c = y - ex["mean"]
    return np.array([ex["mean"], math.sqrt(ex["variance"]), 0.0,
                     float((W * c**4).sum()) / ex["variance"] ** 2])


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_ishigami_500_iid_rows_give_the_four_moments_within_1e_6(tmp_path, seed):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-math.pi, math.pi, (500, 3))
    y = np.sin(x[:, 0]) + 7 * np.sin(x[:, 1]) ** 2 + 0.1 * x[:, 2] ** 4 * np.sin(x[:, 0])
    write_csv(tmp_path / "runs.csv", x, y, ("x1", "x2", "x3", "y"))
    p = tmp_path / "ish.yaml"
    p.write_text(yaml.safe_dump({"data": "runs.csv", "inputs": ISHIGAMI,
                                 "methods": [{"name": "pce_adaptive"}]}))
    got = four(uqguide.run(p), "pce_adaptive")
    assert np.all(np.abs(got - ishigami_exact()) < 1e-6), got - ishigami_exact()
    assert np.array_equal(four(uqguide.fit(x, y, inputs=ISHIGAMI), "pce_adaptive"), got)


# ---------------------------------------------------------------------------- the docs
def test_the_documented_example_gives_the_documented_numbers(tmp_path, monkeypatch):
    """docs/your-simulator.md, "Your own samples": its script and config, run in this process
    (the page's blocks run as subprocesses only in the slow suite)."""
    import runpy

    from tests.doc_pages import ROOT, blocks

    files = {b.file_name: b.body for b in blocks(ROOT / "docs" / "your-simulator.md")}
    for name in ("make_runs.py", "samples.yaml"):
        (tmp_path / name).write_text(files[name])
    page = (ROOT / "docs" / "your-simulator.md").read_text()
    monkeypatch.chdir(tmp_path)
    runpy.run_path("make_runs.py")
    result = uqguide.run("samples.yaml")
    mean, std = (math.expm1(0.6) / 0.6 * math.exp(-1 / 8),
                 math.sqrt(math.expm1(1.2) / 1.2 * (1 + math.exp(-0.5)) / 2
                           - (math.expm1(0.6) / 0.6 * math.exp(-1 / 8)) ** 2))
    assert "1.20920" in page and "0.30150" in page and f"{mean:.5f}" == "1.20920"
    assert f"{std:.5f}" == "0.30150"
    pce = result.run("pce")
    assert pce.n_failed == 1 and pce.estimate.diagnostics["n_validation"] == 50
    # the surrogate's error is at most sqrt(LOO error x variance) in L2 (Cauchy-Schwarz for
    # the mean; the std moves by no more), four times that for the LOO estimate's own spread
    # its own moments are conditional on success (one scattered failed row: the success region
    # is the whole space), each interval holding the closed form
    s = pce.estimate.stats["y"]
    for stat, truth in (("mean", mean), ("std", std)):
        low, high = s.ci[stat][:, 0]
        assert low <= truth <= high, (stat, low, truth, high)
    tol = 4 * math.sqrt(pce.estimate.diagnostics["loo_error"]) * std
    from uqguide.pce.outputs import joint_scalar_moments

    _, m, cov = joint_scalar_moments([("y", pce.estimate.surrogate.expansions["y"])])
    assert [m[0], math.sqrt(cov[0, 0])] == pytest.approx([mean, std], rel=0, abs=tol)
    mc = result.run("mc").estimate.stats["y"]
    assert abs(float(mc.mean[0]) - mean) < 4 * float(mc.sem[0])
    # nothing withheld, so no +mc; the +cv mean over the successful validation runs holds it
    assert not s.fallback
    lo, hi = s.corrected_ci["mean"][:, 0]
    assert lo <= mean <= hi


def test_an_hdf5_series_with_its_time_dataset_and_report_times(tmp_path):
    import h5py

    x, y = rows(30, 18)
    t = np.array([0.0, 1.0, 3.0, 4.0])
    with h5py.File(tmp_path / "runs.h5", "w") as f:
        f["a"], f["b"], f["time"] = x[:, 0], x[:, 1], t
        f["path"] = y[:, None] * t[None, :]
    mc = [{"name": "monte_carlo", "label": "mc"}]
    result = uqguide.run(config(tmp_path, "runs.h5", mc, report_times=[3.0]))
    assert np.array_equal(result.time, t)
    assert np.allclose(result.run("mc").estimate.stats["path"].mean[:, 0], y.mean() * t,
                       rtol=1e-13)
    with pytest.raises(ConfigError, match=r"report_times\[0\]: 9 s is outside the model's "
                                          r"time grid \[0, 4\] s"):
        uqguide.run(config(tmp_path, "runs.h5", mc, report_times=[9.0]))


def test_parquet_without_an_engine_says_what_to_install(tmp_path):
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        pass
    else:
        pytest.skip("pyarrow is installed: Parquet files are read")
    (tmp_path / "runs.parquet").write_bytes(b"PAR1")
    with pytest.raises(ConfigError, match=r"data: runs.parquet: reading Parquet needs pyarrow"):
        uqguide.load_config(config(tmp_path, "runs.parquet"))


def test_the_unit_cube_and_germ_maps_invert_those_of_the_designs():
    """``InputSpace.to_unit`` inverts ``from_unit`` and ``Germ.from_physical`` inverts
    ``to_physical``, for every marginal and a correlated normal group (the data's rows reach
    the fit and the design extension through them)."""
    from uqguide.core.inputs import CorrelatedGroup, InputSpace, LogNormal, Normal, \
        TruncNormal, Uniform
    from uqguide.pce.germ import Germ

    space = InputSpace([Normal(name="n1", dist="normal", mean=1.0, std=2.0),
                        Normal(name="n2", dist="normal", mean=-1.0, std=0.5),
                        Uniform(name="u", dist="uniform", low=2.0, high=5.0),
                        LogNormal(name="l", dist="lognormal", mu=0.1, sigma=0.3),
                        TruncNormal(name="t", dist="truncnormal", mean=0.0, std=1.0,
                                    low=-1.0, high=2.0)],
                       [CorrelatedGroup((0, 1), np.array([[1.0, 0.6], [0.6, 1.0]]))])
    u = np.random.default_rng(19).uniform(0.01, 0.99, (50, 5))
    assert np.allclose(space.to_unit(space.from_unit(u)), u, rtol=0, atol=1e-12)
    germ = Germ.of(space)
    xi = germ.from_unit(u)
    assert np.allclose(germ.from_physical(germ.to_physical(xi)), xi, rtol=0, atol=1e-12)


def test_fit_takes_a_dataset_series_with_its_time_coordinate_and_monte_carlo():
    import xarray as xr

    x, y = rows(40, 21)
    t = np.array([0.0, 2.0, 5.0])
    ds = xr.Dataset({"a": ("run", x[:, 0]), "b": ("run", x[:, 1]),
                     "path": (("run", "t"), y[:, None] * t[None, :])}, coords={"t": t})
    result = uqguide.fit(ds[["a", "b"]], ds[["path"]], inputs=INPUTS, method="monte_carlo")
    assert np.array_equal(result.time, t)
    st = result.run("monte_carlo").estimate.stats["path"]
    assert np.allclose(st.mean[:, 0], y.mean() * t, rtol=1e-13)


# ---------------------------------------------------------------------------- hostile files
def _validate(tmp_path, name: str, **more):
    res = CliRunner().invoke(main, ["validate", str(config(tmp_path, name, **more))])
    assert "Traceback" not in res.output
    return res.exit_code, res.stderr.strip()


def test_a_byte_order_mark_is_stripped_as_csv_readers_do(tmp_path):
    x, y = rows(40, 22)
    plain = write_csv(tmp_path / "runs.csv", x, y).read_bytes()
    (tmp_path / "bom.csv").write_bytes(b"\xef\xbb\xbf" + plain)
    ref = four(uqguide.run(config(tmp_path)), "pce")
    assert np.array_equal(four(uqguide.run(config(tmp_path, "bom.csv")), "pce"), ref)
    # anywhere but the start of the file it is part of a name, and refused
    (tmp_path / "mid.csv").write_bytes(plain.replace(b"a,b,y", b"a,\xef\xbb\xbfb,y", 1))
    assert _validate(tmp_path, "mid.csv") == (
        2, "error: data: mid.csv: line 1, column 2: column name '\\ufeffb' holds a byte-order "
           "mark U+FEFF; a column name is printable text")


NAMES = [
    ("repeated", "a,b,y,a", "line 1, column 4: column 'a' appears twice (also line 1, column 1); "
                            "each column needs its own name"),
    ("control", "a,b,y\x07", "line 1, column 3: column name 'y\\x07' holds a control character "
                             "U+0007; a column name is printable text"),
    ("nul", "a,b,y\x00z", "line 1, column 3: column name 'y\\x00z' holds a control character "
                          "U+0000"),
    ("empty", "a,b,,y", "line 1, column 3: empty column name"),
    ("too_long", "a,b," + "y" * 201, "line 1, column 3: a column name of 201 characters "
                                     "('yyyyyyyyyyyyyyyyyyyy'...); allowed at most 200"),
    # an index this large once built range(10^11) to find the gap
    ("huge_step", "a,b,y[99999999999]", "column y[0] is missing (series 'y' has steps up to "
                                        "y[99999999999]; its columns must be y[0], y[1], ... "
                                        "without gaps)"),
    ("same_step", "a,b,y[0],y[1],y[01]", "line 1, column 5: columns 'y[1]' and 'y[01]' are both "
                                         "step 1 of series 'y'"),
    ("not_an_output_name", "a,b,T (K)", "column 'T (K)' cannot name an output: an output's name "
                                        "must be 1 to 200 letters"),
]


@pytest.mark.parametrize("case,header,message", NAMES, ids=[n[0] for n in NAMES])
def test_a_bad_column_name_is_one_line_exit_2_before_a_value_is_read(tmp_path, case, header,
                                                                    message):
    cols = len(next(csv.reader([header])))
    x, _ = rows(40, 23)
    body = [",".join(repr(float(v)) for v in np.resize(r, cols)) for r in x]
    (tmp_path / "runs.csv").write_text(header + "\n" + "\n".join(body) + "\n")
    code, err = _validate(tmp_path, "runs.csv")
    assert code == 2 and len(err.splitlines()) == 1, err
    assert err.startswith(f"error: data: runs.csv: {message}"), err


def test_a_cell_over_its_limit_is_refused_naming_line_and_column(tmp_path):
    from uqguide.models.data_rows.claims import MAX_NUMBER_CHARS, line_limit

    x, y = rows(40, 24)
    lines = write_csv(tmp_path / "runs.csv", x, y).read_text().splitlines()
    lines[3] = lines[3].rsplit(",", 1)[0] + "," + "1" * (MAX_NUMBER_CHARS + 1)
    (tmp_path / "runs.csv").write_text("\n".join(lines) + "\n")
    assert _validate(tmp_path, "runs.csv") == (
        2, "error: data: runs.csv: line 4, column 'y': a cell of 65 characters; allowed at "
           "most 64 (a number)")
    # a line longer than its cells can be is refused by the count of lines, before it is read
    limit = line_limit(("a", "b", "y"))
    lines[3] = lines[3].rsplit(",", 1)[0] + "," + "1" * 10**6
    (tmp_path / "runs.csv").write_text("\n".join(lines) + "\n")
    assert _validate(tmp_path, "runs.csv") == (
        2, f"error: data: runs.csv: line 4 is longer than {limit} bytes, what 3 cells can take: "
           f"a cell is at most 64 characters (a number) or 4,096 (a reason)")


def _over_memory(source: str, need: str, what: str) -> str:
    return (f"error: data: {source}: reading it needs an estimated {need} ({what}), more than "
            f"max_memory = 300 MB; split the file or keep fewer columns, or raise max_memory "
            f"if the machine has it")


def test_headers_claiming_terabytes_are_refused_against_max_memory_before_reading(tmp_path):
    import h5py

    # a chunked dataset claims its shape without storing it: 8 TB in a file of a few kB
    with h5py.File(tmp_path / "runs.h5", "w") as f:
        f.create_dataset("a", shape=(10**12,), dtype="f8", chunks=(2**16,))
        f.create_dataset("b", shape=(10**12,), dtype="f8", chunks=(2**16,))
        f.create_dataset("y", shape=(10**12,), dtype="f4", chunks=(2**16,))
    assert (tmp_path / "runs.h5").stat().st_size < 10**5
    assert _validate(tmp_path, "runs.h5", max_memory="300 MB") == (2, _over_memory(
        "runs.h5", "156 TB", "3 datasets, the largest 'a' of shape (1000000000000,) float64"))
    # a sparse CSV: two bytes a row, 16 a value once read, and the rows' checks
    (tmp_path / "runs.csv").write_text("a,b,y\n" + ",,\n" * 10**6)
    assert _validate(tmp_path, "runs.csv", max_memory="300 MB") == (2, _over_memory(
        "runs.csv", "419 MB", "1,000,000 rows x 3 columns"))


def test_an_npz_header_claiming_more_than_its_member_holds_is_refused(tmp_path):
    import io
    import zipfile

    x, y = rows(40, 25)
    np.savez(tmp_path / "runs.npz", a=x[:, 0], b=x[:, 1], y=y)
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False,
                                               "shape": (10**12,)})
    with zipfile.ZipFile(tmp_path / "runs.npz", "a") as z:
        z.writestr("big.npy", buf.getvalue() + y.tobytes())
    assert _validate(tmp_path, "runs.npz") == (
        2, "error: data: runs.npz: member 'big.npy': its header claims shape (1000000000000,) "
           "float64, 8,000,000,000,000 bytes, but the member holds 320; save the runs with "
           "numpy.savez")
    with zipfile.ZipFile(tmp_path / "pickled.npz", "w") as z:
        buf = io.BytesIO()
        np.save(buf, np.array([{"a": 1}], dtype=object), allow_pickle=True)
        z.writestr("a.npy", buf.getvalue())
    code, err = _validate(tmp_path, "pickled.npz")
    assert code == 2 and "its header claims shape (1,) object, Python objects (pickled), which "\
                         "are never loaded" in err


def test_a_parquet_files_metadata_is_its_claim(tmp_path, monkeypatch):
    """pyarrow's metadata (here a stand-in: pyarrow is an optional dependency) gives rows and
    columns; a file claiming 10^10 rows is refused before pandas reads it."""
    import sys
    import types

    class Meta:
        num_rows, num_columns = 10**10, 3

    pq = types.ModuleType("pyarrow.parquet")
    pq.ParquetFile = lambda path: types.SimpleNamespace(metadata=Meta())  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "pyarrow", types.ModuleType("pyarrow"))
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", pq)
    (tmp_path / "runs.parquet").write_bytes(b"PAR1")
    assert _validate(tmp_path, "runs.parquet", max_memory="300 MB") == (2, _over_memory(
        "runs.parquet", "2 TB", "10,000,000,000 rows x 3 columns"))


def test_fit_refuses_a_repeated_or_unprintable_column_name():
    import pandas as pd

    x, y = rows(40, 26)
    frame = pd.DataFrame(np.column_stack([x, x[:, :1]]), columns=["a", "b", "a"])
    with pytest.raises(ConfigError, match=r"^data: x: column 3: column 'a' appears twice \(also "
                                          r"column 1\)"):
        uqguide.fit(frame, y, inputs=INPUTS)
    with pytest.raises(ConfigError, match=r"column name 'y\\ufeff' holds a byte-order mark"):
        uqguide.fit(x, pd.DataFrame({"y\ufeff": y}), inputs=INPUTS, method="monte_carlo")


# ---------------------------------------------------------------------------- too few runs
@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_a_statistic_of_fewer_runs_than_it_needs_is_printed_as_needs_n_runs(tmp_path, n):
    """One run's std is 0, two runs' skewness 0 and kurtosis 1, three runs' kurtosis 1.5,
    whatever the output: such a value is NaN and the table says how many runs it needs."""
    x, y = rows(n, 27)
    write_csv(tmp_path / "runs.csv", x, y)
    res = CliRunner().invoke(main, ["run", str(config(tmp_path, methods=[
        {"name": "monte_carlo", "label": "mc"}])), "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    table = res.output.split("scalar output of runs.csv\n", 1)[1].split("\n\n", 1)[0]
    row = table.splitlines()[1]
    needs = [f"needs {k} runs" for k, name in ((2, "std"), (3, "skewness"), (4, "kurtosis"))
             if n < k]
    assert [s for s in needs if s in row] == needs, row
    st = uqguide.read_result(tmp_path / "o" / "data.h5").run("mc").estimate.stats["y"]
    assert float(st.mean[0]) == pytest.approx(y.mean(), rel=1e-14)
    got = [float(st.std[0]), float(st.skewness[0]), float(st.kurtosis[0])]
    assert [math.isnan(v) for v in got] == [n < 2, n < 3, n < 4]
    if n == 1:  # the mean's interval needs a standard deviation too
        assert row.split()[1] == f"{float(y[0]):.4g}" and "[" not in row
        key = " ".join(res.output.split("Key (all of it: docs/statistics.md):")[1].split())
        assert "needs n runs fewer runs than the statistic takes to say anything" in key
    if n == 4:
        assert "needs" not in row
        assert float(st.std[0]) == pytest.approx(y.std(), rel=1e-13)


def test_the_run_budget_counts_the_data_table_and_its_copies_in_flight(tmp_path):
    from uqguide.config.budget import estimate

    x, y = rows(40, 28)
    write_csv(tmp_path / "runs.csv", x, y)
    cfg = uqguide.load_config(config(tmp_path, methods=[{"name": "monte_carlo"}]))
    serial, pooled = estimate(cfg), estimate(cfg, workers=2)
    assert (serial.data_bytes, serial.data_copies, pooled.data_copies) == (40 * 3 * 8, 1, 5)
    assert "  data table: 960 B" in serial.lines()
    assert pooled.peak_bytes - serial.peak_bytes >= 4 * 960


#: Runs uqguide's command line and writes the process's peak RSS (VmHWM, in kB) to argv[1]:
#: the figure of this program alone (wait4's ru_maxrss of a child also counts the RSS its
#: parent had when it forked).
_HWM = """import atexit, runpy, sys
def _hwm(path=sys.argv[1]):
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            open(path, "w").write(line.split()[1])
atexit.register(_hwm)
sys.argv = ["uqguide"] + sys.argv[2:]
runpy.run_module("uqguide.cli", run_name="__main__")
"""


def _peak_rss_of(args: list[str], cwd: Path) -> tuple[int, float, str]:
    """Exit code, peak RSS [bytes] and stderr of ``uqguide <args>`` run as a child."""
    import os
    import subprocess
    import sys

    if not Path("/proc/self/status").is_file():
        pytest.skip("the peak RSS of a process is read from /proc (Linux)")
    root = Path(__file__).resolve().parents[1]
    hwm = cwd / "hwm.txt"
    proc = subprocess.run([sys.executable, "-c", _HWM, str(hwm), *args], cwd=cwd,
                          env={**os.environ, "PYTHONPATH": str(root)}, capture_output=True,
                          text=True)
    return proc.returncode, float(hwm.read_text()) * 1024, proc.stderr


@pytest.mark.slow
def test_reading_stays_under_its_estimate_and_a_refusal_reads_nothing(tmp_path):
    """A CSV of 200,000 rows is read at a peak under uqguide's own estimate of it (which
    max_memory is checked against); a 200 MB sparse CSV over max_memory is refused at a peak
    under the interpreter's share of the estimate (BASE_BYTES): none of it is held."""
    from uqguide.config.data_source import read_bytes
    from uqguide.config.limits import BASE_BYTES
    from uqguide.models.data_rows.claims import csv_claim

    rng = np.random.default_rng(29)
    x = rng.uniform(-1, 1, (200_000, 2))
    x[:, 1] = rng.standard_normal(200_000)
    write_csv(tmp_path / "runs.csv", x, poly(x[:, 0], x[:, 1]))
    cfg = config(tmp_path, methods=[{"name": "monte_carlo"}])
    code, peak, err = _peak_rss_of(["validate", str(cfg)], tmp_path)
    estimate = read_bytes(csv_claim(tmp_path / "runs.csv", "runs.csv"), 2)
    assert code == 0, err
    assert peak < estimate, (peak, estimate)
    with (tmp_path / "sparse.csv").open("wb") as f:
        f.write(b"a,b,y\n")
        for _ in range(50):
            f.write(b",,\n" * (2**22 // 3))
    cfg = config(tmp_path, "sparse.csv", methods=[{"name": "monte_carlo"}], max_memory="1 GB")
    code, peak, err = _peak_rss_of(["validate", str(cfg)], tmp_path)
    assert code == 2 and "more than max_memory = 1 GB" in err, err
    assert peak < BASE_BYTES, peak
