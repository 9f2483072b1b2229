"""The description of one RTL block (see blocks.py for the registry)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from .paths import RTL

Params = dict[str, object]


@dataclass(frozen=True)
class Block:
    name: str
    top: str
    sources: tuple[str, ...]           # relative to rtl/
    params: Callable[[], Params]       # default parameter set (generates tables)
    doc: str
    lint_synth: tuple[str, ...] = ("generic", "ice40")  # Yosys checks run by `make lint`
    synth_only: tuple[str, ...] = ()   # ... and those only `hapgate synth` runs (its table)
    # Yosys warnings waived for this block: (substring of the warning, the written reason)
    yosys_waivers: tuple[tuple[str, str], ...] = ()

    def source_paths(self) -> list[Path]:
        return [RTL / s for s in self.sources]
