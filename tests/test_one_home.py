"""Checks where the rule lives: each core type has one home that every module imports it from,
and a run makes its resolved config once."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import uqguide
from uqguide.config.run_config import RunConfig, validate_config

ROOT = Path(__file__).resolve().parents[1]
CORE_TYPES = ROOT / "uqguide" / "core" / "types.py"
#: The public front doors that may name core types for authors besides their home (the
#: package, and the authoring names of models and methods: issue 45 item 8).
FRONT_DOORS = ("uqguide", "uqguide.models", "uqguide.methods")


def _core_names() -> set[str]:
    """The public classes and constants :mod:`uqguide.core.types` defines."""
    names = set()
    for node in ast.parse(CORE_TYPES.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            names.add(node.name)
        elif isinstance(node, ast.Assign):
            names |= {t.id for t in node.targets if isinstance(t, ast.Name) and t.id.isupper()}
    return names


#: ``from MODULE import NAMES`` (NAMES parenthesised over several lines or not), read as text:
#: parsing every file of the checkout would cost the suite two CPU-seconds.
_IMPORT = re.compile(r"^[ \t]*from[ \t]+(\.*[\w.]*)[ \t]+import[ \t]+(\([^)]*\)|[^\n]*)", re.M)


def _module(path: Path) -> list[str]:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return parts[:-1] if parts[-1] == "__init__" else parts


def _absolute(path: Path, module: str) -> str:
    """The absolute module a (maybe relative) ``from MODULE import`` names."""
    dots = len(module) - len(module.lstrip("."))
    if not dots:
        return module
    package = _module(path) if path.name == "__init__.py" else _module(path)[:-1]
    base = package[:len(package) - (dots - 1)]
    rest = module[dots:]
    return ".".join(base + ([rest] if rest else []))


def test_the_core_types_are_imported_from_their_one_home():
    core = _core_names()
    assert {"ModelOutput", "OutputStats", "Estimate", "GeneratedRows", "DerivedOutput"} <= core
    elsewhere = []
    for folder in ("uqguide", "tests", "benchmarks", "scripts"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            text = path.read_text(encoding="utf-8")
            for m in _IMPORT.finditer(text):
                source = _absolute(path, m.group(1))
                if source in ("uqguide.core.types", *FRONT_DOORS) \
                        or not source.startswith("uqguide"):
                    continue
                names = re.findall(r"\w+", re.sub(r"#[^\n]*", "", m.group(2)))
                for name in core.intersection(names):
                    line = text.count("\n", 0, m.start()) + 1
                    elsewhere.append(f"{path.relative_to(ROOT)}:{line} {name} from {source}")
    assert not elsewhere, ("import these from uqguide.core.types, their one home: "
                           + "; ".join(elsewhere))


def test_a_run_makes_its_resolved_config_once(tmp_path, monkeypatch):
    made = []
    resolve = RunConfig._resolve

    def counted(self: RunConfig) -> dict:
        made.append(self)
        return resolve(self)

    monkeypatch.setattr(RunConfig, "_resolve", counted)
    cfg = validate_config({
        "name": "once", "model": {"name": "linear_gaussian"},
        "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                   for i in (1, 2, 3)],
        "methods": [{"name": "monte_carlo", "n_samples": 64}], "seed": 1})
    # the run folder's identity, the same-study check and the result all read it
    result = uqguide.run(cfg, out=tmp_path)
    assert made == [cfg]
    assert result.config == cfg.resolved()
