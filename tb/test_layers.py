"""The package is layered by role: no module imports a layer above its own (README, Layout).

Parsed with `ast`, so an import inside a function counts as much as one at the top.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "models" / "hapgate"

# layer -> the layers it may import (itself always allowed)
ALLOWED: dict[str, set[str]] = {
    "base": set(),
    "golden": {"base"},
    "flows": {"base", "golden"},
    "runners": {"base", "golden", "flows"},
    "device": {"base", "golden", "flows", "runners"},
    "host": {"base", "golden"},
    "commands": {"base", "golden", "flows", "runners", "device", "host"},
}


def _imported_layers(path: Path, pkg: Path = PKG) -> list[tuple[int, str]]:
    """(line, layer) for every import of a hapgate module in `path` (a file under `pkg`)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    rel = path.relative_to(pkg).with_suffix("").parts      # e.g. ("golden", "interp")
    found: list[tuple[int, str]] = []

    def add(line: int, dotted: str, names: list[str]) -> None:
        parts = dotted.split(".") if dotted else []
        if parts[:1] == ["hapgate"]:
            parts = parts[1:]
        if parts:
            found.append((line, parts[0]))
        else:                                  # `from hapgate import x` / `from .. import x`
            found.extend((line, n) for n in names)

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] == "hapgate":
                    add(node.lineno, a.name, [])
        elif isinstance(node, ast.ImportFrom):
            names = [a.name for a in node.names]
            if node.level == 0:
                if (node.module or "").split(".")[0] == "hapgate":
                    add(node.lineno, node.module or "", names)
            else:
                anchor = list(rel[:-1])[: len(rel) - node.level]   # package the dots lead to
                dotted = ".".join([*anchor, *(node.module.split(".") if node.module else [])])
                add(node.lineno, dotted, names)
    return sorted(found)


def _modules() -> list[Path]:
    return sorted(p for p in PKG.rglob("*.py"))


def test_every_module_is_in_a_layer():
    stray = [str(p.relative_to(PKG)) for p in _modules()
             if p.parent == PKG and p.name != "__init__.py"
             or p.parent != PKG and p.relative_to(PKG).parts[0] not in ALLOWED]
    assert not stray, f"modules outside a layer folder: {stray}"


@pytest.mark.parametrize("layer", sorted(ALLOWED))
def test_no_upward_import(layer):
    bad = []
    for path in sorted((PKG / layer).rglob("*.py")):
        for line, target in _imported_layers(path):
            if target != layer and target not in ALLOWED[layer]:
                bad.append(f"{path.relative_to(PKG)}:{line} imports hapgate.{target}")
    assert not bad, "layer rule broken:\n" + "\n".join(bad)


def test_checker_sees_an_upward_import(tmp_path):
    """The checker itself: upward imports, relative or absolute, inside a function, are seen."""
    fake = tmp_path / "hapgate"
    (fake / "golden").mkdir(parents=True)
    (fake / "golden" / "x.py").write_text(
        "from . import sine\n"
        "def f():\n    from ..runners import sim\n    from hapgate.commands.cli import main\n"
        "    from .. import device\n    import hapgate.flows.flow\n")
    found = _imported_layers(fake / "golden" / "x.py", fake)
    assert found == [(1, "golden"), (3, "runners"), (4, "commands"), (5, "device"), (6, "flows")]


def test_top_package_imports_nothing():
    assert not _imported_layers(PKG / "__init__.py")


# ---------------------------------------------------------------------------- import cycles

def _module_name(path: Path, pkg: Path) -> str:
    parts = path.relative_to(pkg.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph(pkg: Path = PKG) -> dict[str, dict[str, int]]:
    """module -> {imported module of the same package: first line}, from every import in the
    file (top level and inside functions). `from P import x` counts as importing P.x when that
    is a module of the package, else P."""
    files = {_module_name(p, pkg): p for p in sorted(pkg.rglob("*.py"))}
    root = pkg.name
    graph: dict[str, dict[str, int]] = {}
    for mod, path in files.items():
        here = mod.split(".") if path.name == "__init__.py" else mod.split(".")[:-1]
        edges: dict[str, int] = {}

        def add(target: str, line: int, mod: str = mod, edges: dict[str, int] = edges) -> None:
            while target and target not in files:       # hapgate.x.y.Name -> hapgate.x.y
                target = target.rpartition(".")[0]
            if target and target != mod:
                edges.setdefault(target, line)

        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.split(".")[0] == root:
                        add(a.name, node.lineno)
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = here[: len(here) - node.level + 1]
                    dotted = ".".join([*base, *([node.module] if node.module else [])])
                else:
                    dotted = node.module or ""
                if dotted.split(".")[0] != root:
                    continue
                for a in node.names:
                    sub = f"{dotted}.{a.name}"
                    add(sub if sub in files else dotted, node.lineno)
        graph[mod] = edges
    return graph


def find_cycles(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """One cycle (as a closed path a -> ... -> a) per strongly connected component of more than
    one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    comps: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, {}):
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
                comps.append(comp)

    for v in sorted(graph):
        if v not in index:
            visit(v)
    cycles = []
    for comp in comps:                    # a path inside the component back to its start
        members, start = set(comp), min(comp)
        prev: dict[str, str] = {}
        todo, seen = [start], {start}
        while todo:
            v = todo.pop(0)
            for w in sorted(graph[v]):
                if w == start:
                    path = [v]
                    while path[-1] != start:
                        path.append(prev[path[-1]])
                    cycles.append([start, *reversed(path[:-1]), start] if v != start
                                  else [start, start])
                    todo = []
                    break
                if w in members and w not in seen:
                    seen.add(w)
                    prev[w] = v
                    todo.append(w)
    return cycles


def test_no_import_cycle():
    graph = import_graph()
    cycles = find_cycles(graph)
    text = ["  " + " -> ".join(f"{a} (line {graph[a][b]})" for a, b in zip(c, c[1:]))
            + f" -> {c[-1]}" for c in cycles]
    assert not cycles, "import cycles (imports inside functions count):\n" + "\n".join(text)


def test_cycle_finder_sees_a_cycle(tmp_path):
    """The finder itself, on a synthetic package: a cycle through an import inside a function
    and a relative `from . import`, and an acyclic module beside it."""
    fake = tmp_path / "hapgate"
    (fake / "golden").mkdir(parents=True)
    (fake / "__init__.py").write_text("")
    (fake / "golden" / "__init__.py").write_text("")
    (fake / "golden" / "a.py").write_text("from .b import f\n")
    (fake / "golden" / "b.py").write_text("def f():\n    from . import c\n")
    (fake / "golden" / "c.py").write_text("import hapgate.golden.a\nfrom hapgate.golden import d\n")
    (fake / "golden" / "d.py").write_text("import numpy\n")
    graph = import_graph(fake)
    assert graph["hapgate.golden.b"] == {"hapgate.golden.c": 2}
    assert graph["hapgate.golden.c"] == {"hapgate.golden.a": 1, "hapgate.golden.d": 2}
    assert find_cycles(graph) == [["hapgate.golden.a", "hapgate.golden.b", "hapgate.golden.c",
                                   "hapgate.golden.a"]]
    (fake / "golden" / "c.py").write_text("from hapgate.golden import d\n")
    assert find_cycles(import_graph(fake)) == []




def test_golden_needs_only_base_numpy_and_the_standard_library():
    """The golden models are plain Python (no simulator, no plotting): every import of every
    golden module, at the top or inside a function, is hapgate.base, hapgate.golden, numpy or
    the standard library: no exception (the RDL compiler lives in hapgate.flows.regmap)."""
    bad = []
    for path in sorted((PKG / "golden").rglob("*.py")):
        allowed = set(sys.stdlib_module_names) | {"numpy", "__future__"}
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level
                     else [])
            for n in names:
                top = n.split(".")[0]
                ok = top in allowed or n.split(".")[:2] in (["hapgate", "base"],
                                                            ["hapgate", "golden"])
                if not ok:
                    bad.append(f"{path.relative_to(PKG)}:{node.lineno} imports {n}")
    assert not bad, "golden imports outside base, numpy and the standard library:\n" + \
        "\n".join(bad)
