"""The mutant list still fits the tree (`make mutants` is long and outside `make test`): every
edit's text occurs exactly `count` times in its file, a mutant changes something, and every test
it names exists, so a move or a rename shows here at once rather than as a mutant that cannot
be applied (or a test name that kills nothing) at the next `make mutants`."""

from __future__ import annotations

import ast
import re

import pytest
from hapgate.base.paths import ROOT
from hapgate.commands import mutants

MUTANTS = mutants.load()


def _test_exists(nodeid: str) -> bool:
    path, _, rest = nodeid.partition("::")
    f = ROOT / path
    if not f.is_file():
        return False
    if not rest:
        return True
    name = re.split(r"[\[:]", rest)[0]
    tree = ast.parse(f.read_text())
    return any(isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))
               and n.name == name for n in ast.walk(tree))


@pytest.mark.parametrize("m", MUTANTS, ids=[m.name for m in MUTANTS])
def test_mutant_applies_and_names_real_tests(m: mutants.Mutant) -> None:
    for e in m.edits:
        text = (ROOT / e.file).read_text()
        assert text.count(e.find) == e.count, (e.file, e.find)
        assert e.find != e.replace
    assert m.tests and all(_test_exists(t) for t in m.tests), m.tests


def test_names_are_unique() -> None:
    names = [m.name for m in MUTANTS]
    assert len(names) == len(set(names))
