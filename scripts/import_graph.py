"""The import graph between uqguide's layers, read from the package's folders.

The folders are the layers. A *part* is a folder of the package (``uqguide/config/``,
``uqguide/models/``...) or a top-level module (``uqguide/cli.py``). Each folder says where it
sits in the first line of its ``__init__.py`` docstring, "... above ``<folder>``" (``core``, the
bottom folder, says nothing), so the order lives in the tree, beside the code it orders. Two
top-level modules are the foundation every layer may import (``errors``, ``_version``); the
other top-level modules are the front doors (``api``, ``cli``, ``testing``, ``__init__``),
above every folder.

Every ``import`` in the package is read from the source (module level, inside functions and
under ``TYPE_CHECKING`` alike: a lazy or type-only import is still a dependency), and folded onto
the parts.

Printed: each part's layer and the parts it imports. Exit status:

- 0: no cycle, between parts or between the modules of one folder, and every arrow points down;
- 1: a cycle (printed, with the modules that make it), or an arrow that runs back up;
- 2: a folder that does not say what it is above, or a top-level module that is neither a front
  door nor the foundation (a new module belongs in a folder).

Run it from anywhere: ``python scripts/import_graph.py``. ``--dot`` prints the graph in
Graphviz form instead.
"""

from __future__ import annotations

import argparse
import ast
import re
import sys
from collections import defaultdict
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "uqguide"

#: Top-level modules below every folder: what any layer may import.
FOUNDATION = ("errors", "_version")
#: Top-level modules above every folder: the library's and the command line's front doors.
FRONT_DOORS = ("api", "testing", "__init__", "cli", "__main__")

_ABOVE = re.compile(r"above ``(\w+)``")


class LayerError(Exception):
    """The tree does not say how its folders are layered."""


def folder_layers(package: Path = PACKAGE) -> dict[str, int]:
    """Folder -> layer number, from each folder's "above ``X``" (``core`` at 1, foundation 0)."""
    above: dict[str, str | None] = {}
    for init in sorted(package.glob("*/__init__.py")):
        name = init.parent.name
        doc = ast.get_docstring(ast.parse(init.read_text(encoding="utf-8"))) or ""
        first = doc.strip().splitlines()[0] if doc.strip() else ""
        m = _ABOVE.search(first)
        above[name] = m.group(1) if m else None
    roots = [f for f, a in above.items() if a is None]
    if roots != ["core"]:
        others = [f for f in roots if f != "core"]
        raise LayerError(f"folders that do not say what they are above: {', '.join(others)}; "
                         "end the first line of their __init__.py docstring with "
                         "\"above ``<folder>``\"")
    layer: dict[str, int] = {}

    def depth(f: str, seen: tuple[str, ...] = ()) -> int:
        if f in seen:
            raise LayerError(f"folders above each other in a circle: {' -> '.join(seen + (f,))}")
        if f not in above:
            raise LayerError(f"{seen[-1]} says it is above ``{f}``, which is not a folder")
        if f not in layer:
            below = above[f]
            layer[f] = 1 if below is None else depth(below, seen + (f,)) + 1
        return layer[f]

    for f in above:
        depth(f)
    return layer


def layers(package: Path = PACKAGE) -> dict[str, int]:
    """Every part -> its layer: foundation 0, the folders, the front doors on top."""
    folder = folder_layers(package)
    top = max(folder.values()) + 1
    out = {p: 0 for p in FOUNDATION}
    out.update(folder)
    out.update({p: top + (p in ("cli", "__main__")) for p in FRONT_DOORS})
    return out


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


def module_edges() -> dict[str, set[str]]:
    """Module -> the uqguide modules it imports (dotted names)."""
    out: dict[str, set[str]] = defaultdict(set)
    for path in sorted(PACKAGE.rglob("*.py")):
        here = module_name(path)
        is_pkg = path.name == "__init__.py"
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        out[here]
        for node in ast.walk(tree):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                targets = resolve(node, here, is_pkg)
            for t in targets:
                if part_of(t) is not None and t != here:
                    out[here].add(t)
    return out


def edges() -> dict[tuple[str, str], set[str]]:
    """(from part, to part) -> the modules whose imports make that arrow."""
    out: dict[tuple[str, str], set[str]] = defaultdict(set)
    for here, targets in module_edges().items():
        src = part_of(here)
        for t in targets:
            dst = part_of(t)
            if dst is not None and src is not None and dst != src:
                out[(src, dst)].add(here)
    return out


def folder_cycles() -> list[list[str]]:
    """Cycles among the modules of one folder (an arrow inside a layer may not close a loop)."""
    mods = module_edges()
    inner: dict[str, set[str]] = defaultdict(set)
    for a, targets in mods.items():
        for b in targets:
            # a package's __init__ is its folder's door, not a module of it
            if part_of(a) == part_of(b) and a.count(".") >= 2 and b in mods \
                    and not b == ".".join(a.split(".")[:2]):
                inner[a].add(b)
    return cycles(inner)


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
    try:
        layer = layers()
    except LayerError as e:
        print(e, file=sys.stderr)
        return 2
    arrows = edges()
    parts = sorted({p for e in arrows for p in e} | {part_of(module_name(p)) or ""
                                                    for p in PACKAGE.rglob("*.py")})
    unplaced = [p for p in parts if p and p not in layer]
    if unplaced:
        print(f"top-level modules that are neither a front door nor the foundation: "
              f"{', '.join(unplaced)}; move each into the folder of its layer (or name it in "
              f"{Path(__file__).name}'s FRONT_DOORS if it truly is one)", file=sys.stderr)
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
    for p in sorted(parts, key=lambda q: (-layer[q], q)):
        below = sorted(graph.get(p, ()), key=lambda q: (-layer[q], q))
        kind = "/" if (PACKAGE / p).is_dir() else ".py"
        print(f"{layer[p]:2d} {p + kind:18s} -> {', '.join(below) if below else '(nothing)'}")
    bad = 0
    found = cycles(graph) + folder_cycles()
    for comp in found:
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
          f"{len(found)} cycles; {len(up)} arrows back up")
    return bad


if __name__ == "__main__":
    sys.exit(main())
