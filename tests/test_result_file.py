"""The HDF5 result: documented layout, exact round trip, atomic write."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from uqguide.config import validate_config
from uqguide.errors import ResultError
from uqguide.propagate import run
from uqguide.result import read_hdf5, write_hdf5


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


def test_layout_is_as_documented(result, tmp_path):
    path = write_hdf5(result, tmp_path / "r.h5")
    with h5py.File(path) as f:
        assert f["methods/mc_b/stats/ramp/mean"].shape == (result.time.size, 2)
        assert f["methods/mc_b/stats/ramp/cov"].shape == (result.time.size, 2, 2)
        assert f["methods/mc_b/stats/y/ci_kurtosis"].shape == (2, 2)
        assert f["methods/mc_b/samples/x"].shape == (500, 2)
        assert f["methods/mc_b/samples/scalars/y"].shape == (500, 2)
        assert f["outputs/ramp"].attrs["kind"] == "series"
        assert "n_samples: 500" in f.attrs["config_yaml"]


def test_write_is_atomic(result, tmp_path, monkeypatch):
    target = tmp_path / "r.h5"

    def boom(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr("uqguide.result._write_run", boom)
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
