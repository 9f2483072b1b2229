"""The `ecp5-soc` board (the whole controller: rtl/boards/hapgate_ecp5_soc.v) simulated through
its pins: the soft CPU boots the cross-built firmware (`make -C dsp-fw riscv`, the image the
synthesis loads into the RAM) and answers PING on both UART connections
(tb/boards/cocotb_soc_board.py), about 45 000 clocks from reset. Verilator only, as the
SoC's own tests (tb/soc/). The board flow's description of the SoC (sources, CPU, image) is the
simulation's (hapgate.runners.soc), and the pin files constrain every port of the top and
nothing twice."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from hapgate.base.paths import RTL
from hapgate.flows import boards
from hapgate.runners import sim, soc

HERE = Path(__file__).parent
BOARD = boards.BOARDS["ecp5-soc"]
CLK_HZ = 48_000_000        # the board's core clock (the PLL's output), run on the clock pin here
BAUD = 1_000_000           # issue 36: the PC link at 1 Mbaud (hapgate_ecp5_soc's default)


def test_soc_board_answers_ping_on_both_uarts() -> None:
    fw = soc.build_firmware()
    assert fw.hex == boards.FW_HEX
    params = boards.board_params(BOARD, sim=True, clk_hz=CLK_HZ)
    assert params["USE_PLL"] == 0 and params["FW_FILE"] == fw.hex
    sim.run_cocotb(boards.block(BOARD), "verilator", "cocotb_soc_board", HERE, params=params,
                   extra_env={"HG_CLK_HZ": str(CLK_HZ), "HG_BAUD": str(BAUD)})


def test_board_flow_builds_the_simulated_soc() -> None:
    """The board's sources are the simulation's: the gateware, the SoC, the same VexRiscv file,
    then the board's own; the image is the one hapgate.runners.soc builds."""
    src = boards.block(BOARD).source_paths()
    assert src[:len(soc.sources())] == soc.sources()
    assert [p.relative_to(RTL).as_posix() for p in src[len(soc.sources()):]] == [
        "boards/ecp5_pll_reset.v", "boards/hapgate_ecp5_soc.v"]
    assert boards.vexriscv_source() == soc.vexriscv_source()
    assert boards.FW_HEX == soc.FW_BUILD / "riscv" / soc.FW_HEX


def _ports(top: Path) -> set[str]:
    text = re.sub(r"//[^\n]*", "", top.read_text())
    head = text[text.index(") (") : text.index(");")]
    return set(re.findall(r"\b(?:input|output|inout)\s+wire\s+(?:\[[^\]]+\]\s*)?(\w+)", head))


def _constrained(lpf: Path) -> dict[str, str]:
    return {m[0].split("[")[0]: m[1] for m in
            re.findall(r'LOCATE COMP "([^"]+)" SITE "(\w+)"', lpf.read_text())}


def test_pin_files_cover_the_top() -> None:
    """Every port of hapgate_ecp5_soc is placed by ecp5_evn.lpf (the clock, reset, ADC and DAC
    buses: the same pins as hapgate_ecp5_evn's) or ecp5_soc.lpf (the UART), no port by both, and
    no ball twice among the constraints that apply: the freed DSP bus pins carry the header
    UART."""
    ports = _ports(RTL / "boards" / f"{BOARD.top}.v")
    evn = _constrained(RTL / "boards" / BOARD.constraints)
    own = {p: s for f in BOARD.more_constraints for p, s in
           _constrained(RTL / "boards" / f).items()}
    assert ports == {p for p in evn if p in ports} | set(own), ports ^ (set(evn) | set(own))
    assert not set(own) & set(evn)
    assert set(own) == {"uart_rx", "uart_tx", "uart_rx_hdr", "uart_tx_hdr"}
    text = (RTL / "boards" / BOARD.constraints).read_text()
    balls = re.findall(r'LOCATE COMP "(\w+)(?:\[\d+\])?" SITE "(\w+)"', text)
    used = [s for p, s in balls if p in ports] + list(own.values())
    assert len(used) == len(set(used)), "a ball placed twice"
    assert (own["uart_rx"], own["uart_tx"]) == ("P2", "P3")   # litex-boards' ECP5 EVN serial


def test_soc_split_counts_each_side_with_its_submodules() -> None:
    """`hapgate pnr ecp5-soc`'s CPU / gateware figures: each side is its module and everything
    it instantiates (twice-instantiated submodules twice), whatever Yosys names the modules."""
    stat = {"modules": {
        "\\hapgate_ecp5_soc": {"num_cells_by_type": {"$paramod$a1\\hapgate_soc_top": 1,
                                                     "LUT4": 1}},
        "$paramod$a1\\hapgate_soc_top": {"num_cells_by_type": {"$paramod$b2\\hg_soc": 1,
                                                               "$paramod$c3\\hapgate_top": 1}},
        "$paramod$b2\\hg_soc": {"num_cells_by_type": {"VexRiscv": 1, "LUT4": 10, "PFUMX": 7,
                                                      "$paramod\\hg_uart\\BAUD=1": 2}},
        "\\VexRiscv": {"num_cells_by_type": {"LUT4": 100, "TRELLIS_FF": 50, "DP16KD": 2}},
        "$paramod\\hg_uart\\BAUD=1": {"num_cells_by_type": {"LUT4": 3, "TRELLIS_FF": 4}},
        "$paramod$c3\\hapgate_top": {"num_cells_by_type": {"LUT4": 20, "MULT18X18D": 8,
                                                           "CCU2C": 5}},
    }}
    assert boards.soc_split(stat) == {
        "cpu": {"LUT4": 116, "FF": 58, "DP16KD": 2},
        "gateware": {"LUT4": 20, "MULT18X18D": 8, "CCU2C": 5}}


def test_no_fusesoc_target_for_the_soc_board() -> None:
    """hapgate.core has no ecp5-soc target (its CPU file's path depends on the environment)."""
    from hapgate.flows import fusesoc

    assert BOARD not in fusesoc.core_boards()
    assert "hapgate_ecp5_soc" not in fusesoc.core_text()
    assert "hapgate_ecp5_evn" in fusesoc.core_text()


def test_pnr_prints_the_cpu_beside_the_gateware(monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """`hapgate pnr ecp5-soc` prints a second table: each side's cells (the synthesis's split)."""
    from hapgate.commands import cli
    from hapgate.flows.flow import Finding

    split = {"cpu LUT4": 5169, "cpu FF": 2776, "cpu DP16KD": 74,
             "gateware LUT4": 2799, "gateware FF": 2978, "gateware DP16KD": 5}

    def fake_pnr(board: boards.Board, seeds: int = 1, timeout_s: float = 0.0) -> Finding:
        return Finding("nextpnr", board.name, True, 0.0, "fmax 60.0 MHz",
                       {"TRELLIS_COMB": 10977, "TRELLIS_COMB/avail": 83640} | split)

    monkeypatch.setattr(boards, "pnr", fake_pnr)
    assert cli.main(["pnr", "ecp5-soc"]) == 0
    out = capsys.readouterr().out
    rows = {tuple(ln.split()[:2]): ln.split()[2:] for ln in out.splitlines()
            if ln.startswith("ecp5-soc ") and ln.split()[1] in ("cpu", "gateware")}
    kinds = list(boards.SPLIT_CELLS.values())
    assert rows[("ecp5-soc", "cpu")][kinds.index("LUT4")] == "5169"
    assert rows[("ecp5-soc", "gateware")][kinds.index("DP16KD")] == "5"
    assert rows[("ecp5-soc", "cpu")][kinds.index("MULT18X18D")] == "0"
