"""cocotb test of the FPGA's converter pins against the converters' datasheet timing, in
simulation time (rtl/top/README.md, "Converter timing"):

- the DAC write (HG_DAC_PART: the DAC7624/7625 or the 14-bit AD7836 profile): write strobe low
  >= t_WR, data and address stable from before the strobe falls to after it rises, setup to
  the latching edge and hold;
- the ADC sample clock adc_clk (HI1175 / CXD1175A class): high and low between t_PW and t_PW
  max, one period per sample, and every pin read (the core's capture edge, or the board
  adapter's two reads per sample ADC_CAPTURE_LEAD clocks before it) at least t_OD + the IO
  budget after an edge of either polarity and the input hold before the next; an ADC model
  with the part's 2.5-clock pipeline (samples on the falling edge, output register on the
  rising edge, outputs invalid from t_H to t_OD after it) shows that every read for sample n
  (A and B) holds the conversion of ADC clock cycle n - 3.

The figures come from hapgate.golden.converters (the datasheets), never from the RTL; the
judges are plain Python there. HG_CONV_REPORT: a JSON file the measured figures are written to
before the assertions (a test reads it for a build that must fail)."""

from __future__ import annotations

import json
import os

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, First, RisingEdge, Timer
from cocotb.types import LogicArray
from hapgate.flows import regmap
from hapgate.golden import converters as cv
from hapgate.golden import emif
from hapgate.golden.dacsched import period_ps
from hapgate.golden.regmodel import WDOG_KEY
from hapgate.runners import cocotb_emif, tbutil
from hapgate.runners.cocotb_dac import now_ps

P = tbutil.params()
CLK_HZ = int(P["CLK_HZ"])  # type: ignore[arg-type]
DAC = cv.DAC_PARTS[os.environ.get("HG_DAC_PART", "dac7625")]
ADC = cv.HI1175
IO = cv.IoBudget()
LEAD = int(P.get("ADC_CAPTURE_LEAD", 0))  # type: ignore[arg-type]
CFG = tbutil.config().top()   # the paper's at this clock, with the DAC part's t_WR
assert CFG.clk_hz == CLK_HZ and CFG.dac_twr_ns == DAC.t_wr_ns
PERIOD = period_ps(CFG.comm)
W = {r.name: r.word for r in regmap.load(CLK_HZ).registers}
FRAMES = 5                      # commutation frames watched with torque on every channel
A_BASE, B_BASE = 0x10_50_64, 0x60_30_28   # mid-window amplitudes: no signal-loss fault
MOD = 16                        # the ADC model puts its cycle index mod 16 in axis 2's A word


class AdcModel:
    """The three A converters (HI1175 class) on adc_clk: sample at the falling edge, output
    register on the rising edge, 2.5 clocks of latency. After rise k the pins are invalid (X)
    from t_H to t_OD and then hold the conversion of cycle k - 3 (cycle k starts with rise k),
    whose index mod 16 is in axis 2's word. `out` is the pins' timeline (ps, code or None)."""

    def __init__(self, dut) -> None:
        self.dut = dut
        self.rises: list[int] = []
        self.falls: list[int] = []
        self.out: list[tuple[int, int | None]] = [(0, MOD - 1)]   # power-up output
        dut.adc_a.value = A_BASE | ((MOD - 1) << 16)
        dut.adc_b.value = B_BASE

    async def present(self, code: int) -> None:
        await Timer(ADC.tod_ns * cv.PS_PER_NS - ADC.th_ns * cv.PS_PER_NS, unit="ps")
        self.dut.adc_a.value = A_BASE | (code << 16)
        self.out.append((now_ps(), code))

    async def invalid(self, code: int) -> None:
        if ADC.th_ns:
            await Timer(ADC.th_ns * cv.PS_PER_NS, unit="ps")
        self.dut.adc_a.value = LogicArray("X" * 8 + f"{A_BASE & 0xFFFF:016b}")
        self.out.append((now_ps(), None))
        await self.present(code)

    async def run(self) -> None:
        cocotb.start_soon(self.watch_falls())
        while True:
            await RisingEdge(self.dut.adc_clk)
            k = len(self.rises)
            self.rises.append(now_ps())
            cocotb.start_soon(self.invalid((k - ADC.pipeline_samples) % MOD))

    async def watch_falls(self) -> None:
        while True:
            await FallingEdge(self.dut.adc_clk)
            self.falls.append(now_ps())

    def code_at(self, t: int) -> int | None:
        """What the pins show at t; None: invalid, or changing exactly at t."""
        before = [v for ts, v in self.out if ts < t]
        if any(ts == t for ts, _ in self.out):
            return None
        return before[-1] if before else None


def pin_reads(strobes: list[int]) -> list[list[int]]:
    """The instants the pins are taken, one list per read of a sample: the core's capture edge
    (one clock after the strobe rises) or, with the HX8K adapter (LEAD > 0), its B read LEAD
    clocks before that and its A read ADC_S = DIV - DIV // 2 clocks earlier still."""
    b = [s + PERIOD - LEAD * PERIOD for s in strobes]
    return [b, [t - (CFG.div - CFG.div // 2) * PERIOD for t in b]] if LEAD else [b]


def check_adc(dut, model: AdcModel, strobes: list[int], report: dict[str, object]) -> None:
    reads = pin_reads(strobes)
    caps = sorted(t for r in reads for t in r)
    v = cv.judge_adc(model.rises, model.falls, caps, CFG.div * PERIOD, ADC, IO)
    align = [p for r in reads
             for p in cv.adc_alignment_problems(model.rises, r, [model.code_at(t) for t in r],
                                                ADC, MOD)]
    report.update(adc_high_ps=v.high_ps, adc_low_ps=v.low_ps, adc_periods_ps=sorted(v.periods_ps),
                  adc_setup_ps=v.setup_ps, adc_hold_ps=v.hold_ps, adc_problems=v.problems,
                  adc_alignment=align, adc_captures=len(caps), lead=LEAD)
    dut._log.info("CLK %d Hz, ADC clock high %s low %s ps, period %s ps; %d pin reads "
                  "(lead %d): >= %.1f ns after an edge (need %d), >= %.1f ns before the next "
                  "(need %d); alignment problems %d", CLK_HZ, v.high_ps, v.low_ps,
                  sorted(v.periods_ps), len(caps), LEAD, v.setup_ps / 1000,
                  ADC.tod_ns + IO.out_in_ns, v.hold_ps / 1000, IO.in_hold_ns - ADC.th_ns,
                  len(align))


def write_report(report: dict[str, object]) -> None:
    path = os.environ.get("HG_CONV_REPORT")
    if path:
        with open(path, "w") as f:
            json.dump(report, f, indent=1)


async def reset(dut) -> None:
    cocotb.start_soon(Clock(dut.clk, PERIOD, unit="ps").start())
    dut.enc_index.value = 0
    dut.rst.value = 1
    await ClockCycles(dut.clk, 4)
    dut.rst.value = 0


async def watch_strobe(dut, strobes: list[tuple[int, int]]) -> None:
    while True:
        await RisingEdge(dut.adc_strobe)
        rise = now_ps()
        await FallingEdge(dut.adc_strobe)
        strobes.append((rise, now_ps()))


@cocotb.test()
async def adc_timing(dut):
    """The ADC clock and the captures only, 40 samples from reset."""
    model = AdcModel(dut)
    strobes: list[tuple[int, int]] = []
    cocotb.start_soon(model.run())
    cocotb.start_soon(watch_strobe(dut, strobes))
    await reset(dut)
    await ClockCycles(dut.clk, 40 * CFG.div)
    report: dict[str, object] = {"clk_hz": CLK_HZ}
    check_adc(dut, model, [r for r, _ in strobes], report)
    write_report(report)
    assert not report["adc_problems"], report["adc_problems"]
    assert not report["adc_alignment"], report["adc_alignment"]


@cocotb.test()
async def converter_timing(dut):
    """Enable all three axes with torque (so the words change from channel to channel), then
    watch FRAMES frames of DAC writes, the ADC clock and the captures: every write, every clock
    phase and every capture must meet the figures; the measured minima are logged."""
    model = AdcModel(dut)
    strobes: list[tuple[int, int]] = []   # ADC strobe (rise ps, fall ps)
    cocotb.start_soon(model.run())
    cocotb.start_soon(watch_strobe(dut, strobes))
    master = cocotb_emif.EmifMaster(dut)
    await reset(dut)
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
    first = len(strobes)
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

    cocotb.start_soon(watch_pins())
    cocotb.start_soon(watch_wr())
    await Timer(stop - now_ps(), unit="ps")

    report: dict[str, object] = {"clk_hz": CLK_HZ, "dac": DAC.name}
    check_adc(dut, model, [r for r, _ in strobes], report)
    d = cv.judge_dac([(f, r) for f, r, _ in writes], changes, DAC, PERIOD)
    report.update(dac_low_ps=d.low_ps, dac_setup_fall_ps=d.setup_fall_ps,
                  dac_setup_rise_ps=d.setup_rise_ps, dac_hold_ps=d.hold_ps,
                  dac_problems=d.problems, dac_writes=len(writes))
    write_report(report)
    dut._log.info("CLK %d Hz, %s, WR %d clocks: strobe low >= %.1f ns, setup >= %.1f ns to "
                  "the fall, >= %.1f ns to the latching edge, hold >= %.1f ns over %d writes",
                  CLK_HZ, DAC.name, CFG.comm.wr_cycles, d.low_ps / 1000, d.setup_fall_ps / 1000,
                  d.setup_rise_ps / 1000, d.hold_ps / 1000, len(writes))
    assert len(writes) >= 6 * (FRAMES - 1), f"only {len(writes)} DAC writes"
    assert len({w for _, _, w in writes}) > 3, "the words do not change: nothing to check"
    assert not d.problems, d.problems
    assert not report["adc_problems"], report["adc_problems"]
    assert not report["adc_alignment"], report["adc_alignment"]

    # the core's strobe: one clock high, one per sample period, also during the bus traffic
    watched = strobes[first:]
    high = {f - r for r, f in watched}
    periods = {b[0] - a[0] for a, b in zip(watched, watched[1:])}
    assert high == {PERIOD}, f"ADC strobe high {sorted(high)} ps != one clock {PERIOD} ps"
    assert periods == {CFG.div * PERIOD}, f"ADC strobe period {sorted(periods)} ps"
