"""The register map, from its one source `rtl/regs/hapgate.rdl` (SystemRDL).

`load()` compiles the RDL with systemrdl-compiler (parameters CLK_HZ, SKEW_CLOCKS, FRAME_CLOCKS)
into plain dataclasses (cached as JSON in build/gen/, so simulator processes need not compile
again): word address, fields with bit range, software access, write side effect, reset value and
allowed range. Everything else reads this: the register model (`hapgate.golden.regmodel`), the
cocotb
tests, and `generate()`, which writes the PeakRDL outputs:

- the C header (peakrdl-cheader) -> `dsp-fw/include/hg_regs.h` (committed: the firmware builds
  without Python; `dsp-fw/include/hg_fpga_regs.h` maps the firmware's names onto it),
- the register document (peakrdl-markdown) -> `rtl/regs/REGISTERS.md` (committed, linked from
  the README),

both for the default parameters (48 MHz). `python -m hapgate.golden.regmap` regenerates them;
`--check` fails if a committed copy differs from a fresh generation (tb/bus/test_regmap.py runs
the same check).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from pathlib import Path

from ..base.atomic import write_bytes
from ..base.block import Block, Params
from ..base.paths import GEN, ROOT, RTL, ensure

RDL = RTL / "regs" / "hapgate.rdl"
C_HEADER = ROOT / "dsp-fw" / "include" / "hg_regs.h"
DOC = RTL / "regs" / "REGISTERS.md"
BUS_ADDR_BITS = 8          # word-address lines the FPGA decodes (0x40..0xFF: unmapped)
DEFAULT_CLK_HZ = 48_000_000


@dataclass(frozen=True)
class Field:
    name: str
    lsb: int
    width: int
    sw: str                  # "r", "w" or "rw"
    hw: str                  # "r", "w", "na", ...
    reset: int
    woclr: bool = False      # write 1 to clear
    singlepulse: bool = False
    range_min: int | None = None   # a written word outside [min, max] is refused
    range_max: int | None = None

    @property
    def mask(self) -> int:
        return ((1 << self.width) - 1) << self.lsb


@dataclass(frozen=True)
class Register:
    name: str                # e.g. "CTRL", "AXIS[1].POS"
    word: int                # word address on the bus
    fields: tuple[Field, ...]
    desc: str = ""

    @property
    def reset(self) -> int:
        return sum(f.reset << f.lsb for f in self.fields)

    def field(self, name: str) -> Field:
        for f in self.fields:
            if f.name == name:
                return f
        raise KeyError(f"{self.name} has no field {name}")


@dataclass(frozen=True)
class RegMap:
    params: dict[str, int]
    unmapped_read: int
    registers: tuple[Register, ...] = field(default_factory=tuple)

    def by_name(self) -> dict[str, Register]:
        return {r.name: r for r in self.registers}

    def by_word(self) -> dict[int, Register]:
        return {r.word: r for r in self.registers}

    def word(self, name: str) -> int:
        return self.by_name()[name].word


def rdl_params(clk_hz: int = DEFAULT_CLK_HZ, skew_ns: int = 2000, frame_ns: int = 16000
               ) -> dict[str, int]:
    """The RDL's parameters for a build: clock and the DAC timing in clocks."""
    return {"CLK_HZ": clk_hz, "SKEW_CLOCKS": clk_hz // 1000 * skew_ns // 1_000_000,
            "FRAME_CLOCKS": clk_hz // 1000 * frame_ns // 1_000_000}


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


@lru_cache(maxsize=8)
def _load_cached(key: tuple[tuple[str, int], ...]) -> RegMap:
    params = dict(key)
    digest = hashlib.sha1((RDL.read_text() + json.dumps(params, sort_keys=True)).encode())
    cache = GEN / f"regmap_{digest.hexdigest()[:12]}.json"
    if cache.exists():
        d = json.loads(cache.read_text())
    else:
        d = _describe(params)
        _atomic_write(cache, json.dumps(d, indent=1))
    regs = tuple(Register(r["name"], r["word"], tuple(Field(**f) for f in r["fields"]),
                          r["desc"]) for r in d["registers"])
    return RegMap(d["params"], d["unmapped_read"], regs)


def load(clk_hz: int = DEFAULT_CLK_HZ, skew_ns: int = 2000, frame_ns: int = 16000) -> RegMap:
    """The register map for a build (compiled once per parameter set, cached)."""
    return _load_cached(tuple(sorted(rdl_params(clk_hz, skew_ns, frame_ns).items())))


# ---------------------------------------------------------------------------- generated files

HEADER_NOTE = ("// GENERATED from rtl/regs/hapgate.rdl by `python -m hapgate.golden.regmap`"
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
    note = ("<!-- GENERATED from rtl/regs/hapgate.rdl by `python -m hapgate.golden.regmap` "
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


# ---------------------------------------------------------------------------- RTL blocks

def bus_params(clk_hz: int = DEFAULT_CLK_HZ) -> Params:
    p = rdl_params(clk_hz)
    return {"CLK_HZ": clk_hz, "SAMPLE_HZ": 1_000_000, "VEL_LOG2W": 8,
            "SKEW_CLOCKS": p["SKEW_CLOCKS"], "FRAME_CLOCKS": p["FRAME_CLOCKS"],
            "ADDR_BITS": BUS_ADDR_BITS}


def blocks() -> list[Block]:
    return [Block(name="hg_bus", top="hg_bus",
                  sources=("bus/emif_slave.v", "bus/hg_regfile.v", "bus/hg_bus.v"),
                  params=bus_params,
                  doc="EMIF-like async bus slave + register file (snapshot, tick, watchdog)")]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hapgate.golden.regmap",
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
