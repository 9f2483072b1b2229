"""The whole controller's board top (rtl/boards/hapgate_ecp5_soc.v) through its pins: the
reset button, the 12 MHz clock pin (the PLL bypassed: the core runs on it, USE_PLL=0), and the
PC link on both of its UART connections, the FT2232H's port B pins and the header pins. The soft
CPU boots the cross-built firmware from its RAM image and answers a PING frame sent on each
connection, 8N1 at the configured baud, bit by bit; the reply leaves on both tx pins at once.
Run by tb/boards/test_soc_board.py (Verilator)."""

from __future__ import annotations

import os

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge
from cocotb.utils import get_sim_time
from hapgate.golden import pclink

CLK_HZ = int(os.environ["HG_CLK_HZ"])
BAUD = int(os.environ["HG_BAUD"])
BIT = CLK_HZ // BAUD                     # clocks per UART bit (the UART's divisor)
PERIOD_PS = 20_834                       # the clock pin's period (the RTL knows only CLK_HZ)
FW_VERSION = 0x0100                      # dsp-fw/README.md: PING's firmware version
FPGA_ID = 0x4847_0104                    # rtl/bus/README.md: ID, "HG" map 1.4
RATE_HZ = 1000                           # the firmware's default servo rate
RESET_SYNC_CLOCKS = 4                    # ecp5_pll_reset: released 4 clocks after the button
REPLY_CLOCKS = 5 * CLK_HZ // 1000        # a reply is due within 5 ms of its request


def edge() -> int:
    """The current clock edge (from the simulation time)."""
    return int(get_sim_time("ps")) // PERIOD_PS


async def send(dut, pin, data: bytes) -> int:
    """`data` on the rx pin `pin`, 8N1 at BAUD (bit times counted in clocks); returns the edge
    its last stop bit ends."""
    for byte in data:
        for level in (0, *((byte >> k) & 1 for k in range(8)), 1):
            pin.value = level
            await ClockCycles(dut.clk, BIT)
    return edge()


async def receive(dut, got: list[tuple[int, int, int]]) -> None:
    """Decode uart_tx forever: (edge of the start bit, byte, stop bit) into `got`; at each bit's
    middle the header's tx pin must carry the same level."""
    while True:
        await FallingEdge(dut.uart_tx)
        start = edge()
        await ClockCycles(dut.clk, BIT // 2)
        bits = []
        for k in range(10):   # the middle of each bit, the stop bit's last: the next start
            if k:             # bit may follow right after it
                await ClockCycles(dut.clk, BIT)
            assert int(dut.uart_tx_hdr.value) == int(dut.uart_tx.value), \
                f"the tx pins differ at edge {edge()}"
            bits.append(int(dut.uart_tx.value))
        assert bits[0] == 0, f"start bit at edge {start} not low at its middle"
        got.append((start, sum(b << k for k, b in enumerate(bits[1:9])), bits[9]))


async def reply_to(dut, got: list[tuple[int, int, int]], pin, seq: int) -> pclink.Frame:
    """PING `seq` on `pin`; the reply decoded from the tx pin (the first frame after it)."""
    n = len(got)
    end = await send(dut, pin, pclink.encode(pclink.PING, seq))
    for _ in range(REPLY_CLOCKS // BIT):
        await ClockCycles(dut.clk, BIT)
        if any(b == 0 for _, b, _ in got[n:]):
            break
    new = got[n:]
    assert new and any(b == 0 for _, b, _ in new), \
        f"no reply to PING {seq} within {REPLY_CLOCKS} clocks of its last stop bit"
    assert all(stop == 1 for _, _, stop in new), "a reply byte without its stop bit"
    assert new[0][0] > end, "the reply began before its request had ended"
    chunk = bytes(b for _, b, _ in new)
    frame = pclink.decode(chunk[:chunk.index(0)])
    lat_us = (new[0][0] - end) / CLK_HZ * 1e6
    dut._log.info(f"PING {seq}: reply {len(chunk)} bytes, {lat_us:.0f} us after the request")
    return frame


@cocotb.test()
async def ping_on_both_uart_connections(dut) -> None:
    cocotb.start_soon(Clock(dut.clk, PERIOD_PS, unit="ps").start())
    dut.rst_n.value = 0
    dut.uart_rx.value = 1
    dut.uart_rx_hdr.value = 1
    dut.adc_a.value = 0x80_80_80
    dut.adc_b.value = 0x80_80_80
    dut.enc_index.value = 0
    await ClockCycles(dut.clk, 20)
    for pin in (dut.uart_tx, dut.uart_tx_hdr):     # the lines idle high through reset
        assert int(pin.value) == 1
    dut.rst_n.value = 1
    got: list[tuple[int, int, int]] = []
    cocotb.start_soon(receive(dut, got))
    await ClockCycles(dut.clk, RESET_SYNC_CLOCKS + 2_000)
    assert not got, "the tx pin left idle before any request"

    for seq, pin in ((1, dut.uart_rx), (2, dut.uart_rx_hdr)):   # FT2232H port B, then header
        f = await reply_to(dut, got, pin, seq)
        assert (f.msg_type, f.seq) == (pclink.PING | pclink.REPLY, seq)
        assert pclink.parse_ping(f.data) == (FW_VERSION, FPGA_ID, RATE_HZ)
