"""The package is layered by role: no module imports a layer above its own (README, Layout).

Parsed with `ast`, so an import inside a function counts as much as one at the top.
"""

from __future__ import annotations

import ast
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
