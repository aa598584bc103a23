"""Methods as hooks, not switches: what a method does differently lives in the method's class
(``Method.propagate`` and the other hooks of ``uqguide.methods.base``), so no code outside
``uqguide/methods/`` asks a method which kind it is."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np

from uqguide.driver.propagate import propagate
from uqguide.methods.base import Design, Method, Propagated, Runner
from uqguide.core.inputs import InputSpace
from uqguide.core.types import Estimate, ModelOutput
from uqguide.config.run_config import validate_config
from uqguide.models.benchmarks import LinearGaussian

PACKAGE = Path(__file__).resolve().parents[1] / "uqguide"
METHODS = PACKAGE / "methods"


def _name(node: ast.expr) -> str:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    return ""


def method_classes(folder: Path = METHODS) -> set[str]:
    """``Method`` and the names of every class under ``folder`` that derives from it."""
    bases: dict[str, list[str]] = {}
    for path in folder.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef):
                bases[node.name] = [_name(b) for b in node.bases]
    kinds = {"Method"}
    while True:
        more = {c for c, bs in bases.items() if c not in kinds and any(b in kinds for b in bs)}
        if not more:
            return kinds
        kinds |= more


def kind_switches(source: str, kinds: set[str]) -> list[int]:
    """Lines of ``isinstance`` / ``issubclass`` calls, and of ``type(x) is/== C`` comparisons,
    whose class is one of ``kinds``."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        classes: list[ast.expr] = []
        if isinstance(node, ast.Call) and _name(node.func) in ("isinstance", "issubclass") \
                and len(node.args) == 2:
            cls = node.args[1]
            classes = list(cls.elts) if isinstance(cls, ast.Tuple) else [cls]
        elif isinstance(node, ast.Compare) and isinstance(node.left, ast.Call) \
                and _name(node.left.func) == "type":
            classes = list(node.comparators)
        if any(_name(c) in kinds for c in classes):
            lines.append(node.lineno)
    return lines


def test_the_method_classes_are_found():
    kinds = method_classes()
    assert {"Method", "StreamingMethod", "MonteCarlo", "SobolSaltelli",
            "MultiFidelityMC"} <= kinds


def test_the_search_sees_a_switch():
    kinds = {"Method", "StreamingMethod", "MultiFidelityMC"}
    source = ("if isinstance(m, StreamingMethod):\n    pass\n"
              "ok = isinstance(m, (int, base.Method))\n"
              "if type(m) is mfmc.MultiFidelityMC:\n    pass\n"
              "fine = isinstance(m, Design)\n")
    assert kind_switches(source, kinds) == [1, 3, 4]


def test_no_code_outside_methods_asks_a_method_its_kind():
    kinds = method_classes()
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if METHODS in path.parents:
            continue
        text = path.read_text(encoding="utf-8")
        if not any(k in text for k in kinds):
            continue  # (no method class named: nothing to parse)
        for line in kind_switches(text, kinds):
            found.append(f"{path.relative_to(PACKAGE.parent)}:{line}")
    assert not found, ("a switch on a method's kind outside uqguide/methods/ (make it a hook "
                       "of uqguide.methods.base.Method instead): " + ", ".join(found))


class _TwoStages(Method):
    """A method with phases of its own: its design in two checkpoint stages, then the mean."""

    name = "two_stages"
    summary = "test method"

    def design(self, space: InputSpace, seed: int) -> Design:
        rng = np.random.default_rng(seed)
        return Design(x=space.from_unit(rng.random((12, space.dim))))

    def estimate(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Estimate:
        raise AssertionError("the driver must call propagate, which does not estimate")

    def propagate(self, space: InputSpace, design: Design, runner: Runner) -> Propagated:
        first, _ = runner.run(design.x, 0, [(0, 5)])
        runner.plan([(5, 12)])
        both, _ = runner.run(design.x, 1, [(5, 8), (8, 12)], after=first)
        est = Estimate(method=self.name, label=self.label, stats={},
                       diagnostics={"mean_y": float(both.scalars["y"].mean())})
        return Propagated(est, design.x, both, fit_seconds=0.5)


def test_the_driver_runs_a_method_through_its_propagate_hook():
    cfg = validate_config({"model": {"name": "linear_gaussian"},
                           "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0,
                                       "std": 1.0} for i in (1, 2, 3)],
                           "methods": [{"name": "monte_carlo", "n_samples": 10}], "seed": 1})
    method = _TwoStages()
    run = propagate(method, LinearGaussian(), cfg.space, ("y",), seed=3)
    x = np.asarray(method.design(cfg.space, 3).x)
    direct = LinearGaussian().evaluate(x, cfg.space.names, ["y"]).scalars["y"]
    assert run.success and run.n_runs == 12
    np.testing.assert_array_equal(run.scalars["y"], direct)
    assert run.estimate.diagnostics["mean_y"] == float(direct.mean())
    assert run.fit_seconds == run.estimate.diagnostics["fit_seconds"] == 0.5
