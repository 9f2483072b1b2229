"""The register map as plain data: registers with their word address and fields (bit range,
software access, write side effect, reset value, allowed range), what the register-file model
(`hapgate.golden.regmodel`) and the tests need, and the bus block's parameters.

The data comes from the one source `rtl/regs/hapgate.rdl` (SystemRDL), compiled by
`hapgate.flows.regmap` (`load(clk_hz)`; it also generates the C header and the register
document); this module needs no RDL compiler: `from_description` builds a `RegMap` from the
compiled description (plain JSON data).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..base.block import Block, Params

BUS_ADDR_BITS = 8          # word-address lines the FPGA decodes (0x44..0xFF: unmapped)
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


def from_description(d: dict[str, Any]) -> RegMap:
    """The RegMap of a compiled description: {"params", "unmapped_read", "registers": [{"name",
    "word", "fields": [Field's fields as a dict], "desc"}]} (hapgate.flows.regmap makes it)."""
    regs = tuple(Register(r["name"], r["word"], tuple(Field(**f) for f in r["fields"]),
                          r["desc"]) for r in d["registers"])
    return RegMap(d["params"], d["unmapped_read"], regs)


# ---------------------------------------------------------------------------- RTL blocks

def bus_params(clk_hz: int = DEFAULT_CLK_HZ) -> Params:
    """The bus block's parameters: the paper's configuration's, at clk_hz."""
    from . import configs

    p = rdl_params(clk_hz)
    paper = configs.get("paper")
    return {"CLK_HZ": clk_hz, "SAMPLE_HZ": paper.sample_hz, "VEL_LOG2W": paper.vel_log2w,
            "SKEW_CLOCKS": p["SKEW_CLOCKS"], "FRAME_CLOCKS": p["FRAME_CLOCKS"],
            "ADDR_BITS": BUS_ADDR_BITS}


def blocks() -> list[Block]:
    return [Block(name="hg_bus", top="hg_bus",
                  sources=("bus/emif_slave.v", "bus/hg_regfile.v", "bus/hg_bus.v"),
                  params=bus_params,
                  doc="EMIF-like async bus slave + register file (snapshot, tick, watchdog)")]
