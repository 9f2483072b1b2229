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


def _header(path) -> list[str]:
    """The module's parameter and port list: from `module enc_interp3 #(` to the `);` that
    ends it, comments and blank lines included."""
    lines = path.read_text().splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("module enc_interp3 #("))
    end = next(i for i in range(start, len(lines)) if lines[i] == ");")
    return lines[start + 1:end]


def test_the_held_bank_has_the_rtl_banks_parameters_and_ports() -> None:
    """tb/native/device/held/enc_interp3.v is compiled in place of rtl/interp/enc_interp3.v for
    scenes that leave axes out, so its header is a copy of the RTL bank's: held line for line
    here (a parameter or port added to one alone fails)."""
    held = _header(ROOT / "tb" / "native" / "device" / "held" / "enc_interp3.v")
    rtl = _header(RTL / "interp" / "enc_interp3.v")
    assert len(rtl) > 40 and held == rtl
