"""Figures and the Markdown report: files written, labels with units, legends, PCE densities."""

from __future__ import annotations

import copy
import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from matplotlib.image import imread

from uqguide.cli import main
from uqguide.config.run_config import validate_config
from uqguide.report.plots import (
    _moment_density, cost_figure, scalar_figure, series_figure, write_figures,
)
from uqguide.driver.propagate import run
from uqguide.report.document import write_report


def _texts(fig) -> list[str]:
    """Every text of a figure, table cells included, stripped."""
    out = []
    for a in fig.findobj(lambda a: hasattr(a, "get_text")):
        t = a.get_text()
        out.append((t if isinstance(t, str) else t.get_text()).strip())
    return out


@pytest.fixture(scope="module")
def result():
    """linear_gaussian with MC (reference), a small LHS MC and a PCE-like copy of the LHS run
    (moments_method exact, no sample statistics), units set to m and m/s for the label checks."""
    cfg = {
        "model": {"name": "linear_gaussian", "n_times": 21},
        "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 1.0, "std": 1.0} for i in (1, 2, 3)],
        "outputs": ["y", "ramp"],
        "report_times": [0.0, 0.5],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 2000},
                    {"name": "monte_carlo", "label": "lhs", "n_samples": 100, "sampling": "lhs"}],
        "reference": "mc",
        "seed": 3,
    }
    r = run(validate_config(cfg))
    pce = copy.deepcopy(r.run("lhs"))
    pce.estimate.label, pce.estimate.method = "apce", "pce_adaptive"
    for s in pce.estimate.stats.values():
        s.moments_method, s.sem, s.ci = "exact", None, {}
    r.runs.append(pce)
    units = {"y": "m/s", "ramp": "m"}
    r.outputs = [dataclasses.replace(o, unit=units[o.name]) for o in r.outputs]
    return r


def test_series_figure_has_units_titles_and_one_line_per_method(result):
    fig = series_figure(result, "ramp", 1)
    axes = fig.axes
    assert [a.get_ylabel() for a in axes] == [
        "ramp[y2] [m]", "std of ramp[y2] [m]", "skewness of ramp[y2] [-]",
        "kurtosis of ramp[y2] [-]"]
    assert [a.get_xlabel() for a in axes[2:]] == ["time [s]", "time [s]"]
    assert [a.get_title() for a in axes] == ["Mean, shaded: mean $\\pm$ 1 std",
                                             "Standard deviation", "Skewness",
                                             "Kurtosis (non-excess)"]
    assert fig.get_suptitle().startswith("run: ramp[y2] [m] over time")
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend == ["mc (MC, 2000 runs)", "lhs (MC, 100 runs)", "apce (adaptive PCE, 100 runs)",
                      "Gaussian (skewness 0, kurtosis 3)"]
    # the std panel's method lines carry the estimates: last point = std of y2 (t = 1)
    std_lines = [ln for ln in axes[1].get_lines() if len(ln.get_xdata()) == result.time.size]
    assert len(std_lines) == 3
    np.testing.assert_allclose(std_lines[0].get_ydata()[-1],
                               result.run("mc").estimate.stats["ramp"].std[-1, 1])


def test_scalar_figure_histograms_mc_and_draws_the_pce_moment_density(result):
    fig = scalar_figure(result, "y")
    ax0 = fig.axes[0]
    assert ax0.get_xlabel() == "y[y1] [m/s]"
    assert ax0.get_ylabel() == "probability density [1/m/s]"
    legend = fig.legends[0]
    labels = [t.get_text() for t in legend.get_texts()]
    assert labels[0].startswith("mc (MC, 2000 runs) histogram: mean ")
    assert labels[2].startswith("apce (adaptive PCE, 100 runs)*: ")
    assert "the result holds no surrogate" in legend.get_title().get_text()
    # the PCE curve integrates to ~1 over the axis (0.1-99.9% of the samples: nearly all mass)
    curve = ax0.get_lines()[-1]
    x, y = curve.get_xdata(), curve.get_ydata()
    assert np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x)) == pytest.approx(1.0, abs=0.02)


def test_moment_density_has_the_pce_moments():
    d = _moment_density(8.8, 6.6, 1.03)
    m, v, s = d.stats("mvs")
    assert (float(m), float(np.sqrt(v)), float(s)) == pytest.approx((8.8, 6.6, 1.03), rel=1e-12)
    assert _moment_density(1.0, 0.0, np.nan) is None


def test_surrogate_draws_are_drawn_as_a_density_when_a_run_has_them(result):
    r = copy.deepcopy(result)
    pce = r.run("apce")
    rng = np.random.default_rng(0)
    pce.surrogate_scalars = {"y": rng.normal(size=(5000, 2))}  # optional attribute of the hook
    labels = [t.get_text() for t in scalar_figure(r, "y").legends[0].get_texts()]
    assert labels[2].startswith("apce (adaptive PCE, 100 runs) surrogate density (KDE of 5,000 "
                                "draws): ")


def test_cost_figure_shows_every_method(result):
    fig = cost_figure(result)
    texts = _texts(fig)
    for label in ("mc", "lhs", "apce", "2000", "100", "pce_adaptive"):
        assert label in texts
    assert "model runs [-]" in [a.get_xlabel() for a in fig.axes]
    assert "wall time [s]" in [a.get_xlabel() for a in fig.axes]


def _overflow(fig) -> float:
    """How far [in] anything drawn reaches past the figure's edges (0 when nothing does)."""
    fig.canvas.draw()
    box = fig.get_tightbbox(fig.canvas.get_renderer())
    w, h = fig.get_size_inches()
    return max(0.0, -box.x0, -box.y0, box.x1 - w, box.y1 - h)


@pytest.mark.slow  # draws each figure twice; the shipped results' figures are checked too
def test_the_cost_table_and_the_histogram_legend_fit_their_figure(result):
    """The cost figure's table (with a method's list of outputs as a column) ran 10 inches past
    the right edge, a histogram's legend line half an inch."""
    run = result.run("apce")
    diagnostics = run.estimate.diagnostics
    try:
        diagnostics["validation_error.ramp"] = 0.5  # listed as "no usable surrogate: ramp ..."
        diagnostics.update({f"validation_error.out{i}": 0.3 for i in range(12)})
        assert _overflow(cost_figure(result)) <= 0.02
    finally:
        for k in [k for k in diagnostics if k.startswith("validation_error.")]:
            del diagnostics[k]
    assert _overflow(scalar_figure(result, "y")) <= 0.02


def test_save_writes_the_format_its_suffix_names(tmp_path):
    from uqguide.report.figures import new_figure, save

    fig = new_figure((2.0, 1.5))
    fig.add_subplot().plot([0, 1], [0, 1])
    heads = {fmt: save(fig, tmp_path / f"f.{fmt}").read_bytes()[:5]
             for fmt in ("png", "svg", "pdf")}
    assert heads == {"png": b"\x89PNG\r", "svg": b"<?xml", "pdf": b"%PDF-"}


@pytest.mark.slow
def test_plot_writes_vector_formats(result, tmp_path):
    from uqguide.results.result import write_hdf5

    path = write_hdf5(result, tmp_path / "r.h5")
    res = CliRunner().invoke(main, ["plot", str(path), "--format", "svg", "--out",
                                    str(tmp_path / "f")])
    assert res.exit_code == 0, res.output
    svgs = sorted(tmp_path.joinpath("f").glob("*.svg"))
    assert [p.name for p in svgs] and not list(tmp_path.joinpath("f").glob("*.png"))
    assert all(p.read_text().lstrip().startswith("<?xml") for p in svgs)


@pytest.mark.slow
def test_every_shipped_results_figures_fit_their_canvas(monkeypatch, tmp_path):
    """Issue 47's figures test: nothing of any figure of the results in results/ drawn past
    the figure's edges."""
    import uqguide.report.plots as plots
    from uqguide.results.result import read_hdf5

    reach: dict[str, float] = {}
    monkeypatch.setattr(plots, "save", lambda fig, path, **kw: reach.setdefault(
        Path(path).name, _overflow(fig)) and Path(path))
    shipped = sorted(Path(__file__).resolve().parents[1].glob("results/*/*.h5"))
    assert len(shipped) >= 10
    for h5 in shipped:
        plots.write_figures(read_hdf5(h5), tmp_path)
    assert len(reach) >= 100
    assert {k: v for k, v in reach.items() if v > 0.02} == {}


@pytest.mark.slow
def test_write_figures_and_report_files(result, tmp_path):
    files = write_figures(result, tmp_path / "fig")
    names = [f.path.name for f in files]
    # the 2000-run Monte Carlo gives the series' error budgets (sensitivity: auto)
    assert names == ["run_y_hist.png", "run_ramp_y1.png", "run_ramp_y1_budget.png",
                     "run_ramp_y2.png", "run_ramp_y2_budget.png", "run_cost.png"]
    for f in files:
        assert f.path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        h, w = imread(f.path).shape[:2]
        assert w >= 800 and h >= 500  # readable size at the default 130 dpi
    path, figs = write_report(result, tmp_path / "rep")
    text = path.read_text()
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    assert len(links) == 6
    assert all((path.parent / link).is_file() for link in links)
    for heading in ("# run: uncertainty propagation report", "## Uncertain inputs",
                    "## Methods and cost", "### y [m/s] (scalar)", "### ramp [m] (time series)",
                    "## Series over the whole grid against `mc`",
                    "## Error budget (Sobol' indices)", "## Provenance"):
        assert heading in text.splitlines()


FTCAPN = {
    "name": "ft",
    "model": {"name": "ftcapn"},
    "inputs": [{"name": n, "dist": "normal", "mean": 0.0, "std": s} for n, s in
               [("dx", 15.0), ("dy", 15.0), ("dz", 15.0), ("dvx", 3.0), ("dvy", 3.0),
                ("dvz", 3.0), ("b_w", 1e-5), ("b_R", 5.0), ("at_theta", 0.1)]],
    "outputs": ["zem", "omega_s"],
    "report_times": [0, 20, 40, 60],
    "methods": [{"name": "monte_carlo", "label": "mc1000", "n_samples": 1000},
                {"name": "monte_carlo", "label": "mc100", "n_samples": 100}],
    "reference": "mc1000",
    "seed": 5,
}


@pytest.mark.slow
def test_plot_and_report_commands_on_an_ftcapn_result(write_config, tmp_path):
    runner = CliRunner()
    res = runner.invoke(main, ["run", str(write_config(FTCAPN, "ft.yaml")), "--out",
                               str(tmp_path)])
    assert res.exit_code == 0, res.output
    h5 = tmp_path / "ft.h5"
    res = runner.invoke(main, ["plot", str(h5)])
    assert res.exit_code == 0, res.output
    written = [Path(line[6:]) for line in res.output.splitlines()]
    # figures follow the config's output order (zem, then omega_s), then the cost table
    assert [p.name for p in written] == ["ft_zem_hist.png", "ft_omega_s.png",
                                         "ft_omega_s_budget.png", "ft_cost.png"]
    assert all(p.parent == tmp_path / "figures" and p.is_file() for p in written)
    b = tmp_path / "b.json"
    assert runner.invoke(main, ["baseline", str(h5), "-o", str(b)]).exit_code == 0
    res = runner.invoke(main, ["report", str(h5), "--out", str(tmp_path / "rep"),
                               "--baseline", str(b)])
    assert res.exit_code == 0, res.output
    report = tmp_path / "rep" / "ft_report.md"
    assert res.output.splitlines()[-1] == f"wrote {report}"
    text = report.read_text()
    assert "![omega_s](figures/ft_omega_s.png)" in text
    assert "### zem [m] (scalar)" in text
    assert "![error budget of omega_s](figures/ft_omega_s_budget.png)" in text
    assert "Error budget of zem, mc1000: Sobol' indices from the Monte Carlo runs" in text
    assert "## Regression check" in text and "PASS: " in text
    res = runner.invoke(main, ["plot", str(tmp_path / "missing.h5")])
    assert res.exit_code == 2 and "result file not found" in res.stderr


def test_single_run_figures_say_there_is_no_spread():
    cfg = {"model": {"name": "linear_gaussian", "n_times": 5},
           "inputs": [{"name": "x1", "dist": "normal", "std": 1.0}],
           "methods": [{"name": "monte_carlo", "label": "nominal", "n_samples": 1}]}
    r = run(validate_config(cfg))
    fig = series_figure(r, "ramp", 0)
    assert "undefined: the std is zero\n(every run agrees)" in _texts(fig)
    fig = scalar_figure(r, "y")
    (label,) = [t.get_text() for t in fig.legends[0].get_texts()][:1]
    assert label.startswith("nominal (MC, 1 run): single value ")
    assert fig.axes[0].get_ylabel() == "single value (no spread)"
