"""The RTL blocks: top module, sources and a default parameter set (tables generated on demand).

One registry, used by lint, synthesis, the cocotb tests and the benchmarks, so a block is
described once. `params()` generates whatever tables the block reads and returns its parameters;
`Path` values are file parameters (passed as quoted strings, made relative for Yosys).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from .paths import RTL
from . import sine

Params = dict[str, object]


@dataclass(frozen=True)
class Block:
    name: str
    top: str
    sources: tuple[str, ...]           # relative to rtl/
    params: Callable[[], Params]       # default parameter set (generates tables)
    doc: str

    def source_paths(self) -> list[Path]:
        return [RTL / s for s in self.sources]


def sine_lut_params(cfg: sine.SineRomConfig = sine.SineRomConfig()) -> Params:
    return {"ADDR_BITS": cfg.addr_bits, "MAG_BITS": cfg.mag_bits, "LUT_FILE": sine.write_rom(cfg)}


BLOCKS: dict[str, Block] = {
    b.name: b
    for b in (
        Block(
            name="sine_lut",
            top="sine_lut",
            sources=("commutation/sine_lut.v",),
            params=sine_lut_params,
            doc="256-entry quarter-wave sine ROM, unfolded over 1024 angle codes",
        ),
    )
}


def get(name: str) -> Block:
    try:
        return BLOCKS[name]
    except KeyError:
        raise SystemExit(f"unknown block {name!r}; known: {', '.join(BLOCKS)}") from None
