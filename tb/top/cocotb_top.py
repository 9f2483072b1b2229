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
from hapgate.flows import regmap
from hapgate.golden import commutation, configs, emif, encsig, interp, velobs
from hapgate.golden import top as topm
from hapgate.golden.commutation import SINE, SIX_STEP
from hapgate.golden.regmodel import WDOG_KEY, AxisInputs, RegModel
from hapgate.runners import cocotb_emif, funcov, tbutil
from hapgate.runners.cocotb_dac import DacModel

P = tbutil.params()
CLK_HZ = int(P["CLK_HZ"])  # type: ignore[arg-type]
PERIOD_PS = 10**12 // CLK_HZ
CFG = tbutil.config().top()   # the named configuration (or sweep point) the DUT was built with
SEC = sum(int(tbutil.config().rtl_params().get(n, 0)) << i      # the integrity checks built
          for i, n in enumerate(configs.SEC_PARAMS))            # (HW_FAULT.BUILT)
assert CFG.clk_hz == CLK_HZ, (CFG.clk_hz, CLK_HZ)
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
    # the fault becomes visible just after a frame start: the worst case for the commutator
    # alone (motor 1's loads of that frame are still to come; only the output stage can zero
    # them within one frame)
    while ((s + 1) * CFG.div + CFG.interp.latency) % CFG.comm.frame_clocks > CFG.comm.skew_clocks:
        s += 1
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
    master = cocotb_emif.EmifMaster(dut)
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
    mon = cocotb_emif.Monitor(dut, PERIOD_PS, ref, scope=scope)
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
            v = rng.choice((rng.randint(-32768, 32767), 32767, -32768, 0))
            # axis 1 always drives (its fault must have something to zero)
            await wr(f"AXIS[{i}].TORQUE", v if i != 1 or v else 20000)
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

    # VEL: the window FIR, or the tracking observer where it is selected from reset (its reset
    # bandwidth and type: VEL_CTRL's reset value, the observer model's defaults)
    vels = [velobs.run_interp(x) if CFG.vel_obs_sel else x.vel for x in axes]

    def inputs(edge: int) -> list[AxisInputs]:
        s = (edge - CFG.interp.latency - 1) // CFG.div - 1
        if s < 0:
            return [AxisInputs() for _ in range(3)]
        return [AxisInputs(pos=int(x.pos[s]), pos_homed=int(x.pos_homed[s]), vel=int(v[s]),
                           index_pos=int(x.index_pos[s]), index_count=int(x.index_count[s]),
                           overspeed_count=int(x.overspeed_count[s]), homed=int(x.homed[s]),
                           faults=int(x.faults[s])) for x, v in zip(axes, vels)]

    changes = [k * CFG.div + CFG.interp.latency + 1 for k in range(1, a.shape[0] + 1)]
    model = RegModel(RM, inputs=inputs, input_edges=changes, sec=SEC)
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
    e_fault = (s_fault + 1) * CFG.div + CFG.interp.latency
    e_clear = (s_clear + 1) * CFG.div + CFG.interp.latency
    during = ((got_e - CFG.comm.wr_cycles - 1) > e_fault) & (got_e - 3 <= e_clear) & \
        ((got_a == 2) | (got_a == 3))
    assert np.all(got_w[during] == zero), "motor 1 not at zero torque during its fault"
    # not vacuous: the commutator's own words for motor 1 in the frame latched just before the
    # fault became visible (loads presented after it) are non-zero: only the output stage can
    # zero them within the bound
    f0 = e_fault // CFG.comm.frame_clocks
    assert np.any(want.codes[f0, 2:4] != 0), (f0, want.codes[f0])
    assert ((got_e - CFG.comm.wr_cycles - 1 > e_fault) &
            (got_e < (f0 + 1) * CFG.comm.frame_clocks) & (got_a == 2)).any()
    lat_fault = zero_after(e_fault, range(2, 4), "fault")
    assert lat_fault <= bound
    # the global disable
    dis = [c.edge for c in mon.committed if c.we and c.word == W["CTRL"] and c.wdata & 1 == 0]
    lat_dis = zero_after(dis[0], range(6), "disable")
    assert lat_dis <= bound
    if funcov.active():   # the three causes whose zero torque was just checked
        funcov.sample_top(["watchdog", "clip", "disable"])
        funcov.flush()
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


# ------------------------------------------------------------------------------------------------
# Truth: the DAC outputs against the float electrical angle of the homed shaft

TRUTH_REV_S = 230.0        # fast enough to reach the index from anywhere within the run
TRUTH_AMP = 120.0          # ideal signals below full scale (no clipping fault)
POLE_PAIRS = 2             # docs/design/SPEC.md: four-pole motors


def truth_stimulus(seed: int, n: int) -> tuple[np.ndarray, ...]:
    """Three shafts powered up at random positions over the whole revolution, turning at
    +-TRUTH_REV_S (random direction): (lines (n, 3) of the true shaft, a, b, index)."""
    rng = np.random.default_rng(seed)
    start = rng.uniform(0.0, encsig.LINES, 3)
    sign = rng.choice([-1.0, 1.0], 3)
    x = np.stack([encsig.constant(s * TRUTH_REV_S, n, start=float(p))
                  for s, p in zip(sign, start)], 1)
    spec = encsig.with_spec(encsig.IDEAL, amplitude=TRUTH_AMP)
    a = np.zeros((n, 3), dtype=np.int64)
    b = np.zeros((n, 3), dtype=np.int64)
    idx = np.zeros((n, 3), dtype=np.int64)
    for i in range(3):
        qa, qb = encsig.adc_codes(x[:, i], spec)
        a[:, i], b[:, i] = qa, qb
        idx[:, i] = encsig.index_bit(x[:, i])
    return x, a, b, idx


@cocotb.test()
async def homed_truth(dut) -> None:
    """Power up at random shaft positions, arm homing, drive SINE with fixed torques and offsets,
    and check every DAC load of a homed axis against the float truth of the homed shaft
    (hapgate.golden.commutation.truth at the true position relative to the index). Commutating
    from the raw position (relative to power-up) is off by a random angle and fails."""
    seed = int(os.environ.get("HG_SEED", "1"))
    rng = np.random.default_rng(1000 + seed)
    n = N_SAMPLES
    x, a, b, idx = truth_stimulus(seed, n + 50)
    master, dac, t = await tbutil.start_top_dac(dut, PERIOD_PS, CFG.comm)
    ref = dac.reset_ps
    cocotb.start_soon(drive_adc(dut, a, b, idx))
    torque = [int(v) for v in rng.integers(8000, 32768, 3) * rng.choice([-1, 1], 3)]
    offset = [int(v) for v in rng.integers(0, 1024, 3)]
    await master.write(W["WDOG_TIMEOUT"], 1_000_000, t)
    await master.write(W["WDOG"], WDOG_KEY, t)
    for i in range(3):
        await master.write(W[f"AXIS[{i}].TQ_LIMIT"], 65535, t)
        await master.write(W[f"AXIS[{i}].OFFSET"], offset[i], t)
        await master.write(W[f"AXIS[{i}].MODE"], SINE, t)
        await master.write(W[f"AXIS[{i}].TORQUE"], torque[i] & 0xFFFF, t)
    await master.write(W["CTRL"], 0b1111 | 0b111 << 5, t)     # drive on; arm homing of all axes
    armed_edge = (int(get_sim_time(unit="ps")) - ref) // PERIOD_PS
    await Timer(n * CFG.div * PERIOD_PS, unit="ps")
    status = await master.read(W["STATUS"], t)
    assert (status >> 8) & 7 == 7, f"not every axis homed (STATUS 0x{status:08x})"
    assert status & 7 == 0, f"an axis fault (STATUS 0x{status:08x})"
    assert not dac.violations, dac.violations[:5]

    edge = np.array([(ld.t_ps - ref) // PERIOD_PS for ld in dac.loads], dtype=np.int64)
    ch = np.array([ld.addr for ld in dac.loads], dtype=np.int64)
    code = commutation.decode(np.array([ld.word for ld in dac.loads], dtype=np.int64), CFG.comm)
    # the frame each load belongs to (its inputs latched at frame * FRAME_CLOCKS), and the true
    # shaft at that latch: the freshest sample the commutator can have is the one captured
    # before it, so the truth is taken at the latch time and the budget covers up to
    # DIV + LATENCY + 1 clocks of shaft motion before it
    frame = (edge - CFG.comm.load_clocks - 1 - ch * CFG.comm.skew_clocks) // CFG.comm.frame_clocks
    latch_t = frame * CFG.comm.frame_clocks / CLK_HZ                       # s after reset
    samp = latch_t * CFG.sample_hz - 1.0                                   # sample index (float)
    mot = np.arange(3)[ch // 2]
    xl = np.stack([np.interp(samp, np.arange(x.shape[0]), x[:, i]) for i in range(3)], 1)
    x_now = xl[np.arange(ch.size), mot]
    # homed only after the index edge (truth) has reached the registers: from the edge of the
    # first index rise + the interpolator latency + one frame
    rise = [int(np.argmax(idx[1:, i] > idx[:-1, i])) + 1 for i in range(3)]
    homed_from = np.array([(r + 2) * CFG.div + CFG.interp.latency + CFG.comm.frame_clocks
                           for r in rise])
    check = (frame * CFG.comm.frame_clocks > np.maximum(homed_from[mot], armed_edge + 1)) & \
        (frame >= 1)
    per_motor = np.bincount(mot[check], minlength=3)
    assert per_motor.min() >= 40, f"too few homed loads to check per motor: {per_motor}"
    counts = 2**20                                                          # per revolution
    homed_counts = np.mod(x_now * 1024, counts)       # 1024 counts per line; index = line 0
    tq = np.array(torque, dtype=np.float64)[mot]
    # the float truth, written from the spec (docs/design/SPEC.md: 2 pole pairs, a 1024-code
    # electrical cycle, +-8191 at full torque 32767, b 120 deg after a), not from the
    # configuration under test
    theta = 2 * np.pi * (POLE_PAIRS * homed_counts / 2**20 + np.array(offset)[mot] / 1024)
    want = 8191 * tq / 32767 * np.sin(theta - (ch % 2) * 2 * np.pi / 3)
    # budget, in electrical angle: 1/2 ROM code (a code stands for the middle of its bin), the
    # 1/3 code by which b falls short of 120deg, the interpolator (ideal signals: < 1 count of
    # 1024 per line = 2/1024 of a code; plain quadrature's 256-count steps fall on the
    # commutation's 512-count codes, so they add nothing), and the shaft motion over one sample
    # + the interpolator's latency + 1 clocks before the latch; plus 1/2 LSB of rounding and 1/2
    # LSB of the ROM's own rounding
    v_counts_s = TRUTH_REV_S * counts
    motion = v_counts_s * (1.0 / CFG.sample_hz + (CFG.interp.latency + 1) / CLK_HZ)
    codes_per_count = POLE_PAIRS * 1024 / counts
    ang = 2 * np.pi / 1024 * (0.5 + np.where(ch % 2, 1 / 3, 0) + 2 / 1024
                              + motion * codes_per_count)
    budget = 8191 * np.abs(tq) / 32767 * ang + 1.0
    err = np.abs(code - want)
    worst = int(np.argmax(np.where(check, err / budget, 0)))
    dut._log.info(
        f"homed truth, seed {seed}: power-up lines {x[0].round(1).tolist()}, "
        f"{int(check.sum())} loads checked, max |err| {err[check].max():.1f} LSB, RMS "
        f"{np.sqrt(np.mean(err[check] ** 2)):.2f} LSB, worst "
        f"err/budget {err[worst] / budget[worst]:.3f} (channel {ch[worst]}, frame {frame[worst]})")
    assert np.all(err[check] <= budget[check]), (
        f"load {worst} (channel {ch[worst]}, frame {frame[worst]}): code {code[worst]}, "
        f"truth {want[worst]:.1f}, |err| {err[worst]:.1f} > budget {budget[worst]:.1f} LSB")

