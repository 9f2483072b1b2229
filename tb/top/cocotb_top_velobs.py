"""cocotb test of the velocity observer through the whole FPGA (rtl/top/hapgate_top.v with
VEL_OBS = 1 and VEL_OBS_SEL = 1): the VEL_CTRL reset values (SEL from the top parameter),
write and read-back over the bus, and the VEL snapshot of every axis against the models
(hapgate.golden.interp + velobs with the settings each sample saw from the committed writes):
the observer's velocity where SEL = 1, the window FIR's where SEL = 0, in the same unit.
"""

from __future__ import annotations

import os
import random

import cocotb
import numpy as np
from cocotb.triggers import ClockCycles, Timer
from cocotb.utils import get_sim_time
from hapgate.flows import regmap
from hapgate.golden import encsig, interp, velobs
from hapgate.runners import tbutil

P = tbutil.params()
CLK_HZ = int(P["CLK_HZ"])  # type: ignore[arg-type]
PERIOD_PS = 10**12 // CLK_HZ
CFG = tbutil.config().top()   # a sweep point of `observer`
assert CFG.clk_hz == CLK_HZ and CFG.interp.vel_obs and CFG.vel_obs_sel
RM = regmap.load(CLK_HZ)
W = {r.name: r.word for r in RM.registers}
N = int(os.environ.get("HG_SAMPLES", "1200"))
SPEEDS = (150.0, -100.0, 40.0)      # rev/s per axis: positions strictly monotonic


def stimulus() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a = np.zeros((N, 3), dtype=np.int64)
    b = np.zeros((N, 3), dtype=np.int64)
    for i, v in enumerate(SPEEDS):
        x = encsig.constant(v, N, start=3.3 + 7 * i)
        a[:, i], b[:, i] = encsig.adc_codes(x, encsig.with_spec(encsig.PAPER_LIKE, seed=31 + i))
    return a, b, np.array(SPEEDS)


@cocotb.test()
async def observer_through_the_top(dut) -> None:
    rng = random.Random(5)
    a, b, _ = stimulus()
    bus = await tbutil.TopBus(dut, PERIOD_PS, W, rng).start("tick")
    ref, mon, wr, rd = bus.ref, bus.mon, bus.wr, bus.rd
    cocotb.start_soon(tbutil.drive_top_adc(dut, a, b))
    await ClockCycles(dut.clk, 3 * CFG.div)
    await Timer(PERIOD_PS // 3, unit="ps")

    # reset: SEL = 7 (VEL_OBS_SEL), TYPE3 = 7, BW = 6 on every axis
    assert await rd("VEL_CTRL") == 0x6_6677, "VEL_CTRL reset"
    # axis 0 observer III s = 6; axis 1 the FIR reported, its observer type II at s = 3;
    # axis 2 observer III at code 15 (acts as 8), then 4; bits 3, 7 and 20.. read 0
    await wr("VEL_CTRL", 0xFFFF_FFFF)
    assert await rd("VEL_CTRL") == 0xF_FF77
    await wr("VEL_CTRL", 0xF_3655)
    assert await rd("VEL_CTRL") == 0xF_3655
    await wr("VEL_CTRL", 0x4_3655)
    snaps: list[tuple[str, list[int]]] = []
    for when, sel0 in ((0.55, None), (0.85, 0x4_3654)):
        if sel0 is not None:
            await wr("VEL_CTRL", sel0)          # axis 0: back to the FIR
        end_ps = ref + int(when * N) * CFG.div * PERIOD_PS
        await Timer(end_ps - int(get_sim_time(unit="ps")), unit="ps")
        await wr("CTRL", 1 << 8)
        got = [await rd(f"AXIS[{i}].{r}") for i in range(3) for r in ("POS", "VEL")]
        snaps.append((f"snapshot at {when:.2f}", got))

    # ---------------------------------------------------------------- the models
    cap = (np.arange(N) + 1) * CFG.div + 1      # capture edge of each sample
    upd = cap + CFG.interp.latency - 2          # its observer update (the settings read there)
    for i in range(3):
        bw = np.full(N, 6)
        t3 = np.ones(N, dtype=bool)
        sel = np.ones(N, dtype=bool)
        for c in mon.committed:
            if c.we and c.word == W["VEL_CTRL"]:
                bw[upd > c.edge] = (c.wdata >> (8 + 4 * i)) & 15
                t3[upd > c.edge] = bool((c.wdata >> (4 + i)) & 1)
                sel[cap > c.edge] = bool((c.wdata >> i) & 1)
        out = interp.run(a[:, i], b[:, i], None, CFG.interp)
        vo = velobs.run_interp(out, bw=bw, type3=t3)
        for name, got in snaps:
            pos = got[2 * i]
            k = np.flatnonzero((out.pos.astype(np.int64) & 0xFFFFFFFF) == pos)
            assert k.size == 1, f"{name}: axis {i} POS {pos:#x} is not one sample"
            k = int(k[0])
            v = int(vo[k]) if sel[k] else int(out.vel[k])
            want = (v * 1_000_000 >> 8) & 0xFFFFFFFF
            assert got[2 * i + 1] == want, f"{name}: axis {i} sample {k} sel {sel[k]}: VEL " \
                                           f"{got[2 * i + 1]:#x}, model {want:#x}"
            dut._log.info(f"{name}: axis {i} sample {k}: VEL {v} counts/W "
                          f"({'observer' if sel[k] else 'FIR'}), FIR {int(out.vel[k])}")
    # the two velocities differ where they were compared (the selection is visible)
    assert any(int(vo[k]) != int(out.vel[k]) for k in range(300, N))
