"""cocotb test of the ratio angle stage and the harmonic table through the whole FPGA
(rtl/top/hapgate_top.v, ANGLE = 1, HARM = 1), loaded and enabled over the DSP bus.

Three encoders with the paper-like front end plus 1 % 3rd harmonic run at constant speeds (two
forwards, one backwards). The DSP-side sequence is the one rtl/interp/README.md documents: while
the correction is off, the FPGA's own positions of each axis (taken from the interpolator's
outputs, every sample) are fitted off-chip (`angle.harmonic_fit`); each table is loaded with one
HARM_ADDR write and 64 auto-incrementing HARM_DATA writes, read back the same way, and the
correction of axes 0 and 2 is switched on (axis 2 off again later; axis 1 keeps its table off).
Checked:

- the interpolator's position of every axis on every sample equals `hapgate.golden.interp.run`
  with the configuration `hapgate.golden.top.TopConfig` builds, the loaded table and the enable
  level each sample saw from the committed bus writes (a sample sees a write committed before
  its capture edge);
- every bus read (ID and VERSION, HARM_CTRL with LOG2, HARM_ADDR's auto-increment, every table
  entry of every axis, AXIS = 3 selecting nothing) against the register model
  (`hapgate.golden.regmodel`, harm=True) and the table written; ID equals the RDL's reset value;
- every learned entry against the float truth (the mean error of the FPGA's positions in its
  bin, in 1/4 count): within 0.75 (1/2 for its rounding, 1/4 for the fitted line; measured
  <= 0.51), so an entry 2 or more off breaks it, and with bit-exactness and the read-back the FPGA
  runs exactly that table;
- the error against the float truth of the corrected axes: <= 0.35 deg electrical RMS (issue 13's
  budget with 1 % h3), and above it for the same samples with the correction off.

With a CAL = 1 build (the Verilator run shares test_top_calib's build) the calibration stays
disabled: the ratio of the identity-corrected channels is the ratio of the raw ones.
"""

from __future__ import annotations

import os
import random

import cocotb
import numpy as np
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge, Timer
from cocotb.utils import get_sim_time
from hapgate.flows import regmap
from hapgate.golden import angle, encsig, interp
from hapgate.golden.regmodel import RegModel
from hapgate.runners import tbutil

P = tbutil.params()
CLK_HZ = int(P["CLK_HZ"])  # type: ignore[arg-type]
PERIOD_PS = 10**12 // CLK_HZ
CFG = tbutil.config().top()   # a sweep point of `hires` (with CAL = 1: disabled here)
HARM_LOG2 = CFG.interp.harm_log2
assert CFG.clk_hz == CLK_HZ and CFG.interp.harm
RM = regmap.load(CLK_HZ)
W = {r.name: r.word for r in RM.registers}
N_LEARN = int(os.environ.get("HG_LEARN", "3000"))    # samples fitted with the correction off
N_ON = int(os.environ.get("HG_ON", "5000"))          # samples after the load and the enable
BUDGET_DEG = 0.35                                    # issue 13: 1 % h3 with the harmonic stage
# each learned entry against the truth's per-bin mean error (1/4 count): its rounding (1/2) and
# the fitted line's offset from the true one (1/4; measured <= 0.02)
TABLE_BUDGET_QC = 0.75
SPEEDS = (37.3, -30.1, 23.9)                         # rev/s per axis
HN = 1 << HARM_LOG2


def stimulus(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    lines = np.stack([encsig.constant(v, n, start=0.3 + 7.1 * i)
                      for i, v in enumerate(SPEEDS)], 1)
    a = np.zeros((n, 3), dtype=np.int64)
    b = np.zeros((n, 3), dtype=np.int64)
    for i in range(3):
        spec = encsig.with_spec(encsig.PAPER_LIKE, h3=0.01, seed=31 + i)
        a[:, i], b[:, i] = encsig.adc_codes(lines[:, i], spec)
    return a, b, lines


def axis_pos(packed: list[int], i: int) -> np.ndarray:
    """Axis i's signed 32-bit positions from the packed m_pos words."""
    w = np.array(packed, dtype=object)
    return np.array([(v >> (32 * i)) & 0xFFFFFFFF for v in w], dtype=np.uint32).view(np.int32)


def signed8(v: int) -> int:
    return v - 256 if v & 0x80 else v


@cocotb.test()
async def harmonic_table_through_the_top(dut) -> None:
    rng = random.Random(13)
    n_load = 6000 // CFG.div + 200           # samples the bus sequence may take, with margin
    n = N_LEARN + n_load + N_ON
    a, b, lines = stimulus(n)
    bus = await tbutil.TopBus(dut, PERIOD_PS, W, rng).start()
    ref, mon, master, wr, rd = bus.ref, bus.mon, bus.master, bus.wr, bus.rd
    pos: list[int] = []                      # the interpolator's m_pos, every sample

    async def record() -> None:
        while True:
            await RisingEdge(dut.u_interp.m_valid)
            await ReadOnly()
            pos.append(int(dut.u_interp.m_pos.value))

    cocotb.start_soon(tbutil.drive_top_adc(dut, a, b))
    cocotb.start_soon(record())
    await ClockCycles(dut.clk, 3 * CFG.div)
    await Timer(PERIOD_PS // 3, unit="ps")

    ident = await rd("ID")
    assert ident == RM.by_name()["ID"].reset, f"ID 0x{ident:08x}"
    assert await rd("HARM_CTRL") == HARM_LOG2 << 8       # off after reset, LOG2 of the build

    # ------------------------------------------------ learn off-chip from the FPGA's positions
    while len(pos) < N_LEARN:
        await ClockCycles(dut.clk, 64 * CFG.div)
    tables = [angle.harmonic_fit(axis_pos(pos[:N_LEARN], i), CFG.interp.lut_bits, HARM_LOG2)
              for i in range(3)]
    # each entry against the float truth: the mean error of the FPGA's positions in its bin
    cpl = CFG.interp.counts_per_line
    for i in range(3):
        p_i = axis_pos(pos[:N_LEARN], i)
        e = interp.truth_counts_error(p_i, lines[:N_LEARN, i] * cpl)
        jb = np.mod(p_i.astype(np.int64), cpl) * HN // cpl
        t_true = (np.bincount(jb, weights=e - e.mean(), minlength=HN)
                  / np.bincount(jb, minlength=HN) * 4)
        dev = np.abs(tables[i] - t_true)
        assert dev.max() <= TABLE_BUDGET_QC, (
            f"axis {i}: entry {int(dev.argmax())} is {dev.max():.2f} quarter counts off the "
            f"truth's {t_true[dev.argmax()]:.2f}")

    # ------------------------------------------------ load through the registers, read back
    for i in (2, 0, 1):
        await wr("HARM_ADDR", i << 8)
        for v in tables[i]:
            await wr("HARM_DATA", int(v) & 0xFF)
    await wr("HARM_ADDR", 3 << 8)                        # AXIS = 3: stores nothing
    await wr("HARM_DATA", 0x55)
    assert await rd("HARM_DATA") == 0
    back = []
    for i in range(3):
        start = HN % 256                                 # ADDR mod 2**LOG2: entry 0
        await wr("HARM_ADDR", i << 8 | start)
        back.append([signed8(await rd("HARM_DATA")) for _ in range(HN)])
        assert await rd("HARM_ADDR") == i << 8 | (start + HN) % 256  # each access incremented
    for i in range(3):
        assert back[i] == [int(v) for v in tables[i]], f"axis {i}: read back {back[i]}"
    await wr("HARM_CTRL", 0b101)                         # correction on for axes 0 and 2
    assert await rd("HARM_CTRL") == HARM_LOG2 << 8 | 0b101
    assert len(pos) < N_LEARN + n_load, "the bus sequence took longer than planned"
    await Timer((N_ON * 7 // 10) * CFG.div * PERIOD_PS, unit="ps")
    await wr("HARM_CTRL", 0b001)                         # axis 2 off again
    end_ps = ref + ((n + 1) * CFG.div + CFG.interp.latency + 4) * PERIOD_PS
    await Timer(end_ps - int(get_sim_time(unit="ps")), unit="ps")
    assert len(pos) >= n, f"{len(pos)} results for {n} samples"
    del pos[n:]                                          # (the strobe runs on)

    # ------------------------------------------------ the register model, every read
    model = RegModel(RM, harm=True, harm_log2=HARM_LOG2)
    com = mon.committed
    assert len(com) == len(master.log), f"{len(master.log)} accesses, {len(com)} committed"
    reads = 0
    for acc, c in zip(master.log, com):
        assert (c.we, c.word) == (acc.we, acc.word)
        exp = model.access(c.word, c.we, c.wdata, c.edge)
        if not acc.we:
            reads += 1
            assert acc.rdata == exp, (f"read 0x{acc.word:02x} at edge {c.edge}: "
                                      f"0x{acc.rdata:08x}, model 0x{exp:08x}")

    # ------------------------------------------------ the positions, every sample, every axis
    cap = (np.arange(n) + 1) * CFG.div + 1               # capture edge of each sample
    en = np.zeros((n, 3), dtype=bool)
    for c in com:
        if c.we and c.word == W["HARM_CTRL"]:
            for i in range(3):
                en[cap > c.edge, i] = bool(c.wdata >> i & 1)
    truth = lines * CFG.interp.counts_per_line
    deg = 360.0 / CFG.interp.counts_per_line
    figures = []
    for i in range(3):
        rtl = axis_pos(pos, i)
        want = interp.run(a[:, i], b[:, i], None, CFG.interp, harm_table=tables[i],
                          harm_en=en[:, i])
        bad = np.flatnonzero(rtl != want.pos.astype(np.int32))
        assert bad.size == 0, (f"axis {i}: {bad.size} positions differ, first at sample "
                               f"{bad[0]}: rtl {rtl[bad[0]]}, model {want.pos[bad[0]]}")
        if not en[:, i].any():
            continue
        sel = en[:, i]
        off = interp.run(a[:, i], b[:, i], None, CFG.interp)
        j = (np.mod(off.pos[sel].astype(np.int64), CFG.interp.counts_per_line) * HN
             // CFG.interp.counts_per_line)
        # every entry applied to >= 16 samples: an entry loaded 1/4 count off changes the rounded
        # position of a quarter of them, so the bit-exact compare above sees it (P(miss) < 1 %)
        assert np.bincount(j, minlength=HN).min() >= 16, "a table entry was barely used"

        def rms(x: np.ndarray, s: np.ndarray = sel, t: np.ndarray = truth[:, i]) -> float:
            e = interp.truth_counts_error(x[s], t[s])
            return float(np.sqrt(np.mean((e - e.mean()) ** 2)) * deg)

        r_on, r_off = rms(rtl), rms(off.pos)
        figures.append(f"axis {i}: {int(sel.sum())} samples corrected, {r_on:.3f} deg RMS "
                       f"(correction off: {r_off:.3f})")
        assert r_on <= BUDGET_DEG, figures[-1]
        assert r_off > BUDGET_DEG, figures[-1]
    dut._log.info(f"{reads} register reads matched the model; " + "; ".join(figures))
