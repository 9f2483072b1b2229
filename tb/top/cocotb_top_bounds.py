"""cocotb: the FPGA's per-axis torque clamp (TQ_LIMIT) at its boundaries through the whole top
(rtl/top/hapgate_top.v), written over the bus as the firmware does. ALIGN mode puts channel a at
the OFFSET's angle whatever the shaft does, so each code depends on the torque and the limit
only. The expected codes come from the spec's formulas (tb/top/test_top_bounds.py cites them);
the golden model's clamp and commutation (as hapgate.golden.top chains them) must give the same
codes as the RTL, and both the spec's. Also: the fault kinds the top test does not raise
(overspeed, signal loss) zero their motors only, and a second reset restores the reset state
(fault_kinds_zero_torque)."""

from __future__ import annotations

from fractions import Fraction

import cocotb
import numpy as np
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge
from cocotb.utils import get_sim_time
from hapgate.flows import regmap
from hapgate.golden import commutation as cm
from hapgate.golden.regmodel import WDOG_KEY
from hapgate.runners import funcov, tbutil

P = tbutil.params()
CLK_HZ = int(P["CLK_HZ"])  # type: ignore[arg-type]
PERIOD_PS = 10**12 // CLK_HZ
CFG = tbutil.config().top()   # the paper's, at the test's clock
assert CFG.clk_hz == CLK_HZ
RM = regmap.load(CLK_HZ)
W = {r.name: r.word for r in RM.registers}

K = 255                    # OFFSET: channel a at code 255 (T[255], sin next to 1), b at 255 - 341
LIMITS = (10_000, 10_003, 3)   # per axis; see cases()


def rom(i: int) -> int:
    """docs/blocks/sine-rom.md: round(8191 sin((i + 1/2) 90 deg / 256))."""
    return int(np.floor(8191 * np.sin((i + 0.5) * (np.pi / 2) / 256) + 0.5))


def spec_code(k: int, torque: int, limit: int) -> int:
    """commutator.md step 5: clamp to +-min(limit, 32768), round half away from zero of
    v t / 2^15, saturate to +-8191; v from the unfolded quarter-wave ROM."""
    q, i = (k % 1024) >> 8, k & 255
    v = [rom(i), rom(255 - i), -rom(i), -rom(255 - i)][q]
    lim = min(limit, 32768)
    t = max(-lim, min(lim, torque))
    x = Fraction(v * t, 1 << 15)
    m = int(abs(x) + Fraction(1, 2))
    return max(-8191, min(8191, m if x >= 0 else -m))


def steps() -> list[tuple[int, int, int]]:
    """Torque commands per step, one per axis: L - 1, L, L + 1, their negatives, and far past."""
    out = []
    for f in (lambda L: L - 1, lambda L: L, lambda L: L + 1, lambda L: -(L - 1),
              lambda L: -L, lambda L: -(L + 1), lambda L: 32767, lambda L: -32768):
        out.append(tuple(int(f(L)) for L in LIMITS))
    return out


@cocotb.test()
async def torque_limit_bounds(dut) -> None:
    # 70 on every axis: a healthy standstill, no fault
    master, dac, t = await tbutil.start_top_dac(dut, PERIOD_PS, CFG.comm, adc_word=0x464646)
    await master.write(W["WDOG_TIMEOUT"], 1_000_000, t)
    await master.write(W["WDOG"], WDOG_KEY, t)
    for i in range(3):
        await master.write(W[f"AXIS[{i}].TQ_LIMIT"], LIMITS[i], t)
        await master.write(W[f"AXIS[{i}].OFFSET"], K, t)
        await master.write(W[f"AXIS[{i}].MODE"], cm.ALIGN, t)
    await master.write(W["CTRL"], 0b1111, t)                  # global and axis enables
    frame = CFG.comm.frame_clocks
    got, rows = [], []
    for torque in steps():
        for i in range(3):
            await master.write(W[f"AXIS[{i}].TORQUE"], torque[i] & 0xFFFF, t)
        await ClockCycles(dut.clk, 2 * frame + 10)            # a whole frame latched after it
        last = {}
        for ld in dac.loads:
            last[ld.addr] = ld.word
        got.append([last[c] for c in range(6)])
        rows.append(torque)
    status = await master.read(W["STATUS"], t)
    assert status & 0x1007 == 0, f"a fault or the watchdog (STATUS {status:#x})"
    assert not dac.violations, dac.violations[:5]
    codes = cm.decode(np.array(got, dtype=np.int64), CFG.comm)
    tq = np.array(rows, dtype=np.int64)
    want = np.array([[spec_code(k, int(tq[r, m]), LIMITS[m]) for m in range(3)
                      for k in (K, K - 341)] for r in range(len(rows))])
    # the model as hapgate.golden.top chains it: per-axis clamp, then the commutator's codes
    clamped = cm.clamp_torque(tq, np.broadcast_to(np.array(LIMITS), tq.shape))
    model = cm.commutate(cm.Frames.make(np.zeros_like(tq), clamped, offset=K, mode=cm.ALIGN,
                                        limit=65535), CFG.comm)
    for engine, c in (("rtl", codes), ("model", model)):
        bad = np.argwhere(c != want)
        assert bad.size == 0, (f"{engine}: step {bad[0][0]} (torques {rows[bad[0][0]]}, limits "
                               f"{LIMITS}) channel {bad[0][1]}: {c[tuple(bad[0])]}, spec "
                               f"{want[tuple(bad[0])]}")
    dut._log.info(f"TQ_LIMIT bounds: {len(rows)} steps x 6 channels as specified, RTL and model")


@cocotb.test()
async def fault_kinds_zero_torque(dut) -> None:
    """Each interpolator fault kind the top test does not raise (it raises clipping), on its
    own axis, zeroes that axis's motor and only it: overspeed on axis 0 (the ADC pair jumps
    two quadrants in one sample: spec, "two flagged on that sample"), signal loss on axis 2
    (a^2 + b^2 = 200 < 40^2 on 16 consecutive samples: flagged on the 16th). Axis 1 stays
    healthy and keeps its torque. Zero from one frame + the output stage after the fault is
    visible (rtl/top/README.md; the bound of tb/top/cocotb_top.py); STATUS.FAULT and each
    axis's FLAGS.FAULTS name the axis and the kind (rtl/regs/hapgate.rdl). Then a second
    reset, mid-run, restores the documented reset state (rtl/top/README.md, "Reset")."""
    a0 = 70                                                  # quadrant 0 on every axis
    master, dac, t = await tbutil.start_top_dac(dut, PERIOD_PS, CFG.comm,
                                                adc_word=a0 | a0 << 8 | a0 << 16)
    await master.write(W["WDOG_TIMEOUT"], 1_000_000, t)
    await master.write(W["WDOG"], WDOG_KEY, t)
    for i in range(3):
        await master.write(W[f"AXIS[{i}].TQ_LIMIT"], 32768, t)
        await master.write(W[f"AXIS[{i}].OFFSET"], K, t)
        await master.write(W[f"AXIS[{i}].MODE"], cm.ALIGN, t)
        await master.write(W[f"AXIS[{i}].TORQUE"], 20_000, t)
    await master.write(W["CTRL"], 0b1111, t)                  # global and axis enables
    frame, wr = CFG.comm.frame_clocks, CFG.comm.wr_cycles
    await ClockCycles(dut.clk, 2 * frame + 10)
    zero = CFG.zero_word
    before = {ld.addr: ld.word for ld in dac.loads}
    assert sorted(before) == list(range(6)) and zero not in before.values(), before

    # axis 0: quadrant 0 -> 2 in one sample; axis 2: inside the loss threshold; axis 1 as is
    await RisingEdge(dut.adc_strobe)
    t_ovs = int(get_sim_time(unit="ps")) + PERIOD_PS          # its capture edge
    bad = (-a0 & 0xFF) | a0 << 8 | 10 << 16
    dut.adc_a.value = bad
    dut.adc_b.value = bad
    for _ in range(15):
        await RisingEdge(dut.adc_strobe)
    t_loss = int(get_sim_time(unit="ps")) + PERIOD_PS         # the 16th bad sample's capture
    await ClockCycles(dut.clk, 3 * frame)
    assert not dac.violations, dac.violations[:5]

    bound = frame + wr + 1                                    # clocks, from the fault visible
    for ax, t_cap, what in ((0, t_ovs, "overspeed"), (2, t_loss, "signal loss")):
        t_vis = t_cap + CFG.interp.latency * PERIOD_PS
        for ch in (2 * ax, 2 * ax + 1):
            lds = [ld for ld in dac.loads if ld.addr == ch]
            decided = [ld for ld in lds if ld.t_ps - (wr + 1) * PERIOD_PS > t_vis]
            assert decided and all(ld.word == zero for ld in decided), (
                f"{what}: channel {ch} not at zero torque after the fault",
                [ld.word for ld in decided])
            assert any(ld.word != zero for ld in lds if ld.t_ps < t_cap), \
                f"{what}: channel {ch} was not driving before the fault"
            lat = (decided[0].t_ps - t_vis) // PERIOD_PS
            assert lat <= bound, f"{what}: channel {ch} zero {lat} clocks after > {bound}"
    healthy = [ld for ld in dac.loads if ld.addr in (2, 3) and ld.t_ps > t_ovs]
    assert len(healthy) >= 6 and all(ld.word == before[ld.addr] for ld in healthy), \
        "axis 1 (no fault) must keep its torque"

    status = await master.read(W["STATUS"], t)
    assert status & 7 == 0b101, f"STATUS.FAULT {status & 7:#05b}, want axes 0 and 2"
    await master.write(W["CTRL"], 0b1111 | 1 << 8, t)        # SNAP, enables kept
    flags = [await master.read(W[f"AXIS[{i}].FLAGS"], t) & 7 for i in range(3)]
    assert flags == [1, 0, 4], f"FLAGS.FAULTS {flags}: want overspeed (1), none, loss (4)"
    if funcov.active():   # the two causes whose zero torque was just checked
        funcov.sample_top(["overspeed", "loss"])
        funcov.flush()

    # a second reset, mid-run, healthy signals again (rtl/top/README.md, "Reset"): dac_wr_n
    # high throughout; after it every mode is OFF, the limits are 0, drive is disabled (so every
    # load is zero), and the sticky faults are gone
    healthy_word = a0 | a0 << 8 | a0 << 16
    dut.adc_a.value = healthy_word
    dut.adc_b.value = healthy_word
    await ClockCycles(dut.clk, 20 * CFG.div)                # past the interpolator's pipeline
    n_before = len(dac.loads)
    assert not dac.violations, dac.violations[:5]
    dut.rst.value = 1
    for _ in range(4):
        await RisingEdge(dut.clk)
        await ReadOnly()
        assert int(dut.dac_wr_n.value) == 1, "dac_wr_n low during reset"
    await RisingEdge(dut.clk)
    t_rel = int(get_sim_time(unit="ps"))
    dut.rst.value = 0
    await ClockCycles(dut.clk, 2 * frame + 10)
    assert all(ld.t_ps < t_rel - 3 * PERIOD_PS for ld in dac.loads[n_before:]
               if ld.word != zero), "a non-zero DAC load during or after the reset"
    assert {ld.addr for ld in dac.loads if ld.t_ps > t_rel} == set(range(6))
    assert await master.read(W["CTRL"], t) & 0xF == 0, "drive enabled after reset"
    for i in range(3):
        assert await master.read(W[f"AXIS[{i}].MODE"], t) & 3 == cm.OFF
        assert await master.read(W[f"AXIS[{i}].TQ_LIMIT"], t) == 0
    status = await master.read(W["STATUS"], t)
    assert status & 7 == 0, f"STATUS.FAULT {status & 7:#05b} after reset"
    # the reset restarts the frame: each channel's first (zero) load after it may come sooner
    # than the settling time after its last one; every other DAC port rule still holds
    again = [v for v in dac.violations if "rewritten after" not in v
             or not t_rel <= int(v.split()[0]) <= t_rel + 2 * frame * PERIOD_PS]
    assert not again, again[:5]
    dut._log.info(f"faults: overspeed on axis 0 and loss on axis 2 zero their motors within "
                  f"{bound} clocks; axis 1 keeps its torque; a second reset restores the reset "
                  f"state")
