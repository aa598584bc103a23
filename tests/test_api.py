"""The public Python API: load_config / run / read_result, Result.to_xarray / to_dataframe."""

from __future__ import annotations

import doctest

import numpy as np
import pytest

import uqguide
import uqguide.api
from uqguide.core.types import STAT_NAMES

xr = pytest.importorskip("xarray")

CONFIG = {
    "model": {"name": "linear_gaussian"},
    "inputs": [{"name": "x1", "dist": "normal", "std": 1.0},
               {"name": "x2", "dist": "uniform", "low": 0.0, "high": 2.0}],
    "outputs": ["y", "ramp"],
    "report_times": [0.5],
    "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 400},
                {"name": "pce_tensor", "label": "tensor", "m": 3,
                 "validation": {"n_samples": 30}}],
    "reference": "mc",
    "seed": 11,
    "quantiles": [0.1, 0.5, 0.9],
}


@pytest.fixture(scope="module")
def result():
    return uqguide.run(CONFIG)


@pytest.mark.slow
def test_the_api_docstrings_run():
    failed, tried = doctest.testmod(uqguide.api, optionflags=doctest.ELLIPSIS)
    assert tried >= 8 and failed == 0


def test_load_config_takes_a_mapping_a_study_name_and_a_loaded_config():
    cfg = uqguide.load_config(CONFIG)
    assert uqguide.load_config(cfg) is cfg
    assert uqguide.load_config("ftcapn_table3").model.name == "ftcapn"


@pytest.mark.slow
def test_to_xarray_holds_every_statistic_exactly(result):
    ds = result.to_xarray()
    assert list(ds["label"].values) == ["mc", "tensor"]
    assert ds["ramp"].dims == ("label", "statistic", "time", "ramp_component")
    np.testing.assert_array_equal(ds["time"].values, result.time)
    assert ds["time"].attrs["units"] == "s"
    assert list(ds["ramp_component"].values) == ["y1", "y2"]
    assert list(ds["input"].values) == ["x1", "x2"]
    for r in result.runs:
        one = result.to_xarray(r.label)
        for name, s in r.estimate.stats.items():
            for j, stat in enumerate(STAT_NAMES):
                got = ds[name].sel(label=r.label, statistic=stat).values
                np.testing.assert_allclose(got, s.stat(stat), rtol=1e-15, atol=0)
                np.testing.assert_array_equal(one[name].values[j], s.stat(stat))
            np.testing.assert_array_equal(one[f"{name}_cov"].values, s.cov)
            np.testing.assert_array_equal(one[f"{name}_quantile"].values, s.quantiles)
            np.testing.assert_array_equal(one["quantile"].values, s.quantile_levels)
            assert one[name].attrs["units"] == result.output(name).unit
    # a statistic one method lacks is NaN for it in the stacked form
    assert np.isnan(ds["y_sem"].sel(label="tensor").values).all()
    assert np.isnan(ds["y_sobol_first"].sel(label="mc").values).all()
    np.testing.assert_array_equal(ds["y_sobol_first"].sel(label="tensor").values,
                                  result.run("tensor").estimate.stats["y"].sobol_first)


def test_the_stacked_dataset_selects_a_method_by_keyword(result):
    """``sel(method=...)`` is xarray's fill-method keyword: the methods are stacked along
    ``label``, so a plain keyword selects one."""
    ds = result.to_xarray()
    assert "method" not in ds.dims
    one = ds.sel(label="mc")
    np.testing.assert_array_equal(one["y"].sel(statistic="std").values,
                                  result.run("mc").estimate.stats["y"].std)
    assert one["method_name"].item() == "monte_carlo" and one["n_runs"].item() == 400


def test_to_dataframe_is_tidy_over_every_time_step(result):
    df = result.to_dataframe("ramp")
    assert list(df.columns) == ["label", "time", "component", "statistic", "value", "ci_low",
                                "ci_high"]
    T = result.time.size
    mc = df[(df.label == "mc") & (df.statistic == "std")]
    assert len(mc) == 2 * T  # every step, both components
    s = result.run("mc").estimate.stats["ramp"]
    wide = mc.pivot(index="time", columns="component", values="value")
    np.testing.assert_allclose(wide[["y1", "y2"]].to_numpy(), s.std, rtol=1e-15, atol=0)
    low = mc.pivot(index="time", columns="component", values="ci_low")
    np.testing.assert_array_equal(low[["y1", "y2"]].to_numpy(), s.ci["std"][0])
    q = df[(df.label == "tensor") & (df.statistic == "q0.9")]
    np.testing.assert_array_equal(
        q.pivot(index="time", columns="component", values="value")[["y1", "y2"]].to_numpy(),
        result.run("tensor").estimate.stats["ramp"].quantiles[2])
    scalar = result.to_dataframe("y")
    assert "time" not in scalar.columns and set(scalar.component) == {"y1", "y2"}


def test_to_dataframe_still_answers_the_renamed_method_column(result):
    """Scripts written against the column ``method`` (now ``label``) keep working, warned."""
    df = result.to_dataframe("y")
    with pytest.warns(DeprecationWarning, match="'method' is now 'label'"):
        by_method = df["method"]
    assert by_method.equals(df["label"])
    with pytest.warns(DeprecationWarning):
        mc = df[df.method == "mc"]
    with pytest.warns(DeprecationWarning):  # a filtered frame keeps the old name
        assert set(mc["method"]) == {"mc"}
    with pytest.warns(DeprecationWarning):
        sizes = df.groupby("method").size()
    assert sizes.to_dict() == df.groupby("label").size().to_dict()


def test_to_dataframe_has_the_control_variate_rows(result):
    """A validated PCE's control-variate moments are rows labelled ``<label>+cv``, with their
    intervals, as in the statistics table."""
    df = result.to_dataframe("ramp")
    assert set(df.label) == {"mc", "tensor", "tensor+cv"}
    s = result.run("tensor").estimate.stats["ramp"]
    cv = df[df.label == "tensor+cv"]
    assert list(dict.fromkeys(cv.statistic)) == list(STAT_NAMES)
    for stat in STAT_NAMES:
        rows = cv[cv.statistic == stat]
        for col, want in (("value", s.corrected[stat]), ("ci_low", s.corrected_ci[stat][0]),
                          ("ci_high", s.corrected_ci[stat][1])):
            got = rows.pivot(index="time", columns="component", values=col)[["y1", "y2"]]
            np.testing.assert_array_equal(got.to_numpy(), want)


def test_the_tensor_pce_mean_is_the_closed_form(result):
    """y = A x with x1 ~ N(0, 1), x2 ~ U(0, 2): E[y] = (2, 0), exact for a degree-2 rule."""
    mean = result.to_xarray("tensor")["y"].sel(statistic="mean").values
    np.testing.assert_allclose(mean, [2.0, 0.0], atol=1e-12)


def test_read_result_gives_back_the_same_dataset(result, tmp_path):
    from uqguide.results.result import write_hdf5

    back = uqguide.read_result(write_hdf5(result, tmp_path / "r.h5"))
    xr.testing.assert_identical(back.to_xarray(), result.to_xarray())


def test_to_dataframe_names_the_outputs_when_it_needs_one(result):
    """A result of several outputs needs the output named, and says which it has; a result of
    one takes ``to_dataframe()`` as it is (``uqguide.fit`` of a single column)."""
    with pytest.raises(uqguide.errors.ResultError, match="name one of this result's 2 "
                                                         "outputs: y, ramp"):
        result.to_dataframe()
    with pytest.raises(uqguide.errors.ResultError, match=r"no output 'z' .*outputs: y, ramp"):
        result.to_dataframe("z")
    rng = np.random.default_rng(0)
    x = rng.normal(size=(60, 2))
    one = uqguide.fit(x, x[:, 0] + 0.5 * x[:, 1],
                      inputs=[{"name": "a", "dist": "normal", "std": 1.0},
                              {"name": "b", "dist": "normal", "std": 1.0}])
    df = one.to_dataframe()
    assert df.equals(one.to_dataframe(one.outputs[0].name))
    mean = df[(df.statistic == "mean")].value.to_numpy()
    assert np.isfinite(mean).all()
