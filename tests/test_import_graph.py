"""scripts/import_graph.py: the package's parts import down their layers, without a cycle, and
the check itself sees a cycle when there is one."""

from __future__ import annotations

import pytest
import importlib.util
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "import_graph.py"


def _script():
    spec = importlib.util.spec_from_file_location("import_graph", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["import_graph"] = mod
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.slow
def test_the_package_has_no_cycle_and_no_arrow_back_up(capsys):
    assert _script().main([]) == 0, capsys.readouterr().out


def test_a_cycle_is_found_with_its_parts():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _script().cycles(graph) == [["a", "b", "c"]]


def _package(tmp_path, docs):
    for name, doc in docs.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "__init__.py").write_text(f'"""{doc}"""\n')
    return tmp_path


def test_the_layers_are_read_from_the_folders(tmp_path):
    pkg = _package(tmp_path, {"core": "Vocabulary.", "stats": "Numbers, above ``core``.",
                              "models": "Models, above ``stats``.",
                              "pce": "Chaos, above ``stats``."})
    assert _script().folder_layers(pkg) == {"core": 1, "stats": 2, "models": 3, "pce": 3}


def test_a_folder_that_does_not_say_its_layer_is_refused(tmp_path):
    script = _script()
    pkg = _package(tmp_path, {"core": "Vocabulary.", "extra": "Something new."})
    try:
        script.folder_layers(pkg)
    except script.LayerError as e:
        assert "extra" in str(e)
    else:
        raise AssertionError("a folder without its layer was accepted")


def test_folders_above_each_other_in_a_circle_are_refused(tmp_path):
    script = _script()
    pkg = _package(tmp_path, {"core": "Vocabulary.", "a": "A, above ``b``.",
                              "b": "B, above ``a``."})
    try:
        script.folder_layers(pkg)
    except script.LayerError as e:
        assert "circle" in str(e)
    else:
        raise AssertionError("a circle of folders was accepted")


def test_the_real_folders_form_the_documented_chain():
    layer = _script().layers()
    chain = ["errors", "core", "stats", "models", "pce", "methods", "config", "results", "driver",
             "gate", "report", "papers", "commands", "api", "cli"]
    assert [layer[p] for p in chain] == sorted(layer[p] for p in chain)
    assert len({layer[p] for p in chain}) == len(chain)
