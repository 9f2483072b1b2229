"""cocotb test of the whole FPGA (rtl/top/hapgate_top.v) against the chained golden models.

One run plays what the DSP firmware does: configure, then on every servo-tick interrupt read the
snapshot (SEQ, POS/VEL/POS_HOMED of three axes, SEQ), acknowledge, pet the watchdog and change the
torque commands; meanwhile the three encoders move (ADC samples from hapgate.golden.encsig). Along
the
way: homing, an ADC-clipping fault on axis 1 and its clear, a global disable, and finally the DSP
"stops": the watchdog expires. Checked:

- every DAC load (time to the clock edge, channel, word) equals hapgate.golden.top.simulate
(interp ->
  commutation -> output stage) fed with the same ADC samples and the register history that
  hapgate.golden.regmodel derives from the committed bus accesses; the DAC port timing (DacModel);
- every bus read equals the register model, whose interpolator inputs are the interp model's
  outputs at that clock edge (so every snapshot is the model's sample at its tick: coherent);
- explicitly: interrupt period exact; after the watchdog expiry, after the fault and after the
  global disable every channel concerned is at zero torque within one frame (+ the output stage).
"""

from __future__ import annotations

import os
import random

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, RisingEdge, Timer
from cocotb.utils import get_sim_time
from hapgate.golden import emif, encsig, interp, regmap
from hapgate.golden import top as topm
from hapgate.golden.commutation import SINE, SIX_STEP, CommutationConfig
from hapgate.golden.dacsched import DacModel
from hapgate.golden.regmodel import WDOG_KEY, AxisInputs, RegModel
from hapgate.runners import tbutil

P = tbutil.params()
CLK_HZ = int(P["CLK_HZ"])  # type: ignore[arg-type]
PERIOD_PS = 10**12 // CLK_HZ
CFG = topm.TopConfig(clk_hz=CLK_HZ, comm=CommutationConfig(
    serial_mul=bool(P.get("SERIAL_MUL", 0))))
# A board top under tb/boards/board_harness.v: its reset synchroniser releases the core
# RESET_DELAY clocks after rst (held RESET_CYCLES clocks: past a power-on reset), an ADC adapter
# that reads the converters in the period before the core's capture needs sample k + ADC_LEAD
# presented at strobe k, and the register file sits deeper in the hierarchy.
RESET_CYCLES = int(os.environ.get("HG_RESET_CYCLES", "4"))
RESET_DELAY = int(os.environ.get("HG_RESET_DELAY", "0"))
ADC_LEAD = int(os.environ.get("HG_ADC_LEAD", "0"))
BUS_SCOPE = os.environ.get("HG_BUS_SCOPE", "u_bus")
RM = regmap.load(CLK_HZ)
W = {r.name: r.word for r in RM.registers}
N_SAMPLES = int(os.environ.get("HG_SAMPLES", "2000"))
TICK_HZ = 10_000
WDOG_US = 150


def stimulus(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ADC codes (n, 3) for three moving encoders, with a clipping burst on axis 1."""
    spec = encsig.with_spec(encsig.PAPER_LIKE, amplitude=110.0)
    lines = [encsig.constant(150.0, n, start=1010.0),        # index edge after ~90 us
             encsig.constant(-100.0, n, start=14.6),         # index edge after ~140 us
             encsig.reversals(40.0, 800.0, n, start=500.3)]
    a = np.zeros((n, 3), dtype=np.int64)
    b = np.zeros((n, 3), dtype=np.int64)
    idx = np.zeros((n, 3), dtype=np.int64)
    for i, x in enumerate(lines):
        qa, qb = encsig.adc_codes(x, encsig.with_spec(spec, seed=11 + i))
        a[:, i], b[:, i] = qa, qb
        idx[:, i] = encsig.index_bit(x)
    s = int(0.35 * n)
    a[s:s + 3, 1] = 127                                      # ADC clipping: axis 1 fault
    return a, b, idx


async def drive_adc(dut, a: np.ndarray, b: np.ndarray, idx: np.ndarray) -> None:
    """Present sample k while adc_strobe is high (captured at the end of that cycle); with an
    ADC adapter, sample k + ADC_LEAD (from the start: sample 0)."""
    n = a.shape[0]

    def put(k: int) -> None:
        dut.adc_a.value = sum((int(a[k, i]) & 0xFF) << (8 * i) for i in range(3))
        dut.adc_b.value = sum((int(b[k, i]) & 0xFF) << (8 * i) for i in range(3))
        dut.enc_index.value = sum(int(idx[k, i]) << i for i in range(3))

    if ADC_LEAD:
        put(0)
    for k in range(ADC_LEAD, n):
        await RisingEdge(dut.adc_strobe)
        put(k)


def controls(model: RegModel) -> topm.Controls:
    s = model.stored

    def s16(v: int) -> int:
        return v - (1 << 16) if v & 0x8000 else v

    ax = [f"AXIS[{i}]." for i in range(3)]
    return topm.Controls(
        global_en=s["CTRL"] & 1, axis_en=tuple((s["CTRL"] >> (1 + i)) & 1 for i in range(3)),
        torque=tuple(s16(s[a + "TORQUE"] & 0xFFFF) for a in ax),
        offset=tuple(s[a + "OFFSET"] & 0x3FF for a in ax),
        mode=tuple(s[a + "MODE"] & 3 for a in ax),
        tq_limit=tuple(s[a + "TQ_LIMIT"] & 0xFFFF for a in ax),
        wdog_expired=int(model.wd_expired))


@cocotb.test()
async def firmware_like_run(dut) -> None:
    rng = random.Random(5)
    a, b, idx = stimulus(N_SAMPLES + 400)   # margin: the last servo loop may run past N
    # (the models run after the simulation: homing and fault-clear pulses come from the bus)
    cocotb.start_soon(Clock(dut.clk, PERIOD_PS, unit="ps").start())
    master = emif.EmifMaster(dut)
    dac = DacModel(dut, CFG.comm)
    dut.adc_a.value = 0
    dut.adc_b.value = 0
    dut.enc_index.value = 0
    dut.rst.value = 1
    dac.start()
    await ClockCycles(dut.clk, RESET_CYCLES)
    ref = int(get_sim_time(unit="ps")) + RESET_DELAY * PERIOD_PS
    dac.reset_ps = ref
    dut.rst.value = 0
    scope = dut
    for part in BUS_SCOPE.split("."):
        scope = getattr(scope, part)
    mon = emif.Monitor(dut, PERIOD_PS, ref, scope=scope)
    mon.start("tick", "wdog_expired")
    cocotb.start_soon(drive_adc(dut, a, b, idx))
    end_ps = ref + (N_SAMPLES * CFG.div - 200) * PERIOD_PS

    irq_rises: list[int] = []

    async def watch_irq() -> None:
        while True:
            await RisingEdge(dut.irq)
            irq_rises.append(mon.edge_now())

    cocotb.start_soon(watch_irq())
    await ClockCycles(dut.clk, 3 * CFG.div)      # the first samples are through
    await Timer(PERIOD_PS // 3, unit="ps")
    t = emif.Timing(setup=PERIOD_PS, strobe=emif.MIN_STROBE_CLOCKS * PERIOD_PS, hold=0,
                    idle=emif.MIN_RECOVERY_CLOCKS * PERIOD_PS)

    async def wr(name: str, v: int) -> None:
        await master.write(W[name], v & 0xFFFFFFFF, emif.random_timing(rng, PERIOD_PS)
                           if rng.random() < 0.5 else t)

    async def rd(name: str) -> int:
        return await master.read(W[name], emif.random_timing(rng, PERIOD_PS)
                                 if rng.random() < 0.5 else t)

    assert await rd("ID") >> 16 == 0x4847
    await wr("WDOG_TIMEOUT", WDOG_US)
    await wr("TICK_DIV", CLK_HZ // TICK_HZ)
    for i, (mode, lim, off) in enumerate(((SINE, 30000, 100), (SIX_STEP, 65535, 0),
                                          (SINE, 20000, 900))):
        await wr(f"AXIS[{i}].TQ_LIMIT", lim)
        await wr(f"AXIS[{i}].OFFSET", off)
        await wr(f"AXIS[{i}].MODE", mode)
        await wr(f"AXIS[{i}].TORQUE", rng.randint(-32768, 32767))
    await wr("CTRL", 1 << 4)                          # clear faults (and restart the watchdog)
    await wr("WDOG", WDOG_KEY)
    await wr("CTRL", 0b1111 | 0b011 << 5)             # enable all; arm homing of axes 0 and 1
    ctrl = 0b1111
    stop_petting = int(0.62 * N_SAMPLES) * CFG.div
    disable_at = int(0.22 * N_SAMPLES) * CFG.div
    clear_at = int(0.45 * N_SAMPLES) * CFG.div
    disabled = cleared = False
    while int(get_sim_time(unit="ps")) < end_ps - 40 * CFG.div * PERIOD_PS:
        await RisingEdge(dut.irq)
        await Timer(rng.randint(1, 40) * PERIOD_PS // 3, unit="ps")
        seq0 = await rd("SEQ")
        for i in range(3):
            for w in ("POS", "VEL", "POS_HOMED"):
                await rd(f"AXIS[{i}].{w}")
        seq1 = await rd("SEQ")
        assert seq0 == seq1, "a snapshot changed during the read sequence at 10 kHz"
        await rd("STATUS")
        await wr("IRQ", 1)
        now = (int(get_sim_time(unit="ps")) - ref) // PERIOD_PS
        if now < stop_petting:
            await wr("WDOG", WDOG_KEY)
        if rng.random() < 0.7:
            i = rng.randrange(3)
            await wr(f"AXIS[{i}].TORQUE", rng.choice((rng.randint(-32768, 32767), 32767,
                                                       -32768, 0)))
        if rng.random() < 0.15:
            await wr("AXIS[2].MODE", rng.choice((SINE, SIX_STEP, 2)))
        if not disabled and now > disable_at:
            disabled = True
            await wr("CTRL", ctrl & ~1)              # global disable (axes still enabled)
        elif disabled and ctrl and now > disable_at and not cleared:
            await wr("CTRL", ctrl)
        if not cleared and now > clear_at:
            cleared = True
            await wr("CTRL", ctrl | 1 << 4)           # clear axis 1's clipping fault
    if end_ps > int(get_sim_time(unit="ps")):
        await Timer(end_ps - int(get_sim_time(unit="ps")), unit="ps")
    end_edge = (int(get_sim_time(unit="ps")) - ref) // PERIOD_PS

    # ---------------------------------------------------------------- replay through the models
    arm: list[list[int]] = [[], [], []]
    clr: list[int] = []
    # pulses: from the committed CTRL writes (the register model decodes them from the RDL)
    probe = RegModel(RM)
    for c in mon.committed:
        probe.access(c.word, c.we, c.wdata, c.edge)
    for e, name, _bits in probe.pulses:
        if name.startswith("CTRL.HOME_ARM"):
            arm[int(name[-1])].append(e)
        elif name == "CTRL.FAULT_CLR":
            clr.append(e)
    axes = [interp.run(a[:, i], b[:, i], idx[:, i], CFG.interp,
                       clear_at=topm.pulse_samples(clr, CFG),
                       arm_at=topm.pulse_samples(arm[i], CFG)) for i in range(3)]

    def inputs(edge: int) -> list[AxisInputs]:
        s = (edge - topm.LATENCY - 1) // CFG.div - 1
        if s < 0:
            return [AxisInputs() for _ in range(3)]
        return [AxisInputs(pos=int(x.pos[s]), pos_homed=int(x.pos_homed[s]), vel=int(x.vel[s]),
                           index_pos=int(x.index_pos[s]), index_count=int(x.index_count[s]),
                           overspeed_count=int(x.overspeed_count[s]), homed=int(x.homed[s]),
                           faults=int(x.faults[s])) for x in axes]

    changes = [k * CFG.div + topm.LATENCY + 1 for k in range(1, a.shape[0] + 1)]
    model = RegModel(RM, inputs=inputs, input_edges=changes)
    timeline = topm.Timeline()
    errors: list[str] = []
    assert len(mon.committed) == len(master.log)
    n_exp = 0
    for acc, c in zip(master.log, mon.committed):
        assert (acc.we, acc.word) == (c.we, c.word)
        model.run_to(c.edge - 1)
        for x in model.expiries[n_exp:]:
            timeline.set(x, topm.Controls(**{**vars(controls(model)), "wdog_expired": 1}))
        n_exp = len(model.expiries)
        exp = model.access(c.word, c.we, c.wdata, c.edge)
        if not acc.we and exp != acc.rdata:
            errors.append(f"read 0x{c.word:02x} at edge {c.edge}: 0x{acc.rdata:08x}, "
                          f"model 0x{exp:08x}")
        timeline.set(c.edge, controls(model))
    model.run_to(end_edge)
    for x in model.expiries[n_exp:]:
        timeline.set(x, topm.Controls(**{**vars(controls(model)), "wdog_expired": 1}))
    assert not errors, f"{len(errors)} reads differ:\n" + "\n".join(errors[:15])
    assert mon.rises["tick"] == [e for e in model.ticks if e <= end_edge]
    assert mon.rises["wdog_expired"] == model.expiries, (mon.rises["wdog_expired"],
                                                         model.expiries)
    assert len(model.expiries) == 1, "the watchdog must expire once the DSP stops"

    frames = (end_edge - 20) // CFG.comm.frame_clocks - 1
    want = topm.simulate(a, b, idx, timeline, CFG, frames, arm_edges=arm, clear_edges=clr)
    got_t = np.array([(ld.t_ps - ref) for ld in dac.loads], dtype=np.int64)
    assert np.all(got_t % PERIOD_PS == 0)
    got_e = got_t // PERIOD_PS
    keep = got_e <= want.load_edge[-1]
    got_e, got_a = got_e[keep], np.array([ld.addr for ld in dac.loads])[keep]
    got_w = np.array([ld.word for ld in dac.loads])[keep]
    assert not dac.violations, dac.violations[:5]
    assert got_e.size == want.load_edge.size, f"{got_e.size} loads, model {want.load_edge.size}"
    assert np.array_equal(got_e, want.load_edge), "load times differ from the model"
    assert np.array_equal(got_a, want.addr), "channel order differs"
    bad = np.flatnonzero(got_w != want.word)
    assert bad.size == 0, (f"{bad.size} of {got_w.size} DAC words differ; first at load "
                           f"{bad[0]}: {got_w[bad[0]]} vs model {want.word[bad[0]]}")
    nonzero = np.count_nonzero(got_w != CFG.zero_word)
    assert nonzero > got_w.size // 4, "the run must actually drive the motors"

    # ---------------------------------------------------------------- explicit safety checks
    f_clk = CFG.comm.frame_clocks
    bound = f_clk + CFG.comm.wr_cycles + 1
    zero = CFG.zero_word

    def zero_after(edge: int, channels: range, what: str) -> int:
        """Every load of `channels` presented after `edge` is zero; return the latency to the
        last channel's first zero load."""
        worst = 0
        for ch in channels:
            sel = (got_a == ch) & (got_e - CFG.comm.wr_cycles - 1 > edge)
            first = int(got_e[sel][0])
            worst = max(worst, first - edge)
        return worst

    x = model.expiries[0]
    after = (got_e - CFG.comm.wr_cycles - 1) > x
    assert np.all(got_w[after] == zero), "a non-zero DAC load after the watchdog expired"
    lat_wd = zero_after(x, range(6), "watchdog")
    assert lat_wd <= bound, f"watchdog: {lat_wd} clocks to zero on all channels > {bound}"
    # the axis-1 fault: visible from the edge after its sample's results
    s_fault = int(np.argmax(axes[1].faults != 0))
    s_clear = int(np.argmax((np.arange(axes[1].faults.size) > s_fault) & (axes[1].faults == 0)))
    e_fault = (s_fault + 1) * CFG.div + topm.LATENCY
    e_clear = (s_clear + 1) * CFG.div + topm.LATENCY
    during = ((got_e - CFG.comm.wr_cycles - 1) > e_fault) & (got_e - 3 <= e_clear) & \
        ((got_a == 2) | (got_a == 3))
    assert np.all(got_w[during] == zero), "motor 1 not at zero torque during its fault"
    lat_fault = zero_after(e_fault, range(2, 4), "fault")
    assert lat_fault <= bound
    # the global disable
    dis = [c.edge for c in mon.committed if c.we and c.word == W["CTRL"] and c.wdata & 1 == 0]
    lat_dis = zero_after(dis[0], range(6), "disable")
    assert lat_dis <= bound
    # interrupt period
    periods = set(np.diff(irq_rises).tolist())
    assert periods <= {CLK_HZ // TICK_HZ, 2 * CLK_HZ // TICK_HZ} and CLK_HZ // TICK_HZ in periods, \
        f"irq periods {periods} clocks"
    reads = sum(1 for acc in master.log if not acc.we)
    if hasattr(dut, "gl_checked"):  # tb/boards/board_gl_harness.v: the netlist beside the RTL
        assert int(dut.gl_checked.value) >= end_edge, "the netlist comparison did not run"
    dut._log.info(
        f"top: {N_SAMPLES} samples, {got_w.size} DAC loads bit-exact ({nonzero} non-zero), "
        f"{reads} reads checked, {len(model.ticks)} ticks; zero torque after: watchdog "
        f"{lat_wd} clocks ({lat_wd * PERIOD_PS / 1e6:.2f} us), fault {lat_fault}, disable "
        f"{lat_dis} (frame {f_clk}); irq period {CLK_HZ // TICK_HZ} clocks")
