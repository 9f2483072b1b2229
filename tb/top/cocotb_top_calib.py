"""cocotb test of the calibration path through the whole FPGA (rtl/top/hapgate_top.v, CAL = 1).

The DSP enables the calibration of axes 0 and 1 over the bus (axis 1 is frozen later, axis 2
stays off) while the encoders move; then the shafts stop. Checked against the models
(hapgate.golden.interp with the calibration, the enable and freeze levels each sample saw from
the committed bus writes): the live calibration registers of every axis (offsets, gains, phase,
block counts) read back over the bus, and the snapshot positions after the stop.
"""

from __future__ import annotations

import os
import random
from dataclasses import replace

import cocotb
import numpy as np
from cocotb.triggers import ClockCycles, Timer
from cocotb.utils import get_sim_time
from hapgate.flows import regmap
from hapgate.golden import enccal, encsig, interp
from hapgate.runners import tbutil

P = tbutil.params()
CLK_HZ = int(P["CLK_HZ"])  # type: ignore[arg-type]
PERIOD_PS = 10**12 // CLK_HZ
CFG = tbutil.config().top()   # a sweep point of `hires` (CAL = 1)
assert CFG.clk_hz == CLK_HZ and CFG.interp.cal
RM = regmap.load(CLK_HZ)
W = {r.name: r.word for r in RM.registers}
N_MOVE = int(os.environ.get("HG_SAMPLES", "2000"))
N_HOLD = 200
MU = 4


def stimulus() -> tuple[np.ndarray, np.ndarray]:
    n = N_MOVE + N_HOLD
    hold = np.arange(n) >= N_MOVE
    lines = [encsig.constant(150.0, n, start=3.3), encsig.constant(-100.0, n, start=14.6),
             encsig.reversals(40.0, 800.0, n, start=500.3)]
    a = np.zeros((n, 3), dtype=np.int64)
    b = np.zeros((n, 3), dtype=np.int64)
    for i, x in enumerate(lines):
        x = np.where(hold, x[N_MOVE - 1], x)                      # then the shafts stop
        qa, qb = encsig.adc_codes(x, encsig.with_spec(encsig.PAPER_LIKE, noise_lsb=0.0,
                                                      seed=21 + i))
        a[:, i], b[:, i] = qa, qb
    return a, b


@cocotb.test()
async def calibration_through_the_top(dut) -> None:
    rng = random.Random(9)
    a, b = stimulus()
    n = a.shape[0]
    bus = await tbutil.TopBus(dut, PERIOD_PS, W, rng).start("tick")
    ref, mon, wr, rd = bus.ref, bus.mon, bus.wr, bus.rd
    cocotb.start_soon(tbutil.drive_top_adc(dut, a, b))
    await ClockCycles(dut.clk, 3 * CFG.div)
    await Timer(PERIOD_PS // 3, unit="ps")

    # reset values: the identity
    assert await rd("AXIS[0].CAL_GAIN") == 0x4000_4000
    assert await rd("AXIS[0].CAL_CTRL") == 0x60
    await wr("AXIS[0].CAL_CTRL", 1 | MU << 4)
    await wr("AXIS[1].CAL_CTRL", 1 | MU << 4)
    assert await rd("AXIS[1].CAL_CTRL") == 1 | MU << 4
    await Timer(int(0.6 * N_MOVE) * CFG.div * PERIOD_PS, unit="ps")
    await wr("AXIS[1].CAL_CTRL", 3 | MU << 4)                    # freeze axis 1
    end_ps = ref + (n * CFG.div - 20) * PERIOD_PS
    await Timer(end_ps - int(get_sim_time(unit="ps")), unit="ps")
    await wr("CTRL", 1 << 8)                                     # snapshot after the stop
    got = {i: [await rd(f"AXIS[{i}].{r}") for r in ("CAL_OFS", "CAL_GAIN", "CAL_PHASE",
                                                     "CAL_STAT", "POS")] for i in range(3)}

    # ---------------------------------------------------------------- the models
    cap = (np.arange(n) + 1) * CFG.div + 1      # capture edge of each sample
    ctl_writes = {0: [], 1: []}
    for c in mon.committed:
        for i in (0, 1):
            if c.we and c.word == W[f"AXIS[{i}].CAL_CTRL"]:
                ctl_writes[i].append((c.edge, c.wdata))
    for i in range(3):
        en = np.zeros(n, dtype=bool)
        fr = np.zeros(n, dtype=bool)
        for edge, v in ctl_writes.get(i, []):
            after = cap > edge
            en[after] = bool(v & 1)
            fr[after] = bool(v & 2)
        out = interp.run(a[:, i], b[:, i], None, CFG.interp, cal_en=en, cal_freeze=fr,
                         cal_mu=MU)
        c = enccal.applied(out.extra["cal_state_after"][:, -1]) & 0xFFFF
        want = [int(c[0] | c[1] << 16), int(c[2] | c[3] << 16), int(c[4]),
                int(out.extra["cal_gear"][-1] | out.extra["cal_updates"][-1] << 16),
                int(out.pos[-1]) & 0xFFFFFFFF]
        assert got[i] == want, f"axis {i}: read {[hex(v) for v in got[i]]} " \
                               f"model {[hex(v) for v in want]}"
        if i < 2:
            assert out.extra["cal_updates"][-1] >= 20, f"axis {i}: too few updates"
        else:
            assert want[1] == 0x4000_4000 and out.extra["cal_updates"][-1] == 0
    # the frozen axis stopped adapting at the freeze; the other went on
    assert got[1][3] >> 16 < got[0][3] >> 16
    # and the calibrated position differs from the paper's on the calibrated axes
    plain = interp.run(a[:, 0], b[:, 0], None, replace(CFG.interp, cal=False))
    assert int(plain.pos[-1]) & 0xFFFFFFFF != got[0][4]
