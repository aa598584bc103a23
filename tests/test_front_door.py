"""What ``import uqguide`` offers: the API listed by ``dir``, each name the real object, unknown
names an AttributeError; a result is written only under a name the config gives."""

from __future__ import annotations

import pytest

import uqguide
from uqguide.errors import ConfigError

PUBLIC = ("run", "load_config", "read_result", "fit", "Result", "RunConfig", "Model", "Method")


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
    assert uqguide.fit is api.fit
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


def test_a_surrogate_prints_as_a_few_lines_and_the_same_after_a_file(tmp_path):
    """The kept surrogate's repr: the method, the inputs and per output its degree, terms and
    error, not its coefficients (which stay at ``expansions[name].alpha`` / ``.coef``)."""
    cfg = {"name": "ishigami_pce",
           "model": {"name": "ishigami"},
           "inputs": [{"name": f"x{i}", "dist": "uniform", "low": -3.0, "high": 3.0}
                      for i in (1, 2, 3)],
           "methods": [{"name": "pce_tensor", "label": "t4", "m": 5,
                        "validation": {"n_samples": 60}},
                       {"name": "pce_adaptive", "label": "apce", "n_samples": 60}],
           "seed": 2}
    fresh = uqguide.run(cfg, out=tmp_path)
    texts = {}
    for label, method, kind in (("t4", "pce_tensor", "validation"),
                                ("apce", "pce_adaptive", "LOO")):
        s = fresh.surrogate(label)
        text = texts[label] = repr(s)
        lines = text.splitlines()
        assert lines[0] == f"Surrogate {label!r} ({method}): 3 inputs -> 1 output"
        assert lines[1] == "  inputs: x1, x2, x3"
        e = s.expansions["y"]
        degree = int(e.alpha.sum(axis=1).max())
        err = float(fresh.run(label).estimate.diagnostics[
            f"{'validation_error' if kind == 'validation' else 'loo_error'}.y"])
        assert lines[2] == (f"  y (scalar, 1): degree {degree}, {e.alpha.shape[0]} terms, "
                            f"{kind} error {err:.2g}")
        assert lines[3].startswith("  full expansion: .expansions[name].alpha")
        assert len(lines) == 4 and e.coef.shape == (e.alpha.shape[0], 1)
    # the 5^3 tensor rule: degree 4 per input, total degree 12 (as its diagnostics count it)
    assert "degree 12, 125 terms" in texts["t4"]

    back = uqguide.read_result(tmp_path / "ishigami_pce.h5")
    stored = repr(back.run("apce").estimate.surrogate)  # before the germ is rebuilt
    assert stored.startswith("StoredSurrogate (from a file")
    assert stored.splitlines()[2] == texts["apce"].splitlines()[2].split(", LOO")[0]
    for label in ("t4", "apce"):
        assert repr(back.surrogate(label)) == texts[label]


def test_a_surrogate_summary_cuts_long_lists():
    import numpy as np

    from uqguide.pce.surrogate import SHOWN_OUTPUTS, summary

    inputs = [f"input_number_{i}" for i in range(20)]
    alpha = np.array([[0] * 20, [1] + [0] * 19, [0, 2] + [0] * 18])
    rows = [(f"out{i}", alpha, 4, (301, 3), "series", None) for i in range(SHOWN_OUTPUTS + 3)]
    lines = summary("Surrogate 'x' (pce_adaptive)", inputs, rows, {"miss": ("a", "b")}
                    ).splitlines()
    assert lines[0] == f"Surrogate 'x' (pce_adaptive): 20 inputs -> {SHOWN_OUTPUTS + 4} outputs"
    assert lines[1].endswith(", ...") and len(lines[1]) <= 90
    assert lines[2] == "  out0 (series, 301x3): degree 2, 3 terms x 4 components"
    assert lines[2 + SHOWN_OUTPUTS] == "  ... and 3 more fitted outputs"
    assert lines[3 + SHOWN_OUTPUTS] == "  miss: derived from a, b"
    assert len(lines) == SHOWN_OUTPUTS + 5


def test_a_result_and_its_runs_print_as_summaries():
    result = uqguide.run({**UNNAMED, "name": "lg", "outputs": ["y", "ramp"],
                          "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 200},
                                      {"name": "pce_tensor", "label": "t", "m": 2}],
                          "reference": "mc"})
    steps = result.time.size
    assert repr(result).splitlines() == [
        "Result 'lg': model linear_gaussian, 2 inputs -> 2 outputs, 2 methods",
        "  inputs: x1, x2",
        f"  outputs: y, ramp ({steps} steps)",
        "  mc (monte_carlo): 200 runs, 0 failed (reference)",
        "  t (pce_tensor): 4 runs, 0 failed",
        "  .run(label), .surrogate(label), .to_xarray(), .to_dataframe(output)"]
    assert repr(result.run("t")) == ("MethodRun 't' (pce_tensor): 4 runs, 0 failed; "
                                     "statistics of ramp, y")
