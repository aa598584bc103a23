"""scripts/import_graph.py: the package's parts import down their layers, without a cycle, and
the check itself sees a cycle when there is one."""

from __future__ import annotations

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


def test_the_package_has_no_cycle_and_no_arrow_back_up(capsys):
    assert _script().main([]) == 0, capsys.readouterr().out


def test_a_cycle_is_found_with_its_parts():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _script().cycles(graph) == [["a", "b", "c"]]
