"""Issue 24, item 2: the synthesizable source reads as the design. Simulation-only code in rtl/
goes through one mechanism, the macros of rtl/include/hg_sim.vh (docs/design/SIMULATION.md):
no other file of rtl/ tests a simulation define (`ifdef/`ifndef/`elsif of HG_SIM*), every use
is a single line naming a macro the include file defines, and no module has more than one
simulation-only port bundle."""

from __future__ import annotations

import re

from hapgate.base.paths import ROOT

RTL = ROOT / "rtl"
INCLUDE = RTL / "include" / "hg_sim.vh"
SOURCES = sorted(p for p in RTL.rglob("*.v"))
BUNDLES = ("HG_SIM_PORTS", "HG_SIM_TOP_PORTS")


def defined_macros() -> set[str]:
    return set(re.findall(r"^`define\s+(HG_SIM_\w+)", INCLUDE.read_text(), re.M))


def test_no_simulation_define_is_tested_outside_the_include_file() -> None:
    bad = [f"{p.relative_to(ROOT)}:{i}: {line.strip()}" for p in SOURCES
           for i, line in enumerate(p.read_text().splitlines(), 1)
           if re.search(r"`(ifdef|ifndef|elsif)\s+HG_SIM", line)]
    assert not bad, bad


def test_every_use_is_one_line_naming_a_defined_macro() -> None:
    macros = defined_macros()
    assert {"HG_SIM_PORTS", "HG_SIM_CLK", "HG_SIM_EN"} <= macros
    uses = 0
    for p in SOURCES:
        for i, line in enumerate(p.read_text().splitlines(), 1):
            code = line.split("//", 1)[0]
            for name in re.findall(r"\bHG_SIM\w*", code):
                assert re.search(rf"`{name}\b", code), f"{p}:{i}: {name} outside a macro use"
                assert name in macros, f"{p}:{i}: `{name} is not defined in {INCLUDE}"
                uses += 1
            if "`HG_SIM" in code:
                # one line per use: the macro's arguments close on the same line
                tail = code[code.index("`HG_SIM"):]
                assert tail.count("(") == tail.count(")"), f"{p}:{i}: a use spans lines"
    assert uses > 0


def test_at_most_one_simulation_port_bundle_per_module() -> None:
    for p in SOURCES:
        for mod in re.split(r"^\s*module\s+", p.read_text(), flags=re.M)[1:]:
            body = mod.split("endmodule", 1)[0]
            name = mod.split(None, 1)[0]
            n = sum(len(re.findall(rf"`{b}\b", body)) for b in BUNDLES)
            assert n <= 1, f"{p}: module {name} has {n} simulation port bundles"
