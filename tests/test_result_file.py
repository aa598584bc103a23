"""The HDF5 result: documented layout, exact round trip, atomic write."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from uqguide.config.run_config import validate_config
from uqguide.errors import ResultError
from uqguide.driver.propagate import run
from uqguide.results.result import read_hdf5, write_hdf5


@pytest.fixture
def result():
    cfg = {
        "model": {"name": "linear_gaussian"},
        "inputs": [{"name": "x1", "dist": "normal", "std": 1.0},
                   {"name": "x2", "dist": "uniform", "low": 0.0, "high": 2.0}],
        "outputs": ["y", "ramp"],
        "report_times": [0.5],
        "methods": [{"name": "monte_carlo", "label": "mc_b", "n_samples": 500},
                    {"name": "monte_carlo", "label": "mc_a", "n_samples": 300,
                     "sampling": "lhs"}],
        "reference": "mc_b",
        "seed": 5,
    }
    return run(validate_config(cfg))


def test_round_trip_is_exact_and_keeps_method_order(result, tmp_path):
    path = write_hdf5(result, tmp_path / "r.h5")
    back = read_hdf5(path)
    assert [r.label for r in back.runs] == ["mc_b", "mc_a"]
    assert [o.name for o in back.outputs] == ["y", "ramp"]  # config order, not alphabetical
    assert back.reference == "mc_b" and back.model == "linear_gaussian"
    np.testing.assert_array_equal(back.time, result.time)
    for a, b in zip(result.runs, back.runs):
        np.testing.assert_array_equal(a.x, b.x)
        np.testing.assert_array_equal(a.failed, b.failed)
        for name, s in a.estimate.stats.items():
            t = b.estimate.stats[name]
            for k in ("mean", "std", "skewness", "kurtosis", "cov", "sem"):
                np.testing.assert_array_equal(getattr(s, k), getattr(t, k))
            for k in s.ci:
                np.testing.assert_array_equal(s.ci[k], t.ci[k])
        np.testing.assert_array_equal(a.scalars["y"], b.scalars["y"])
    assert back.config["methods"][1]["sampling"] == "lhs"
    assert back.provenance["versions"]["numpy"] == np.__version__


def test_compile_seconds_are_kept_apart_and_older_files_read_as_none(result, tmp_path):
    from uqguide.report.tables import cost_table

    assert "compile_s" not in cost_table(result)  # nothing compiled: no column
    result.runs[1].compile_seconds = 21.25
    back = read_hdf5(write_hdf5(result, tmp_path / "r.h5"))
    assert [r.compile_seconds for r in back.runs] == [0.0, 21.25]
    assert [r.model_seconds for r in back.runs] == [r.model_seconds for r in result.runs]
    cost = cost_table(back)
    assert list(cost["compile_s"]) == [0.0, 21.25]
    assert list(cost.columns[4:7]) == ["model_s", "compile_s", "fit_s"]
    old = read_hdf5(Path(__file__).parent / "data" / "result_format1.h5")
    assert [r.compile_seconds for r in old.runs] == [0.0, 0.0]


def test_layout_is_as_documented(result, tmp_path):
    path = write_hdf5(result, tmp_path / "r.h5")
    T = result.time.size
    with h5py.File(path) as f:
        assert f.attrs["format"] == 2
        assert f["methods/mc_b/ramp"].shape == (4, T, 2)  # statistic, time, component
        assert f["methods/mc_b/ramp_cov"].shape == (T, 2, 2)
        assert f["methods/mc_b/y_ci"].shape == (2, 4, 2)  # bound, statistic, component
        assert f["methods/mc_b/samples/x"].shape == (500, 2)
        assert f["methods/mc_b/samples/scalars/y"].shape == (500, 2)
        assert f["outputs/ramp"].attrs["kind"] == "series"
        assert "n_samples: 500" in f.attrs["config_yaml"]
        # netCDF-4 conventions: dimension scales, strings as UTF-8
        assert [d[0].name for d in f["methods/mc_b/ramp"].dims] == [
            "/methods/mc_b/statistic", "/methods/mc_b/time", "/methods/mc_b/ramp_component"]
        assert h5py.check_string_dtype(f["input"].dtype).encoding == "utf-8"
        assert f["methods/mc_b/samples/reasons"].dtype.kind == "O"


def test_xarray_opens_a_method_group_with_named_dims_and_the_time(result, tmp_path):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    path = write_hdf5(result, tmp_path / "r.h5")
    with xr.open_dataset(path, group="methods/mc_b", engine="h5netcdf") as ds:
        assert ds["ramp"].dims == ("statistic", "time", "ramp_component")
        np.testing.assert_array_equal(ds["time"].values, result.time)
        assert ds["time"].attrs["units"] == "s"
        assert list(ds["statistic"].values) == ["mean", "std", "skewness", "kurtosis"]
        assert list(ds["input"].values) == ["x1", "x2"]
        assert ds["y_ci"].dims == ("bound", "statistic", "y_component")
        s = result.run("mc_b").estimate.stats["ramp"]
        np.testing.assert_array_equal(ds["ramp"].sel(statistic="std").values, s.std)
        np.testing.assert_array_equal(ds["ramp_sem"].values, s.sem)
        assert ds["ramp"].attrs["units"] == result.output("ramp").unit
        # the same as the in-memory Dataset of that method
        mem = result.to_xarray("mc_b")
        for name in mem.data_vars:
            np.testing.assert_array_equal(ds[name].values, mem[name].values)
    with xr.open_dataset(path, engine="h5netcdf") as root:
        np.testing.assert_array_equal(root["time"].values, result.time)
        assert list(root["input"].values) == ["x1", "x2"]


def test_the_root_group_opens_in_xarray_as_the_file_s_index(result, tmp_path):
    """The root group lists the methods (config order) and outputs, and names each method's
    group: a user who opens the file without ``group=`` sees what is in it."""
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    path = write_hdf5(result, tmp_path / "r.h5")
    with xr.open_dataset(path, engine="h5netcdf") as root:
        assert list(root["label"].values) == ["mc_b", "mc_a"]
        assert list(root["method_name"].values) == ["monte_carlo", "monte_carlo"]
        assert root["n_runs"].sel(label="mc_a").item() == 300
        assert root["n_failed"].dims == ("label",) and root["success"].values.tolist() == [1, 1]
        assert list(root["output"].values) == ["y", "ramp"]
        assert list(root["output_kind"].values) == ["scalar", "series"]
        assert list(root["output_unit"].values) == [o.unit for o in result.outputs]
        assert root.attrs["model"] == "linear_gaussian" and root.attrs["reference"] == "mc_b"
        group = root["method_group"].sel(label="mc_a").item()
    with xr.open_dataset(path, group=group, engine="h5netcdf") as ds:
        np.testing.assert_array_equal(ds["y"].sel(statistic="mean").values,
                                      result.run("mc_a").estimate.stats["y"].mean)


def test_format_1_files_still_read():
    """A file written by uqguide before format 2 (tests/data, made by the format-1 writer)."""
    back = read_hdf5(Path(__file__).parent / "data" / "result_format1.h5")
    assert [r.label for r in back.runs] == ["mc", "tensor"]
    assert back.input_names == ["x1", "x2"]
    mc, tensor = back.run("mc").estimate, back.run("tensor").estimate
    assert mc.stats["ramp"].mean.shape == (back.time.size, 2)
    assert mc.stats["y"].ci["kurtosis"].shape == (2, 2)
    assert mc.stats["y"].quantile_levels == (0.1, 0.5, 0.9)
    assert tensor.stats["y"].sobol_first.shape == (2, 2)
    assert tensor.scalar_names == ["y[0]", "y[1]"]
    assert back.run("mc").reasons.tolist() == [""] * 200
    # y = A x, x1 ~ N(0, 1), x2 ~ U(0, 2): the tensor rule's mean is exact, (2, 0)
    np.testing.assert_allclose(tensor.stats["y"].mean, [2.0, 0.0], atol=1e-12)
    # and it converts like a new one
    assert back.to_xarray()["ramp"].dims == ("label", "statistic", "time", "ramp_component")


def test_write_is_atomic(result, tmp_path, monkeypatch):
    from uqguide.results import netcdf_file

    target = tmp_path / "r.h5"
    real = netcdf_file._write_dataset

    def boom(g, name, *args, **kwargs):
        if name == "x":  # half-way: the first method's statistics are written, its runs not
            raise RuntimeError("disk full")
        return real(g, name, *args, **kwargs)

    monkeypatch.setattr(netcdf_file, "_write_dataset", boom)
    with pytest.raises(RuntimeError):
        write_hdf5(result, target)
    assert list(tmp_path.iterdir()) == [], "no partial or temporary file may remain"


def test_reading_a_non_result_is_a_result_error(tmp_path):
    bad = tmp_path / "bad.h5"
    with h5py.File(bad, "w") as f:
        f["x"] = 1
    with pytest.raises(ResultError, match="not a uqguide result file"):
        read_hdf5(bad)
    (tmp_path / "junk.h5").write_text("not hdf5")
    with pytest.raises(ResultError, match="unreadable"):
        read_hdf5(tmp_path / "junk.h5")
