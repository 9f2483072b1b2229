"""The register map's generation, from its one source `rtl/regs/hapgate.rdl` (SystemRDL).

`load()` compiles the RDL with systemrdl-compiler (parameters CLK_HZ, SKEW_CLOCKS, FRAME_CLOCKS)
into the plain data of `hapgate.golden.regmap` (word address, fields with bit range, software
access, write side effect, reset value and allowed range), cached as JSON in build/gen/ by the
content of the RDL and the parameters (hapgate.base.cache), so simulator processes need not
compile again. Everything else reads that: the register model (`hapgate.golden.regmodel`), the
cocotb tests, the virtual device. `generate()` writes the PeakRDL outputs:

- the C header (peakrdl-cheader) -> `dsp-fw/include/hg_regs.h` (committed: the firmware builds
  without Python; `dsp-fw/include/hg_fpga_regs.h` maps the firmware's names onto it),
- the register document (peakrdl-markdown) -> `rtl/regs/REGISTERS.md` (committed, linked from
  the README),

both for the default parameters (48 MHz). `python -m hapgate.flows.regmap` (`make regs`)
regenerates them; `--check` fails if a committed copy differs from a fresh generation
(tb/bus/test_regmap.py runs the same check).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from dataclasses import asdict
from functools import lru_cache
from pathlib import Path

from ..base import cache
from ..base.atomic import write_bytes
from ..base.paths import GEN, ROOT, RTL, ensure
from ..golden.regmap import BUS_ADDR_BITS as BUS_ADDR_BITS
from ..golden.regmap import DEFAULT_CLK_HZ as DEFAULT_CLK_HZ
from ..golden.regmap import Field, RegMap, from_description, rdl_params

RDL = RTL / "regs" / "hapgate.rdl"
C_HEADER = ROOT / "dsp-fw" / "include" / "hg_regs.h"
DOC = RTL / "regs" / "REGISTERS.md"


def _compile(params: dict[str, int]):
    from systemrdl import RDLCompiler

    comp = RDLCompiler()
    comp.compile_file(str(RDL))
    return comp.elaborate(parameters=params)


def _describe(params: dict[str, int]) -> dict:
    from systemrdl.node import FieldNode, RegNode

    root = _compile(params)
    top = root.top
    regs = []
    for node in top.descendants(unroll=True):
        if not isinstance(node, RegNode):
            continue
        if node.absolute_address % 4:
            raise ValueError(f"{node.get_path()} is not word-aligned")
        fields = []
        for f in node.fields():
            assert isinstance(f, FieldNode)
            sw = ("r" if f.is_sw_readable else "") + ("w" if f.is_sw_writable else "")
            onwrite = f.get_property("onwrite")
            fields.append(asdict(Field(
                name=f.inst_name, lsb=f.lsb, width=f.width, sw=sw,
                hw=f.get_property("hw").name, reset=int(f.get_property("reset") or 0),
                woclr=onwrite is not None and onwrite.name == "woclr",
                singlepulse=bool(f.get_property("singlepulse")),
                range_min=f.get_property("range_min", default=None),
                range_max=f.get_property("range_max", default=None))))
        path = node.get_path(hier_separator=".")
        name = path.split(".", 1)[1]
        regs.append({"name": name, "word": node.absolute_address // 4, "fields": fields,
                     "desc": node.get_property("desc") or ""})
    return {"params": params, "unmapped_read": int(top.get_property("unmapped_read")),
            "registers": regs}


def _atomic_write(path: Path, text: str) -> None:
    ensure(path.parent)
    if path.exists() and path.read_text() == text:
        return
    write_bytes(path, text)


def _atomic_write(path: Path, text: str) -> None:
    ensure(path.parent)
    if path.exists() and path.read_text() == text:
        return
    write_bytes(path, text)


@lru_cache(maxsize=8)
def _load_cached(key: tuple[tuple[str, int], ...]) -> RegMap:
    params = dict(key)
    path = GEN / f"regmap_{cache.digest(files=[RDL], data=params)}.json"
    cache.cached_file(path, lambda: json.dumps(_describe(params), indent=1))
    return from_description(json.loads(path.read_text()))


def load(clk_hz: int = DEFAULT_CLK_HZ, skew_ns: int = 2000, frame_ns: int = 16000) -> RegMap:
    """The register map for a build (compiled once per parameter set, cached)."""
    return _load_cached(tuple(sorted(rdl_params(clk_hz, skew_ns, frame_ns).items())))


# ---------------------------------------------------------------------------- generated files

HEADER_NOTE = ("// GENERATED from rtl/regs/hapgate.rdl by `python -m hapgate.flows.regmap`"
               " (peakrdl-cheader) -- do not edit.\n// Defaults: CLK_HZ = 48 MHz. Offsets are"
               " BYTE offsets; the DSP bus is word-addressed (word = byte / 4).\n")


def render_c_header() -> str:
    from peakrdl_cheader.c_standards import CStandard
    from peakrdl_cheader.exporter import CHeaderExporter

    root = _compile(rdl_params())
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "hg_regs.h"
        CHeaderExporter().export(root, str(out), std=CStandard.gnu99)
        text = out.read_text()
    return HEADER_NOTE + text


def render_markdown() -> str:
    from peakrdl_markdown import MarkdownExporter

    root = _compile(rdl_params())
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "REGISTERS.md"
        MarkdownExporter().export(root, str(out))
        text = out.read_text()
    note = ("<!-- GENERATED from rtl/regs/hapgate.rdl by `python -m hapgate.flows.regmap` "
            "(peakrdl-markdown), defaults CLK_HZ = 48 MHz. Do not edit. -->\n\n"
            "Offsets are byte offsets; the DSP bus is word-addressed (word address = offset / 4)."
            " Unmapped addresses read 0xDEADBEEF; writes to them change nothing.\n\n")
    return note + text


def outputs() -> dict[Path, str]:
    return {C_HEADER: render_c_header(), DOC: render_markdown()}


def generate(check: bool = False) -> list[Path]:
    """Write the committed outputs (or, with check, list those that differ from a fresh run)."""
    stale = []
    for path, text in outputs().items():
        if not path.exists() or path.read_text() != text:
            stale.append(path)
            if not check:
                _atomic_write(path, text)
    return stale


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hapgate.flows.regmap",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true", help="fail if a committed output is stale")
    args = ap.parse_args(argv)
    stale = generate(check=args.check)
    for p in stale:
        print(f"{'stale' if args.check else 'wrote'}: {p.relative_to(ROOT)}")
    if not stale:
        print("register outputs up to date")
    return 1 if (args.check and stale) else 0


if __name__ == "__main__":
    sys.exit(main())
