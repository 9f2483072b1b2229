"""The registry of RTL blocks: top module, sources and a default parameter set.

One registry, used by lint, synthesis, the cocotb tests and the benchmarks, so a block is
described once. Each model module that owns RTL blocks exposes `blocks() -> list[Block]`;
`params()` generates whatever tables the block reads and returns its parameters (`Path` values
are file parameters, passed as quoted strings and made relative for Yosys).
"""

from __future__ import annotations

from importlib import import_module

from ..base.block import Block, Params

__all__ = ["Block", "Params", "BLOCKS", "get"]

# Model modules that own RTL blocks, in lint/report order.
OWNERS = ("golden.sine", "golden.interp", "golden.commutation", "golden.regmap", "golden.capture",
          "golden.configs", "golden.render",
          "flows.boards")

BLOCKS: dict[str, Block] = {
    b.name: b for owner in OWNERS for b in import_module(f"hapgate.{owner}").blocks()
}


def get(name: str) -> Block:
    try:
        return BLOCKS[name]
    except KeyError:
        raise SystemExit(f"unknown block {name!r}; known: {', '.join(BLOCKS)}") from None
