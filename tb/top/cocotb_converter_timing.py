"""cocotb test of the FPGA's converter pins against the converters' datasheet timing, in
simulation time (rtl/top/README.md, "Converter timing"): the DAC write (DAC7624/7625 class:
write strobe low >= t_WCS, data and address stable from before the strobe falls to after it
rises) and the ADC sample strobe (one clock high, one strobe per sample period). The figures
come from hapgate.golden.top (DAC_TWR_NS) and the test's own constants, never from the RTL."""

from __future__ import annotations

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, First, RisingEdge, Timer
from hapgate.golden import emif, regmap
from hapgate.golden import top as topm
from hapgate.golden.dacsched import now_ps, period_ps
from hapgate.golden.regmodel import WDOG_KEY
from hapgate.runners import tbutil

P = tbutil.params()
CLK_HZ = int(P["CLK_HZ"])  # type: ignore[arg-type]
CFG = topm.TopConfig(clk_hz=CLK_HZ)
PERIOD = period_ps(CFG.comm)
W = {r.name: r.word for r in regmap.load(CLK_HZ).registers}
FRAMES = 5                      # commutation frames watched with torque on every channel
# DAC7624/7625 Table II (rtl/top/README.md): t_WCS CS low for write >= 50 ns; t_DS data valid
# to CS low, t_AS address valid to CS low, t_DH / t_AH valid after CS high: >= 0 ns
T_WCS_PS = topm.DAC_TWR_NS * 1000
T_DS_PS = T_AS_PS = T_DH_PS = T_AH_PS = 0


@cocotb.test()
async def converter_timing(dut):
    """Enable all three axes with torque (so the words change from channel to channel), then
    watch FRAMES frames of DAC writes and the ADC strobe: every write and every strobe must
    meet the figures; the measured minima are logged."""
    cocotb.start_soon(Clock(dut.clk, PERIOD, unit="ps").start())
    dut.adc_a.value = 0x10_50_64     # constant mid-window amplitudes: no signal-loss fault
    dut.adc_b.value = 0x60_30_28
    dut.enc_index.value = 0
    dut.rst.value = 1
    master = emif.EmifMaster(dut)
    await ClockCycles(dut.clk, 4)
    dut.rst.value = 0
    await ClockCycles(dut.clk, 3 * CFG.div)
    await Timer(PERIOD // 3, unit="ps")
    t = emif.Timing(setup=PERIOD, strobe=emif.MIN_STROBE_CLOCKS * PERIOD, hold=0,
                    idle=emif.MIN_RECOVERY_CLOCKS * PERIOD)
    for i, tq in enumerate((12000, -20000, 30000)):
        await master.write(W[f"AXIS[{i}].TQ_LIMIT"], 65535, t)
        await master.write(W[f"AXIS[{i}].OFFSET"], 300 * i, t)
        await master.write(W[f"AXIS[{i}].MODE"], 0, t)           # SINE
        await master.write(W[f"AXIS[{i}].TORQUE"], tq & 0xFFFF, t)
    await master.write(W["CTRL"], 1 << 4, t)                     # clear faults
    await master.write(W["WDOG"], WDOG_KEY, t)
    await master.write(W["CTRL"], 0b1111, t)                     # enable all
    await ClockCycles(dut.clk, CFG.comm.frame_clocks + 8)        # the first frame with torque

    writes: list[tuple[int, int, int]] = []   # (fall ps, rise ps, word)
    changes: list[int] = []                   # data or address changes, ps
    strobes: list[tuple[int, int]] = []       # ADC strobe (rise ps, fall ps)
    stop = now_ps() + FRAMES * CFG.comm.frame_ns * 1000

    async def watch_pins() -> None:
        while True:
            await First(dut.dac_data.value_change, dut.dac_addr.value_change)
            changes.append(now_ps())

    async def watch_wr() -> None:
        while True:
            await FallingEdge(dut.dac_wr_n)
            fall = now_ps()
            await RisingEdge(dut.dac_wr_n)
            writes.append((fall, now_ps(), int(dut.dac_data.value)))

    async def watch_strobe() -> None:
        while True:
            await RisingEdge(dut.adc_strobe)
            rise = now_ps()
            await FallingEdge(dut.adc_strobe)
            strobes.append((rise, now_ps()))

    cocotb.start_soon(watch_pins())
    cocotb.start_soon(watch_wr())
    cocotb.start_soon(watch_strobe())
    await Timer(stop - now_ps(), unit="ps")

    assert len(writes) >= 6 * (FRAMES - 1), f"only {len(writes)} DAC writes"
    assert len({w for _, _, w in writes}) > 3, "the words do not change: nothing to check"
    low = min(r - f for f, r, _ in writes)
    setup = min(f - max((c for c in changes if c <= f), default=-10**15) for f, _, _ in writes)
    hold = min(min((c for c in changes if c >= r), default=10**15) - r for _, r, _ in writes)
    inside = [c for c in changes for f, r, _ in writes if f < c < r]
    dut._log.info("CLK %d Hz, WR %d clocks: strobe low >= %.1f ns, data/address setup >= %.1f "
                  "ns, hold >= %.1f ns over %d writes", CLK_HZ, CFG.comm.wr_cycles, low / 1000,
                  setup / 1000, hold / 1000, len(writes))
    assert low >= T_WCS_PS, f"DAC strobe low {low} ps < t_WCS {T_WCS_PS} ps"
    assert not inside, f"data/address changed while the strobe was low at {inside[:3]} ps"
    assert setup >= max(T_DS_PS, T_AS_PS, PERIOD), f"data/address setup {setup} ps"
    assert hold >= max(T_DH_PS, T_AH_PS, PERIOD), f"data/address hold {hold} ps"

    # ADC strobe: the converters' sample clock; one clock high, one rise per sample period
    high = {f - r for r, f in strobes}
    periods = {b[0] - a[0] for a, b in zip(strobes, strobes[1:])}
    dut._log.info("ADC strobe high %s ps, period %s ps over %d samples", sorted(high),
                  sorted(periods), len(strobes))
    assert high == {PERIOD}, f"ADC strobe high {sorted(high)} ps != one clock {PERIOD} ps"
    assert periods == {CFG.div * PERIOD}, f"ADC strobe period {sorted(periods)} ps"
