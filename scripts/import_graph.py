"""The import graph between uqguide's parts, checked against its layers.

A *part* is a subpackage (``uqguide/models/``, ``uqguide/pce/``...) or a top-level module
(``uqguide/config.py``). Every ``import`` in the package is read from the source (module level,
inside functions and under ``TYPE_CHECKING`` alike: a lazy or type-only import is still a
dependency), and folded onto the parts.

Printed: each part's layer and the parts it imports. Exit status:

- 0: no cycle between parts, and every arrow points down the layers of ``LAYERS``;
- 1: a cycle (printed, with the modules that make it), or an arrow that runs back up;
- 2: a part that ``LAYERS`` does not place (a new module must be given its layer here).

Run it from anywhere: ``python scripts/import_graph.py``. ``--dot`` prints the graph in
Graphviz form instead.
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections import defaultdict
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "uqguide"

#: Layers from the bottom (0) up: a part may import parts of its own layer or below, never
#: above. Parts in one layer must not import each other in a circle.
LAYERS: list[tuple[str, ...]] = [
    # 0. leaves: errors, typed values, small utilities with no uqguide imports of note
    ("errors", "strict", "atomic", "interrupts", "safe_yaml", "failures", "quantiles",
     "events", "types", "progress", "runlock", "_version", "figures"),
    # 1. numerics on arrays
    ("stats", "moment_sums_kernel"),
    # 2. the models and the input space they are sampled on
    ("models", "inputs"),
    # 3. surrogate building blocks, describing models and statistics
    ("pce", "describe", "labelled", "limits"),
    # 4. the methods
    ("methods",),
    # 5. names of models and methods, the shipped studies, configuration and its budgets
    ("registry", "catalog", "config", "budget", "report_times"),
    # 6. execution of model runs
    ("execution",),
    # 7. results
    ("result", "result_netcdf", "result_surrogate", "frames", "checkpoint"),
    # 8. the driver, the paper scenarios and what reads results
    ("propagate", "papers", "report", "plots", "baseline", "gate", "replay", "testing"),
    # 9. the library's front doors
    ("run_and_write", "api", "report_document", "progress_display", "__init__"),
    # 10. the command line
    ("cli", "__main__"),
]


def part_of(module: str) -> str | None:
    """The part of a dotted module name inside uqguide (None outside)."""
    bits = module.split(".")
    if bits[0] != "uqguide":
        return None
    if len(bits) == 1:
        return "__init__"
    return bits[1]


def module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    bits = list(rel.parts)
    if bits[-1] == "__init__":
        bits = bits[:-1]
    return ".".join(bits)


def resolve(node: ast.ImportFrom, here: str, is_pkg: bool) -> list[str]:
    """Absolute module names an ``import from`` statement reaches."""
    if node.level == 0:
        base = node.module or ""
    else:
        pkg = here.split(".") if is_pkg else here.split(".")[:-1]
        pkg = pkg[: len(pkg) - (node.level - 1)]
        base = ".".join(pkg + ([node.module] if node.module else []))
    if node.module:
        return [base]
    # ``from . import name``: a submodule where one exists, else a name of the package itself
    return [f"{base}.{a.name}" if _is_module(f"{base}.{a.name}") else base for a in node.names]


def _is_module(dotted: str) -> bool:
    path = PACKAGE.parent.joinpath(*dotted.split("."))
    return path.with_suffix(".py").exists() or (path / "__init__.py").exists()


def edges() -> dict[tuple[str, str], set[str]]:
    """(from part, to part) -> the modules whose imports make that arrow."""
    out: dict[tuple[str, str], set[str]] = defaultdict(set)
    for path in sorted(PACKAGE.rglob("*.py")):
        here = module_name(path)
        src = part_of(here)
        is_pkg = path.name == "__init__.py"
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                targets = resolve(node, here, is_pkg)
            for t in targets:
                dst = part_of(t)
                if dst is not None and src is not None and dst != src:
                    out[(src, dst)].add(here)
    return out


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one part (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dot", action="store_true", help="print Graphviz dot instead")
    args = ap.parse_args(argv)
    layer = {p: i for i, parts in enumerate(LAYERS) for p in parts}
    arrows = edges()
    parts = sorted({p for e in arrows for p in e} | {part_of(module_name(p)) or ""
                                                    for p in PACKAGE.rglob("*.py")})
    unplaced = [p for p in parts if p and p not in layer]
    if unplaced:
        print(f"parts with no layer in LAYERS: {', '.join(unplaced)}; give each its layer in "
              f"{Path(__file__).name}", file=sys.stderr)
        return 2
    graph: dict[str, set[str]] = defaultdict(set)
    for (a, b) in arrows:
        graph[a].add(b)
    if args.dot:
        print("digraph uqguide {\n  rankdir=BT;")
        for (a, b) in sorted(arrows):
            print(f'  "{a}" -> "{b}";')
        print("}")
        return 0
    up = [(a, b) for (a, b) in sorted(arrows) if layer[b] > layer[a]]
    for i, names in reversed(list(enumerate(LAYERS))):
        for p in names:
            if p not in parts:
                continue
            below = sorted(graph.get(p, ()), key=lambda q: (-layer[q], q))
            print(f"{i:2d} {p:18s} -> {', '.join(below) if below else '(nothing)'}")
    bad = 0
    for comp in cycles(graph):
        bad = 1
        print(f"\ncycle: {' <-> '.join(comp)}")
        for a in comp:
            for b in comp:
                if (a, b) in arrows:
                    print(f"  {a} -> {b}: in {', '.join(sorted(arrows[(a, b)]))}")
    for a, b in up:
        bad = 1
        print(f"\nback up: {a} (layer {layer[a]}) -> {b} (layer {layer[b]}): in "
              f"{', '.join(sorted(arrows[(a, b)]))}")
    print(f"\n{len(arrows)} arrows between {len(parts)} parts; "
          f"{len(cycles(graph))} cycles; {len(up)} arrows back up")
    return bad


if __name__ == "__main__":
    sys.exit(main())
