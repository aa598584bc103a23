"""What ``import uqguide`` offers: the API listed by ``dir``, each name the real object, unknown
names an AttributeError; a result is written only under a name the config gives."""

from __future__ import annotations

import pytest

import uqguide
from uqguide.errors import ConfigError

PUBLIC = ("run", "load_config", "read_result", "Result", "RunConfig", "Model", "Method")


def test_dir_lists_the_api_and_all_agrees():
    names = dir(uqguide)
    for name in PUBLIC:
        assert name in names
    assert set(PUBLIC) | {"__version__"} == set(uqguide.__all__)
    assert names == sorted(names)
    # the module's own helpers are not offered as API
    assert not {"Any", "TYPE_CHECKING", "annotations", "ModuleType"} & set(names)


def test_each_name_is_the_object_it_stands_for():
    from uqguide import api
    from uqguide.config.run_config import RunConfig
    from uqguide.methods.base import Method
    from uqguide.models.base import Model
    from uqguide.results.result import Result

    assert uqguide.run is api.run
    assert uqguide.load_config is api.load_config
    assert uqguide.read_result is api.read_result
    assert uqguide.Result is Result
    assert uqguide.RunConfig is RunConfig
    assert uqguide.Model is Model
    assert uqguide.Method is Method
    from uqguide import Method as again  # the from-import form goes through the same path

    assert again is Method


def test_an_unknown_name_is_the_usual_attribute_error():
    with pytest.raises(AttributeError, match="module 'uqguide' has no attribute 'Rezult'"):
        uqguide.Rezult  # noqa: B018 - the look-up is what is tested
    assert not hasattr(uqguide, "surrogate")
    with pytest.raises(ImportError):
        from uqguide import Rezult  # noqa: F401


UNNAMED = {
    "model": {"name": "linear_gaussian"},
    "inputs": [{"name": "x1", "dist": "normal", "std": 1.0},
               {"name": "x2", "dist": "uniform", "low": 0.0, "high": 2.0}],
    "outputs": ["y"],
    "methods": [{"name": "pce_tensor", "label": "tensor", "m": 2}],
}


def test_an_unnamed_mapping_is_not_written_but_still_runs_in_memory(tmp_path):
    with pytest.raises(ConfigError) as err:
        uqguide.run(UNNAMED, out=tmp_path)
    assert err.value.field == "name"
    assert "name" in str(err.value) and "out=" in str(err.value)
    assert list(tmp_path.iterdir()) == []  # refused before any file or run folder
    result = uqguide.run(UNNAMED)  # without out= nothing is written, and nothing clashes
    assert result.run("tensor").estimate.stats["y"].mean.shape == (2,)


def test_two_named_mappings_write_two_files(tmp_path):
    for name in ("first", "second"):
        uqguide.run({**UNNAMED, "name": name}, out=tmp_path)
    assert {p.name for p in tmp_path.glob("*.h5")} == {"first.h5", "second.h5"}
