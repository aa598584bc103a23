"""``Result.to_xarray()``: an output of one component has no size-1 component dimension (a band
plot of a one-component series needs no ``.squeeze()``); one of several keeps it, the result
file keeps it for both, and ``to_dataframe()`` keeps its documented columns."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np
import pytest

import uqguide
from tests.doc_pages import ROOT, blocks
from uqguide.results.result import read_hdf5, write_hdf5
from uqguide.results.statistics import OutputStatistics

TIME = np.linspace(0.0, 2.0, 21)


def _closed_form(x: np.ndarray) -> dict[str, np.ndarray]:
    # y(t) = a exp(-t) (one component), p(t) = (a t, b t) (two), s = a + b (one scalar)
    a, b = x[:, 0:1], x[:, 1:2]
    return {"time": TIME, "y": a * np.exp(-TIME), "p": np.stack([a * TIME, b * TIME], -1),
            "s": (a + b)[:, 0]}


@pytest.fixture(scope="module")
def result():
    return uqguide.run({
        "model": {"name": "callable", "function": _closed_form, "inputs": ["a", "b"],
                  "nominal": [1.0, 0.0],
                  "outputs": [{"name": "y", "kind": "series", "unit": "m"},
                              {"name": "p", "kind": "series", "components": 2,
                               "component_names": ["u", "v"]}, "s"]},
        "inputs": [{"name": "a", "dist": "normal", "mean": 1.0, "std": 0.1},
                   {"name": "b", "dist": "uniform", "low": -1.0, "high": 1.0}],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 400},
                    {"name": "monte_carlo", "label": "mc2", "n_samples": 100}],
        "seed": 3})


def test_one_component_outputs_have_no_component_dimension(result):
    ds = result.to_xarray("mc")
    assert ds["y"].dims == ("statistic", "time")
    assert ds["y_cov"].dims == ("time",)
    assert ds["y_ci"].dims == ("bound", "statistic", "time")
    assert ds["s"].dims == ("statistic",)
    assert "y_component" not in ds.dims and "y_component" in ds.coords  # the name stays
    # several components: kept
    assert ds["p"].dims == ("statistic", "time", "p_component")
    assert list(ds["p_component"].values) == ["u", "v"]
    assert ds["p_cov"].dims == ("time", "p_component", "p_component2")
    both = result.to_xarray()
    assert both["y"].dims == ("label", "statistic", "time")
    assert both["p"].dims == ("label", "statistic", "time", "p_component")
    # the values are the method's, the component axis dropped: y = a exp(-t), E a = 1
    st = result.run("mc").estimate.stats["y"]
    np.testing.assert_array_equal(ds["y"].sel(statistic="mean").values, st.mean[:, 0])
    np.testing.assert_array_equal(both["y"].sel(label="mc", statistic="std").values,
                                  st.std[:, 0])


def test_the_file_keeps_the_dimension_and_reads_back_alike(result, tmp_path):
    import xarray as xr

    path = write_hdf5(result, tmp_path / "r.h5")
    with xr.open_dataset(path, group="methods/mc", engine="h5netcdf") as g:
        assert g["y"].dims == ("statistic", "time", "y_component")
    back = read_hdf5(path)
    xr.testing.assert_identical(back.to_xarray(), result.to_xarray())
    # the statistics read from the squeezed Dataset are the method's, shapes and all
    info = result.output("y")
    a = OutputStatistics.of("mc", info, result.run("mc").estimate.stats["y"])
    b = OutputStatistics.read("mc", info, result.to_xarray("mc"))
    for x, z in zip(a.statistics, b.statistics):
        np.testing.assert_array_equal(x.value, z.value)
        np.testing.assert_array_equal(x.ci, z.ci)
    np.testing.assert_array_equal(a.cov, b.cov)


def test_to_dataframe_keeps_its_documented_columns(result):
    df = result.to_dataframe("y")
    assert list(df.columns) == ["label", "time", "component", "statistic", "value", "ci_low",
                                "ci_high"]
    assert list(result.to_dataframe("s").columns) == ["label", "component", "statistic",
                                                      "value", "ci_low", "ci_high"]
    with pytest.warns(DeprecationWarning, match="'method' is now 'label'"):
        assert set(df["method"]) == {"mc", "mc2"}


def _band_plot_block() -> str:
    (block,) = [b for b in blocks(ROOT / "docs" / "guide.md")
                if b.lang == "python" and "fill_between" in b.body]
    return block.body


def test_the_guide_s_band_plot_runs_as_written(tmp_path, monkeypatch):
    # the page's code in this process (its subprocess run is a slow doc example): the plain
    # matplotlib band of a one-component series, which a (time, 1) mean and std refused
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    monkeypatch.chdir(tmp_path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", DeprecationWarning)
            exec(compile(_band_plot_block(), "docs/guide.md", "exec"), {"__name__": "__main__"})
    finally:
        plt.close("all")
    assert os.path.getsize(Path("band.png")) > 0
