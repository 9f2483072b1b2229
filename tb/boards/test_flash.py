"""`hapgate flash BOARD` / `make flash BOARD=...` (issue 36): openFPGALoader writes the newest
packed bitstream; without a board it says so and exits 2. The board-less cases run the real
openFPGALoader (Debian's, tb/debian-deps.sh; CI has no FPGA on USB); what is written to a board
is checked with a stand-in executable (HG_OPENFPGALOADER) that answers as openFPGALoader does
and records its arguments."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from hapgate.base.paths import ROOT
from hapgate.commands import flash
from hapgate.flows import boards

HG = [sys.executable, "-m", "hapgate.commands.cli"]


def run(*argv: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*HG, *argv], cwd=ROOT, capture_output=True, text=True,
                          env=os.environ | (env or {}), timeout=120)


def stand_in(tmp: Path, scan: str, rc: int = 0, says: str = "") -> tuple[Path, Path]:
    """An openFPGALoader that prints `scan` for --scan-usb and, else, `says` with exit `rc`;
    every call's arguments go to a log."""
    log = tmp / "calls.log"
    exe = tmp / "openFPGALoader"
    exe.write_text(f"#!/bin/sh\necho \"$@\" >> {log}\n"
                   f"if [ \"$1\" = --scan-usb ]; then printf '%s\\n' \"{scan}\"; exit 0; fi\n"
                   f"printf '%s\\n' \"{says}\" >&2\nexit {rc}\n")
    exe.chmod(0o755)
    return exe, log


@pytest.mark.parametrize("board", ["ecp5-evn", "ecp5-soc"])
def test_no_board_attached_exits_2_saying_so(tmp_path: Path, board: str) -> None:
    bit = tmp_path / "s1.design.bit"
    bit.write_bytes(b"\xff" * 64)
    r = run("flash", board, "--bitstream", str(bit))             # the real openFPGALoader
    assert r.returncode == 2, r.stderr
    assert "no board attached" in r.stderr and board in r.stderr, r.stderr


def test_the_soc_board_is_written_as_the_ecp5_evaluation_board(tmp_path: Path) -> None:
    """ecp5-soc is the same board as ecp5-evn: openFPGALoader's `ecp5_evn`."""
    exe, log = stand_in(tmp_path, "found 1 USB device")
    bit = tmp_path / "s1.design.bit"
    bit.write_bytes(b"\xff" * 64)
    r = run("flash", "ecp5-soc", "--bitstream", str(bit), env={"HG_OPENFPGALOADER": str(exe)})
    assert r.returncode == 0, r.stderr
    assert log.read_text().splitlines() == ["--scan-usb", f"-b ecp5_evn {bit}"]


@pytest.mark.parametrize("argv, want", [
    (("flash", "nope"), "unknown board 'nope'; known: ice40-hx8k, ecp5-evn, ecp5-soc"),
    (("flash", "ecp5-evn", "--bitstream", ""), "--bitstream: the path is empty"),
    (("flash", "ecp5-evn", "--bitstream", "/nonexistent/a.bit"),
     "--bitstream /nonexistent/a.bit: no such file"),
])
def test_bad_arguments_exit_2_naming_them(argv: tuple[str, ...], want: str) -> None:
    r = run(*argv)
    assert r.returncode == 2 and want in r.stderr, r.stderr


def test_the_default_bitstream_is_the_newest_packed_one(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """Without --bitstream: the newest non-empty `s<seed>.<bitstream>` of build/pnr/<board>/
    (here a build folder of the test's own); none there: the folder is named, with `make synth`."""
    monkeypatch.setattr(flash, "BUILD", tmp_path)
    board = boards.BOARDS["ice40-hx8k"]
    with pytest.raises(flash.FlashError, match=r"ice40-hx8k in .*: run `make synth` first"):
        flash.bitstream(board, None)
    wd = tmp_path / "pnr" / board.name
    wd.mkdir(parents=True)
    for i, (seed, size) in enumerate(((1, 64), (3, 64), (2, 0))):   # s2: an empty (failed) pack
        f = wd / f"s{seed}.{board.bitstream}"
        f.write_bytes(b"\0" * size)
        os.utime(f, (1000 + i, 1000 + i))
    assert flash.bitstream(board, None) == wd / f"s3.{board.bitstream}"


@pytest.mark.parametrize("extra, sram", [((), True), (("--flash",), False)], ids=["sram", "spi"])
def test_the_bitstream_goes_to_the_named_board(tmp_path: Path, extra: tuple[str, ...],
                                               sram: bool) -> None:
    exe, log = stand_in(tmp_path, "found 1 USB device")
    bit = tmp_path / "s2.design.bit"
    bit.write_bytes(b"\xff" * 64)
    r = run("flash", "ecp5-evn", "--bitstream", str(bit), *extra,
            env={"HG_OPENFPGALOADER": str(exe)})
    assert r.returncode == 0, r.stderr
    calls = log.read_text().splitlines()
    assert calls == ["--scan-usb", f"-b ecp5_evn {'' if sram else '-f '}{bit}"], calls
    assert ("SRAM" if sram else "SPI flash") in r.stderr


def test_a_cable_that_does_not_open_is_no_board_and_a_failure_is_1(tmp_path: Path) -> None:
    bit = tmp_path / "s1.design.bit"
    bit.write_bytes(b"\xff" * 64)
    exe, _ = stand_in(tmp_path, "found 1 USB device", 1, "JTAG init failed with: unable to "
                      "open ftdi device")
    r = run("flash", "ecp5-evn", "--bitstream", str(bit), env={"HG_OPENFPGALOADER": str(exe)})
    assert r.returncode == 2 and "no board attached" in r.stderr, r.stderr
    exe, _ = stand_in(tmp_path, "found 1 USB device", 1, "CRC error")
    r = run("flash", "ecp5-evn", "--bitstream", str(bit), env={"HG_OPENFPGALOADER": str(exe)})
    assert r.returncode == 1 and "CRC error" in r.stderr, r.stderr


def test_make_flash_needs_a_board() -> None:
    r = subprocess.run(["make", "-s", "flash"], cwd=ROOT, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode != 0 and "make flash BOARD=NAME" in r.stderr, r.stderr
