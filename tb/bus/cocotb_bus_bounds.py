"""cocotb: the FPGA watchdog's documented numbers at their boundaries (issue 29), on the bus +
register file (rtl/bus/hg_bus.v), the register model replaying the same accesses. Both are
compared with the spec's numbers, written here (tb/bus/test_bus_bounds.py has the sources)."""

from __future__ import annotations

import cocotb
from cocotb.triggers import ClockCycles, RisingEdge, Timer
from cocotb.utils import get_sim_time
from cocotb_hg_bus import CLK_HZ, PERIOD_PS, RM, W, replay, setup, std_timing
from hapgate.golden import emif
from hapgate.golden.regmodel import WDOG_KEY, RegModel

WDOG_RESET_US = 10_000           # rtl/regs/hapgate.rdl WDOG_TIMEOUT.US reset
WDOG_MIN_US, WDOG_MAX_US = 100, 1_000_000   # its range_min / range_max
CFG_ERR = 1 << 13                # STATUS.CFG_ERR
WDOG = 1 << 12                   # STATUS.WDOG
FAULT_CLR = 1 << 4               # CTRL.FAULT_CLR


@cocotb.test()
async def watchdog_bounds(dut) -> None:
    master, mon, inputs = await setup(dut)
    model = RegModel(RM, inputs=inputs, input_edges=inputs.edges)
    t = std_timing()
    per_us = CLK_HZ // 1_000_000                   # the spec's CLK_HZ / 10^6 (50 MHz: 50)
    assert per_us * 1_000_000 == CLK_HZ
    assert await master.read(W["WDOG_TIMEOUT"], t) == WDOG_RESET_US
    # the range: each end accepted, one microsecond past it refused (value kept, CFG_ERR set);
    # a value with a bit above the 20-bit field is refused too
    kept = WDOG_RESET_US
    cases = [(WDOG_MIN_US - 1, False), (WDOG_MIN_US, True), (WDOG_MIN_US + 1, True),
             (WDOG_MAX_US + 1, False), (WDOG_MAX_US, True), (WDOG_MAX_US - 1, True), (0, False),
             ((1 << 20) | WDOG_MIN_US, False)]
    for value, ok in cases:
        await master.write(W["CTRL"], FAULT_CLR, t)        # clears CFG_ERR (and restarts)
        await master.write(W["WDOG_TIMEOUT"], value, t)
        kept = value if ok else kept
        got = await master.read(W["WDOG_TIMEOUT"], t)
        status = await master.read(W["STATUS"], t)
        assert got == kept, f"WDOG_TIMEOUT {value}: reads {got}, spec {kept}"
        assert bool(status & CFG_ERR) == (not ok), f"WDOG_TIMEOUT {value}: STATUS {status:#x}"
    # the expiry at the minimum: exactly 100 us = 100 * CLK_HZ / 10^6 clocks after the
    # restarting clock (not one clock before); a key one clock before the expiry restarts it,
    # a key on the expiry clock wins over it, a key one clock after comes too late
    await master.write(W["WDOG_TIMEOUT"], WDOG_MIN_US, t)
    n = WDOG_MIN_US * per_us
    want: list[int] = []

    async def commit_at(edge: int, word: int, data: int) -> None:
        fall = mon.ref_ps + (edge - emif.CAPTURE_EDGE) * PERIOD_PS - PERIOD_PS // 4
        now = int(get_sim_time(unit="ps"))
        assert fall > now + PERIOD_PS, "scheduled too late"
        await Timer(fall - now, unit="ps")
        await master.access(True, word, data, emif.Timing(0, 6 * PERIOD_PS, 0, 3 * PERIOD_PS))
        assert mon.committed[-1].edge == edge

    await master.write(W["CTRL"], FAULT_CLR, t)            # restart (and clear)
    start = mon.committed[-1].edge
    await RisingEdge(dut.wdog_expired)
    want.append(start + n)
    assert mon.edge_now() == start + n, f"expired {mon.edge_now() - start} clocks after, spec {n}"
    assert await master.read(W["STATUS"], t) & WDOG
    for d in (-1, 0, 1):
        await master.write(W["CTRL"], FAULT_CLR, t)
        start = mon.committed[-1].edge
        await commit_at(start + n + d, W["WDOG"], WDOG_KEY)
        # restarted (d <= 0): the next expiry n clocks after the key; late (d = 1): at start + n
        want.append(start + n if d > 0 else start + 2 * n + d)
        await ClockCycles(dut.clk, 2 * n + 4)
        assert bool(await master.read(W["STATUS"], t) & WDOG)
    await ClockCycles(dut.clk, 4)
    end = mon.edge_now()
    reads, errors = replay(model, master, mon)
    model.run_to(end)
    assert not errors, "\n".join(errors[:10])
    assert mon.rises["wdog_expired"] == want, (mon.rises["wdog_expired"], want)
    assert model.expiries == want, (model.expiries, want)
    dut._log.info(f"watchdog bounds: {len(cases)} range writes, expiries at {n} clocks = "
                  f"{WDOG_MIN_US} us as specified, RTL and model ({reads} reads checked)")
