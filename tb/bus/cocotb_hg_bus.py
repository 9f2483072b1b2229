"""cocotb tests of rtl/bus/hg_bus.v (EMIF-like slave + register file) against the register model
(hapgate.golden.regmodel, built on the RDL via hapgate.flows.regmap). The interpolator outputs
are driven by
the testbench. Every check compares with the model or with simulation time, never with values
read back from the design's own code.
"""

from __future__ import annotations

import bisect
import os
import random

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, RisingEdge, Timer
from cocotb.utils import get_sim_time
from hapgate.flows import regmap
from hapgate.golden import emif
from hapgate.golden.regmodel import WDOG_KEY, AxisInputs, RegModel
from hapgate.runners import cocotb_emif, funcov, tbutil

P = tbutil.params()
CLK_HZ = int(P["CLK_HZ"])  # type: ignore[arg-type]
PERIOD_PS = 10**12 // CLK_HZ
RM = regmap.load(CLK_HZ)
W = {r.name: r.word for r in RM.registers}
N_ACCESSES = int(os.environ.get("HG_ACCESSES", "2000"))
SEED = int(os.environ.get("HG_SEED", "1"))


class Inputs:
    """The interpolator outputs the testbench drives, with the edge from which each set holds."""

    def __init__(self, dut) -> None:
        self.dut = dut
        self.edges: list[int] = [-(10**9)]
        self.values: list[list[AxisInputs]] = [[AxisInputs() for _ in range(3)]]
        self.drive(self.values[0])

    def __call__(self, edge: int) -> list[AxisInputs]:
        return self.values[bisect.bisect_right(self.edges, edge) - 1]

    def drive(self, axes: list[AxisInputs]) -> None:
        d = self.dut

        def pack(name: str, width: int) -> int:
            return sum((getattr(a, name) & ((1 << width) - 1)) << (width * i)
                       for i, a in enumerate(axes))

        d.in_pos.value = pack("pos", 32)
        d.in_pos_homed.value = pack("pos_homed", 32)
        d.in_vel.value = pack("vel", 32)
        d.in_vel_obs.value = pack("vel_obs", 32)   # (VEL_OBS = 0 here: VEL must stay the FIR's)
        d.in_index_pos.value = pack("index_pos", 32)
        d.in_index_count.value = pack("index_count", 16)
        d.in_overspeed_count.value = pack("overspeed_count", 16)
        d.in_homed.value = pack("homed", 1)
        d.in_faults.value = pack("faults", 3)
        d.in_fault.value = sum(a.fault << i for i, a in enumerate(axes))

        def pack2(lo: str, hi: str, lo_w: int, hi_lsb: int) -> int:
            return sum((((getattr(a, lo) & ((1 << lo_w) - 1))
                         | ((getattr(a, hi) & 0xFFFF) << hi_lsb)) << (32 * i))
                       for i, a in enumerate(axes))

        d.in_cal_ofs.value = pack2("cal_ofs_a", "cal_ofs_b", 16, 16)
        d.in_cal_gain.value = pack2("cal_gain_a", "cal_gain_b", 16, 16)
        d.in_cal_stat.value = pack2("cal_gear", "cal_updates", 8, 16)
        d.in_cal_phase.value = pack("cal_phase", 16)
        d.in_cap.value = 0        # (no capture buffer here: CAP_* read 0, as the model's)

    def set(self, axes: list[AxisInputs], edge: int) -> None:
        """Drive now (between edges); the hardware sees it from `edge` on."""
        self.drive(axes)
        self.edges.append(edge)
        self.values.append(axes)


def random_axes(rng: random.Random) -> list[AxisInputs]:
    def s32() -> int:
        return rng.randint(-(2**31), 2**31 - 1)

    return [AxisInputs(pos=s32(), pos_homed=s32(), vel=rng.randint(-(2**18), 2**18 - 1),
                       index_pos=s32(), index_count=rng.getrandbits(16) * rng.randint(0, 1),
                       overspeed_count=rng.getrandbits(16), homed=rng.randint(0, 1),
                       faults=rng.choice((0, 0, 0, 1, 2, 4, 7)),
                       cal_ofs_a=rng.randint(-512, 511), cal_ofs_b=rng.randint(-512, 511),
                       cal_gain_a=rng.randint(8192, 32767), cal_gain_b=rng.randint(8192, 32767),
                       cal_phase=rng.randint(-2048, 2047), cal_gear=rng.getrandbits(8),
                       cal_updates=rng.getrandbits(16),
                       vel_obs=rng.randint(-(2**17), 2**17 - 1)) for _ in range(3)]


async def setup(dut, watch: tuple[str, ...] = ("tick", "wdog_expired")
                ) -> tuple[cocotb_emif.EmifMaster, cocotb_emif.Monitor, Inputs]:
    cocotb.start_soon(Clock(dut.clk, PERIOD_PS, unit="ps").start())
    master = cocotb_emif.EmifMaster(dut)
    inputs = Inputs(dut)
    dut.rst.value = 1
    await ClockCycles(dut.clk, 4)
    ref = int(get_sim_time(unit="ps"))      # the last edge that samples rst high: edge 0
    dut.rst.value = 0
    mon = cocotb_emif.Monitor(dut, PERIOD_PS, ref)
    mon.start(*watch)
    await Timer(PERIOD_PS // 3, unit="ps")  # the bus is asynchronous: start off the clock grid
    return master, mon, inputs


def std_timing() -> emif.Timing:
    return emif.Timing(setup=PERIOD_PS, strobe=emif.MIN_STROBE_CLOCKS * PERIOD_PS,
                       hold=PERIOD_PS, idle=2 * PERIOD_PS)


def replay(model: RegModel, master: cocotb_emif.EmifMaster, mon: cocotb_emif.Monitor,
           first: int = 0) -> tuple[int, list[str]]:
    """Check the monitor saw exactly the master's accesses, then run them through the model and
    compare every read. Returns (reads checked, mismatch descriptions)."""
    acc = master.log[first:]
    com = [c for c in mon.committed if c.edge > model.done]
    errors: list[str] = []
    assert len(com) == len(acc), (f"{len(acc)} accesses issued, {len(com)} committed, "
                                  f"{len(mon.proto)} dropped")
    proto = sorted(p for p in mon.proto if p > model.done)
    pi = 0
    reads = 0
    seen: list[tuple[str | None, bool, bool]] = []   # functional coverage (coverage runs)
    for a, c in zip(acc, com):
        assert (c.we, c.word) == (a.we, a.word), f"issued {a}, committed {c}"
        if a.we:
            assert c.wdata == a.wdata, f"issued {a}, committed {c}"
        while pi < len(proto) and proto[pi] < c.edge:
            model.proto_error(proto[pi])
            pi += 1
        exp = model.access(c.word, c.we, c.wdata, c.edge)
        reg = model.words.get(c.word)
        seen.append((reg.name if reg else None, bool(c.we), model.seq > 0))
        if not a.we:
            reads += 1
            if a.rdata != exp or a.oe != 1:
                name = model.words[a.word].name if a.word in model.words else "unmapped"
                errors.append(f"read {name} (0x{a.word:02x}) at edge {c.edge}: got "
                              f"0x{a.rdata:08x} oe={a.oe}, model 0x{exp:08x}")
        if a.ready != 1:
            errors.append(f"ready low at the end of a served strobe (edge {c.edge})")
    for p in proto[pi:]:
        model.proto_error(p)
    if funcov.active():
        funcov.sample_bus(seen)
        funcov.flush()
    return reads, errors


@cocotb.test()
async def rdl_conformance(dut) -> None:
    """Every register of the RDL: reset value; every field: all-ones, zeros, walking ones and a
    random word written, each followed by a read: the access type (RO/RW/WO/W1C/single pulse/
    range-checked) shows in what comes back. Unmapped addresses: 0xDEADBEEF, writes ignored."""
    master, mon, inputs = await setup(dut)
    model = RegModel(RM, inputs=inputs, input_edges=inputs.edges)
    rng = random.Random(SEED)
    t = std_timing()
    for r in RM.registers:  # reset values, before any write
        await master.read(r.word, t)
    skip = {W["WDOG"], W["CTRL"]}  # exercised below: they start the watchdog and drive pulses
    for r in RM.registers:
        if r.word in skip:
            continue
        patterns = [0xFFFFFFFF, 0, *(f.mask & -f.mask for f in r.fields), rng.getrandbits(32)]
        for f in r.fields:  # walking ones inside each field
            patterns += [1 << b for b in range(f.lsb, f.lsb + f.width)]
        for v in dict.fromkeys(patterns):
            await master.write(r.word, v, t)
            await master.read(r.word, t)
    for bit in range(32):  # CTRL: every bit, then back to zero
        await master.write(W["CTRL"], 1 << bit, t)
        await master.read(W["CTRL"], t)
        await master.read(W["STATUS"], t)
    await master.write(W["WDOG"], 0x12345678, t)
    await master.read(W["WDOG"], t)
    await master.write(W["WDOG"], WDOG_KEY, t)
    await master.read(W["WDOG"], t)
    unmapped = [*range(0x0C, 0x10), 0x16, 0x17, 0x1C, 0x3F, *rng.sample(range(0x44, 256), 12)]
    for word in unmapped:
        await master.write(word, rng.getrandbits(32), t)
        await master.read(word, t)
        await master.read(W["STATUS"], t)
    reads, errors = replay(model, master, mon)
    assert not errors, f"{len(errors)} of {reads} reads differ:\n" + "\n".join(errors[:20])
    dut._log.info(f"RDL conformance: {len(RM.registers)} registers, {reads} reads checked")


@cocotb.test()
async def random_accesses(dut) -> None:
    """N random accesses (HG_ACCESSES) with random EMIF timing and bus-to-FPGA clock ratio,
    interpolator outputs changing underneath, ticks and watchdog running; every read checked
    against the model, every tick and watchdog expiry at the model's clock edge."""
    master, mon, inputs = await setup(dut)
    model = RegModel(RM, inputs=inputs, input_edges=inputs.edges,
                     sample_hz=int(P["SAMPLE_HZ"]))  # type: ignore[arg-type]
    rng = random.Random(SEED)
    mapped = [r.word for r in RM.registers]
    tick_min = RM.by_name()["TICK_DIV"].fields[0].range_min or 1
    stop = False

    async def change_inputs() -> None:
        while not stop:
            await ClockCycles(dut.clk, rng.randint(20, 400))
            e = mon.edge_now()
            await FallingEdge(dut.clk)
            inputs.set(random_axes(rng), e + 1)

    cocotb.start_soon(change_inputs())
    for _ in range(N_ACCESSES):
        t = emif.random_timing(rng, PERIOD_PS)
        u = rng.random()
        word = rng.choice(mapped) if u < 0.93 else rng.randrange(0, 1 << regmap.BUS_ADDR_BITS)
        we = rng.random() < 0.45
        if we and word in (W["TICK_DIV"], W["WDOG"]) and rng.random() < 0.9:
            we = False   # rare: each restarts the tick period or the watchdog
        data = rng.getrandbits(32)
        if we and word == W["WDOG"] and rng.random() < 0.7:
            data = WDOG_KEY
        elif we and word == W["TICK_DIV"] and rng.random() < 0.8:
            data = rng.randint(tick_min, 3 * tick_min)
        elif we and word == W["WDOG_TIMEOUT"] and rng.random() < 0.8:
            data = rng.randint(100, 400)
        elif we and word == W["CTRL"]:
            data &= rng.choice((0x1FF, 0x0F, 0x10F, 0x11F))
        await master.access(we, word, data, t)
    stop = True
    await ClockCycles(dut.clk, 8)
    end = mon.edge_now()
    reads, errors = replay(model, master, mon)
    model.run_to(end)
    assert not errors, f"{len(errors)} of {reads} reads differ:\n" + "\n".join(errors[:20])
    assert mon.rises["tick"] == model.ticks, "tick edges differ from the model"
    assert mon.rises["wdog_expired"] == model.expiries, (
        f"watchdog expiries at {mon.rises['wdog_expired'][:5]}, model {model.expiries[:5]}")
    dut._log.info(f"{len(master.log)} random accesses ({reads} reads) checked; "
                  f"{len(model.ticks)} ticks, {len(model.expiries)} watchdog expiries matched; "
                  f"clock edges {end}")


@cocotb.test()
async def short_strobes(dut) -> None:
    """Strobes from 0.3 to 5 clocks at random phase. A served access must be correct; an access
    that is not served must change nothing and set STATUS.PROTO_ERR (unless shorter than one clock,
    which the synchroniser may miss entirely). Read and write strobes together: PROTO_ERR."""
    master, mon, inputs = await setup(dut)
    rng = random.Random(SEED)
    t = std_timing()
    served = {"write": 0, "read": 0}
    dropped = {"write": 0, "read": 0}
    missed = 0
    value = 0
    await master.write(W["SCRATCH"], value, t)
    for k in range(400):
        clocks = rng.uniform(0.3, 5.0)
        short = emif.Timing(setup=rng.randint(0, PERIOD_PS), strobe=int(clocks * PERIOD_PS),
                            hold=0, idle=4 * PERIOD_PS)
        n_com = len(mon.committed)
        n_pro = len(mon.proto)
        if k % 2 == 0:
            new = rng.getrandbits(32)
            await master.write(W["SCRATCH"], new, short)
            await ClockCycles(dut.clk, 4)
            got = await master.read(W["SCRATCH"], t)
            status = await master.read(W["STATUS"], t)
            was_served = len(mon.committed) - n_com == 3   # the write and the two reads
            perr = (status >> 15) & 1
            if was_served:
                assert got == new and not perr, f"served write wrong: {got:#x} vs {new:#x}"
                value = new
                served["write"] += 1
            else:
                assert got == value, f"dropped write changed SCRATCH ({clocks:.2f} clocks)"
                if perr:
                    dropped["write"] += 1
                else:
                    assert clocks < 1.0 and len(mon.proto) == n_pro, \
                        f"a {clocks:.2f}-clock write strobe vanished without PROTO_ERR"
                    missed += 1
        else:
            acc = await master.access(False, W["SCRATCH"], 0, short)
            await ClockCycles(dut.clk, 4)
            status = await master.read(W["STATUS"], t)
            was_served = len(mon.committed) - n_com == 2
            perr = (status >> 15) & 1
            if was_served:
                assert not perr
                if clocks >= 4.0:  # read data valid < 3 clocks after the fall (+ 1 of margin)
                    assert acc.rdata == value and acc.oe == 1, \
                        f"{clocks:.2f}-clock read got {acc.rdata:#x} oe={acc.oe}, want {value:#x}"
                served["read"] += 1
            elif perr:
                dropped["read"] += 1
            else:
                assert clocks < 1.0, f"a {clocks:.2f}-clock read strobe vanished without PROTO_ERR"
                missed += 1
        if perr:
            await master.write(W["CTRL"], 1 << 4, t)   # FAULT_CLR
            assert (await master.read(W["STATUS"], t) >> 15) & 1 == 0
        if clocks >= 3.0:
            assert was_served, f"a {clocks:.2f}-clock strobe was not served"
    # both strobes at once
    dut.bus_addr.value = W["SCRATCH"]
    dut.bus_data_in.value = 0xABCD
    dut.bus_ce_n.value = 0
    dut.bus_re_n.value = 0
    dut.bus_we_n.value = 0
    await Timer(8 * PERIOD_PS, unit="ps")
    dut.bus_re_n.value = 1
    dut.bus_we_n.value = 1
    dut.bus_ce_n.value = 1
    await Timer(4 * PERIOD_PS, unit="ps")
    assert await master.read(W["SCRATCH"], t) == value
    assert (await master.read(W["STATUS"], t) >> 15) & 1 == 1
    dut._log.info(f"short strobes: served {served}, dropped+flagged {dropped}, "
                  f"unseen (< 1 clock) {missed}")
    assert dropped["write"] and dropped["read"] and served["write"] and served["read"]


@cocotb.test()
async def tick_period(dut) -> None:
    """The servo-tick interrupt: exactly 1 kHz by default and 10 kHz after TICK_DIV = CLK_HZ/1e4,
    measured on the irq pin in simulation time; the acknowledge drops irq; a missed acknowledge
    sets IRQ.MISSED; out-of-range dividers are refused."""
    master, mon, inputs = await setup(dut)
    t = std_timing()
    rises: list[int] = []

    async def watch_irq() -> None:
        while True:
            await RisingEdge(dut.irq)
            rises.append(int(get_sim_time(unit="ps")))

    cocotb.start_soon(watch_irq())
    for rate in (1000, 10000):
        if rate != 1000:
            await master.write(W["TICK_DIV"], CLK_HZ // rate, t)
        rises.clear()
        n = 6
        while len(rises) < n:
            await RisingEdge(dut.irq)
            await master.write(W["IRQ"], 1, t)        # acknowledge
            assert int(dut.irq.value) == 0
        periods = {b - a for a, b in zip(rises, rises[1:])}
        assert periods == {10**12 // rate}, f"{rate} Hz: periods {periods} ps"
        dut._log.info(f"tick at {rate} Hz: {n - 1} periods of exactly {10**12 // rate} ps")
    # no acknowledge for two ticks: MISSED
    await RisingEdge(dut.irq)
    await ClockCycles(dut.clk, CLK_HZ // 10000 + 2)
    assert await master.read(W["IRQ"], t) == 0b11
    await master.write(W["IRQ"], 0b11, t)
    assert await master.read(W["IRQ"], t) & 0b10 == 0
    for bad in (CLK_HZ // 10000 - 1, CLK_HZ // 100 + 1, 0):
        await master.write(W["TICK_DIV"], bad, t)
        assert await master.read(W["TICK_DIV"], t) == CLK_HZ // 10000
        assert (await master.read(W["STATUS"], t) >> 13) & 1 == 1
        await master.write(W["CTRL"], 1 << 4, t)


@cocotb.test()
async def watchdog(dut) -> None:
    """Watchdog: expires exactly WDOG_TIMEOUT us after the last key write (simulation time),
    sets STATUS.WDOG (sticky) and wdog_expired; wrong keys do not pet; FAULT_CLR restarts."""
    master, mon, inputs = await setup(dut)
    t = std_timing()
    await master.write(W["WDOG_TIMEOUT"], 150, t)
    await master.write(W["WDOG"], WDOG_KEY, t)
    pet_edge = mon.committed[-1].edge
    for _ in range(5):
        await master.write(W["WDOG"], 0x5AFEC0DF, t)   # wrong key
    await RisingEdge(dut.wdog_expired)
    exp_edge = mon.edge_now()
    dt_ns = (exp_edge - pet_edge) * PERIOD_PS / 1000
    assert dt_ns == 150_000, f"expired {dt_ns} ns after the pet, want 150 us"
    assert (await master.read(W["STATUS"], t) >> 12) & 1 == 1
    await master.write(W["WDOG"], WDOG_KEY, t)            # a pet does not clear the sticky bit
    assert (await master.read(W["STATUS"], t) >> 12) & 1 == 1
    assert int(dut.wdog_expired.value) == 1
    await master.write(W["CTRL"], 1 << 4, t)               # FAULT_CLR: clears and restarts
    clr_edge = mon.committed[-1].edge
    assert (await master.read(W["STATUS"], t) >> 12) & 1 == 0
    assert int(dut.wdog_expired.value) == 0
    await RisingEdge(dut.wdog_expired)
    assert (mon.edge_now() - clr_edge) * PERIOD_PS == 150 * 10**6
    dut._log.info(f"watchdog: expiry exactly 150 us after the key ({exp_edge - pet_edge} clocks)")


@cocotb.test()
async def snapshot_coherence(dut) -> None:
    """The interpolator outputs change every sample (1 us); each sample's words are a function of
    the sample number. Every word of every axis read between two equal SEQ reads (snapshots from
    the 10 kHz tick and from CTRL.SNAP) must come from one sample; the model, which knows when each
    sample was on the inputs, must agree on every read."""
    master, mon, inputs = await setup(dut)
    t = std_timing()
    clocks_per_sample = CLK_HZ // 1_000_000
    await master.write(W["TICK_DIV"], CLK_HZ // 10000, t)   # 10 kHz: many snapshots
    stop = False
    n_sample = 0

    def sample(n: int) -> list[AxisInputs]:
        return [AxisInputs(pos=n * 7 + i, pos_homed=n * 5 - i, vel=(n % 1000) - 500 + i,
                           index_pos=-n - i, index_count=(n + i) & 0xFFFF,
                           overspeed_count=(3 * n + i) & 0xFFFF, homed=(n >> 4) & 1,
                           faults=(n + i) % 8) for i in range(3)]

    async def drive() -> None:
        nonlocal n_sample
        while not stop:
            await ClockCycles(dut.clk, clocks_per_sample)
            e = mon.edge_now()
            await FallingEdge(dut.clk)
            n_sample += 1
            inputs.set(sample(n_sample), e + 1)

    cocotb.start_soon(drive())
    ax_words = ["POS", "VEL", "IDX_POS", "COUNTS", "POS_HOMED", "FLAGS"]
    coherent = torn = 0
    samples_seen = set()
    model = RegModel(RM, inputs=inputs, input_edges=inputs.edges)
    for k in range(60):
        if k % 2:
            await master.write(W["CTRL"], 1 << 8, t)   # CTRL.SNAP: a snapshot on demand
        s0 = await master.read(W["SEQ"], t)
        words = [[await master.read(W[f"AXIS[{i}].{w}"], t) for w in ax_words] for i in range(3)]
        s1 = await master.read(W["SEQ"], t)
        if s0 != s1:
            torn += 1
            continue
        if s0 == 0:  # no snapshot yet: the reset values
            continue
        # which sample? decode from axis 0's POS, then every word must match that sample
        pos0 = words[0][0] - (1 << 32) if words[0][0] >= 1 << 31 else words[0][0]
        n = pos0 // 7
        expect = sample(n)
        for i in range(3):
            a = expect[i]
            want = [a.pos & 0xFFFFFFFF, (a.vel * 1_000_000 >> 8) & 0xFFFFFFFF,
                    a.index_pos & 0xFFFFFFFF, a.overspeed_count | a.index_count << 16,
                    a.pos_homed & 0xFFFFFFFF, a.faults | a.homed << 4]
            assert words[i] == want, f"SEQ {s0}: axis {i} words {words[i]} not all of sample {n}"
        coherent += 1
        samples_seen.add(n)
        await Timer(random.randint(1, 50) * PERIOD_PS // 3, unit="ps")
    stop = True
    assert coherent >= 30 and len(samples_seen) >= 10
    # and the model agrees on every read (tick timing, snapshot contents)
    reads, errors = replay(model, master, mon)
    assert not errors, "\n".join(errors[:10])
    dut._log.info(f"snapshot: {coherent} coherent snapshots of {len(samples_seen)} samples, "
                  f"{torn} SEQ changes during a read sequence (detected)")


@cocotb.test()
async def same_clock_coincidences(dut) -> None:
    """Accesses placed so that they take effect exactly on (and around) the clock of a servo tick
    or a watchdog expiry: IRQ acknowledge vs tick (the tick wins), CTRL.SNAP vs tick (one SEQ
    step), TICK_DIV write vs tick, key vs expiry (the restart wins). Also proves the documented
    capture timing: an access whose strobe falls just before clock edge E is applied at E + 3."""
    master, mon, inputs = await setup(dut)
    model = RegModel(RM, inputs=inputs, input_edges=inputs.edges)
    div = CLK_HZ // 10000
    t = std_timing()
    await master.write(W["TICK_DIV"], div, t)
    await master.write(W["WDOG_TIMEOUT"], 100, t)

    async def commit_at(edge: int, word: int, data: int, we: bool = True) -> None:
        fall = mon.ref_ps + (edge - emif.CAPTURE_EDGE) * PERIOD_PS - PERIOD_PS // 4
        now = int(get_sim_time(unit="ps"))
        assert fall > now + PERIOD_PS, "scheduled too late"
        await Timer(fall - now, unit="ps")
        await master.access(we, word, data, emif.Timing(0, 6 * PERIOD_PS, 0, 3 * PERIOD_PS))
        assert mon.committed[-1].edge == edge, (
            f"applied at edge {mon.committed[-1].edge}, expected {edge}")

    cases = [(W["IRQ"], 1), (W["CTRL"], 1 << 8), (W["TICK_DIV"], div + 7), (W["IRQ"], 3),
             (W["TICK_DIV"], div)]
    for word, data in cases:
        for d in (-2, -1, 0, 1, 2):
            n = len(mon.rises["tick"])
            while len(mon.rises["tick"]) == n:
                await RisingEdge(dut.tick)
            cur = await master.read(W["TICK_DIV"], t)
            await commit_at(mon.rises["tick"][-1] + cur + d, word, data)
            await master.read(W["IRQ"], t)
            await master.read(W["SEQ"], t)
    for d in (-1, 0, 1):   # a key exactly at, before and after the expiry clock
        await master.write(W["CTRL"], 1 << 4, t)   # clear + restart
        start = mon.committed[-1].edge
        await commit_at(start + 100 * (CLK_HZ // 1_000_000) + d, W["WDOG"], WDOG_KEY)
        await master.read(W["STATUS"], t)
    await ClockCycles(dut.clk, 10)
    end = mon.edge_now()
    reads, errors = replay(model, master, mon)
    model.run_to(end)
    assert not errors, "\n".join(errors[:10])
    assert mon.rises["tick"] == model.ticks
    assert mon.rises["wdog_expired"] == model.expiries
    dut._log.info(f"coincidences: {reads} reads, {len(model.ticks)} ticks, "
                  f"{len(model.expiries)} expiries as modelled")
