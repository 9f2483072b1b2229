"""`hapgate flash BOARD` (and `make flash BOARD=...`): write a board's bitstream with
openFPGALoader (Debian's `openfpgaloader`, installed by tb/debian-deps.sh).

The bitstream is the newest one `make synth` (`hapgate pnr`) packed for the board,
`build/pnr/<board>/s<seed>.<bitstream>`, or `--bitstream PATH`. It goes to the FPGA's
configuration SRAM (lost at power-off), or with `--flash` to the board's SPI flash (loaded at
every power-up). Exit 0 when written, 2 for bad arguments, a missing bitstream, a missing
openFPGALoader or no board attached (each named), 1 when openFPGALoader fails on a board it
found. `HG_OPENFPGALOADER` names another executable (the tests use a stand-in).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from ..base.paths import BUILD
from ..flows import boards

NO_DEVICE = re.compile(r"found\s+0\s+USB\s+device", re.I)
NOT_FOUND = re.compile(r"unable to open ftdi device|device not found|no device found|"
                       r"JTAG init failed", re.I)


class FlashError(RuntimeError):
    """A refusal before anything is written: the message says what, exit 2."""


def loader() -> str:
    exe = os.environ.get("HG_OPENFPGALOADER", "openFPGALoader")
    path = shutil.which(exe)
    if path is None:
        raise FlashError(f"{exe} not found: install Debian's openfpgaloader (tb/debian-deps.sh, "
                         "or `make deps` as root)")
    return path


def bitstream(board: boards.Board, given: str | None) -> Path:
    """The file to write: `given`, else the newest packed bitstream of the board."""
    if given is not None:
        if not given:
            raise FlashError("--bitstream: the path is empty")
        p = Path(given)
        if not p.is_file():
            raise FlashError(f"--bitstream {given}: no such file")
        return p
    wd = BUILD / "pnr" / board.name
    found = sorted(wd.glob(f"s*.{board.bitstream}"), key=lambda f: f.stat().st_mtime)
    found = [f for f in found if f.stat().st_size > 0]
    if not found:
        raise FlashError(f"no bitstream for {board.name} in {wd}/ (s*.{board.bitstream}): "
                         "run `make synth` first, or give --bitstream")
    return found[-1]


def flash(board_name: str, given: str | None = None, to_flash: bool = False) -> int:
    board = boards.BOARDS.get(board_name)
    if board is None:
        raise FlashError(f"unknown board {board_name!r}; known: {', '.join(boards.BOARDS)}")
    if not board.loader:
        raise FlashError(f"{board_name}: openFPGALoader knows no board for it")
    bit = bitstream(board, given)
    exe = loader()
    scan = subprocess.run([exe, "--scan-usb"], capture_output=True, text=True)
    said = scan.stdout + scan.stderr
    if NO_DEVICE.search(said):
        raise FlashError(f"no board attached: openFPGALoader found no USB device (connect the "
                         f"{board.name} board's USB port)")
    cmd = [exe, "-b", board.loader, *(["-f"] if to_flash else []), str(bit)]
    print(f"flash: {' '.join(cmd)}", file=sys.stderr, flush=True)
    run = subprocess.run(cmd, capture_output=True, text=True)
    out = (run.stdout + run.stderr).strip()
    if run.returncode != 0:
        if NOT_FOUND.search(out):
            raise FlashError(f"no board attached: openFPGALoader cannot open the "
                             f"{board.loader} board's cable: {out.splitlines()[-1]}")
        print(f"error: openFPGALoader failed ({run.returncode}): {out}", file=sys.stderr)
        return 1
    where = "SPI flash (kept at power-off)" if to_flash else "FPGA (SRAM: until power-off)"
    print(f"flash: {bit} written to the {board.name}'s {where}", file=sys.stderr)
    return 0


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("board", metavar="BOARD", help=f"one of {', '.join(boards.BOARDS)}")
    p.add_argument("--bitstream", metavar="PATH",
                   help="the file to write (default: the newest one `make synth` packed)")
    p.add_argument("--flash", action="store_true",
                   help="write the SPI flash (loaded at every power-up) instead of the SRAM")


def main(args: argparse.Namespace) -> int:
    try:
        return flash(args.board, args.bitstream, args.flash)
    except FlashError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
