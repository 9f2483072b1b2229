"""cocotb timing tests of rtl/dac_sched/dac_sched.v, driven through the commutator that feeds it
(the scheduler's producer): the DAC model checks setup, hold, strobe width and settling; the
schedule check asserts order, skew, frame period and latency in simulation time. power_up needs
only clk and dac_wr_n: it also runs on the whole top and on gate-level netlists."""

from __future__ import annotations

import cocotb
import numpy as np
from cocotb.triggers import Timer
from hapgate.golden import commutation as cm
from hapgate.golden.dacsched import check_schedule, random_frames
from hapgate.runners import tbutil
from hapgate.runners.cocotb_dac import Bench


@cocotb.test()
async def schedule_timing(dut):
    """40 frames of random inputs changed at random points: every load where the spec says."""
    cfg = cm.CommutationConfig.from_json(tbutil.model_config())
    rng = np.random.default_rng(11)
    frames = random_frames(rng, 40, cfg)
    bench = Bench(dut, cfg)
    t0 = await bench.start(frames)
    latches = await bench.run(frames, rng.integers(1, cfg.frame_clocks - 1, len(frames)))
    words = check_schedule(bench.dac.loads, latches, cfg, t0_ps=t0)
    assert np.array_equal(cm.decode(words[:40], cfg), cm.commutate(frames, cfg))
    assert not bench.dac.violations, "; ".join(bench.dac.violations[:5])
    lat = np.array([ld.t_ps for ld in bench.dac.loads[6:12]]) - latches[0]
    dut._log.info("frame start -> load, ns: %s", (lat / 1000).tolist())
    # every channel is reloaded exactly once per frame, so never within its settling time
    t = np.array([ld.t_ps for ld in bench.dac.loads])
    a = np.array([ld.addr for ld in bench.dac.loads])
    for ch in range(6):
        assert np.all(np.diff(t[a == ch]) >= cfg.settle_ns * 1000)


@cocotb.test()
async def power_up(dut):
    """From FPGA configuration to the first clock: no clock edge, reset not yet applied, and the
    DAC strobe is high all along (a low strobe would load the DACs with whatever is on the data
    pins when it rises at the first clock)."""
    dut.clk.value = 0
    for step in range(10):
        await Timer(100, "ns")
        v = dut.dac_wr_n.value
        assert v.is_resolvable and int(v) == 1, f"dac_wr_n is {v} {100 * (step + 1)} ns after " \
            "power-up, before any clock"
