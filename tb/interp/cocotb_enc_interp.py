"""cocotb tests of rtl/interp/enc_interp.v (one axis) against models/hapgate/golden/interp.py.

The stimulus is one of hapgate.golden.encsig's named scenarios (HG_SCENARIO, HG_SAMPLES); every
output column is compared with the bit-exact model on every sample. Inputs are driven and
outputs sampled on the falling clock edge.
"""

from __future__ import annotations

import os

import cocotb
import numpy as np
from cocotb.triggers import FallingEdge
from cocotb.utils import get_sim_time
from hapgate.golden import encsig, interp
from hapgate.runners import native, tbutil

LATENCY = 5        # clocks s_valid -> m_valid, paper path (+1 ANGLE_REG, +RB+1 ratio, +1 HARM)
PERIOD_NS = 20     # 50 MHz for the unit test; the 3-axis top derives its strobe from CLK_HZ


def config() -> interp.InterpConfig:
    return interp.InterpConfig(**tbutil.model_config())  # type: ignore[arg-type]


async def stream(dut, sc: encsig.Scenario, gaps: np.ndarray | None = None,
                 pulses_between: bool = False) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Feed the scenario (gaps[k] idle clocks before sample k) and collect every output.

    Control pulses (clear_at / arm_at) are applied with their sample; with `pulses_between`
    they are pulsed in the idle clock before it instead (they must apply to the same sample).
    Returns the outputs and, per sample, the latency in ns of simulation time: from the clock
    cycle in which s_valid presents the sample to the cycle in which m_valid presents its result
    (both observed at the falling edge)."""
    n = sc.a.size
    gaps = np.zeros(n, dtype=np.int64) if gaps is None else gaps
    clear = np.zeros(n, dtype=bool)
    clear[sc.clear_at] = True
    arm = np.zeros(n, dtype=bool)
    arm[sc.arm_at] = True
    a = sc.a.astype(np.int64) & 0xFF
    b = sc.b.astype(np.int64) & 0xFF
    idx = sc.index.astype(np.int64)
    cols: dict[str, list[int]] = {c: [] for c in native.COLUMNS}
    no_obs = not tbutil.model_config().get("vel_obs", False)
    sent: list[float] = []
    lat: list[float] = []
    k = 0
    wait = int(gaps[0])
    cycle = 0
    while len(sent) < n or len(lat) < n:
        await FallingEdge(dut.clk)
        cycle += 1
        if dut.m_valid.value == 1:
            lat.append(get_sim_time("ns") - sent[len(lat)])
            tbutil.append_interp_outputs(dut, cols)
            assert dut.m_fault.value == (cols["faults"][-1] != 0)
            assert no_obs is False or dut.m_vel_obs.value.to_signed() == 0  # VEL_OBS = 0: 0
        dut.ctl_fault_clear.value = 0
        dut.ctl_home_arm.value = 0
        if k < n and wait == 0:
            dut.s_valid.value = 1
            dut.s_a.value = int(a[k])
            dut.s_b.value = int(b[k])
            dut.s_index.value = int(idx[k])
            if not pulses_between:
                dut.ctl_fault_clear.value = int(clear[k])
                dut.ctl_home_arm.value = int(arm[k])
            sent.append(get_sim_time("ns"))
            k += 1
            wait = int(gaps[k]) if k < n else 0
        else:
            dut.s_valid.value = 0
            if pulses_between and k < n and wait == 1:  # the idle clock right before sample k
                dut.ctl_fault_clear.value = int(clear[k])
                dut.ctl_home_arm.value = int(arm[k])
            wait = max(0, wait - 1)
        assert cycle < int(np.sum(gaps)) + n + 50, "outputs stopped coming"
    return {c: np.array(v, dtype=np.int64) for c, v in cols.items()}, np.array(lat)


def assert_latency(lat_ns: np.ndarray, cfg: interp.InterpConfig) -> None:
    """Latency is part of the spec: LATENCY clocks for the paper's path, one more with the angle
    register (ANGLE_REG), RATIO_BITS + 1 more with the ratio divider (ANGLE = 1)."""
    extra = int(cfg.angle_reg) + ((cfg.ratio_bits + 1) if cfg.ratio else 0) + int(cfg.harm)
    assert cfg.latency == LATENCY + extra + int(cfg.cal)
    want = (LATENCY + extra) * PERIOD_NS
    assert np.all(lat_ns == want), f"latency {sorted(set(lat_ns.tolist()))} ns != {want} ns"


async def reset(dut) -> None:
    dut.s_valid.value = 0
    dut.s_a.value = 0
    dut.s_b.value = 0
    dut.s_index.value = 0
    dut.ctl_fault_clear.value = 0
    dut.ctl_home_arm.value = 0
    dut.ctl_harm_en.value = 0      # harmonic table (HARM = 1) off and not written
    dut.cfg_harm_we.value = 0
    dut.cfg_harm_addr.value = 0
    dut.cfg_harm_data.value = 0
    await tbutil.start(dut, period_ns=PERIOD_NS)


def check(rtl: dict[str, np.ndarray], sc: encsig.Scenario, cfg: interp.InterpConfig) -> None:
    model = native.model_matrix(interp.run(sc.a, sc.b, sc.index, cfg, clear_at=sc.clear_at,
                                           arm_at=sc.arm_at))
    bad = native.first_mismatch(rtl, model)
    assert bad is None, f"{sc.name}: first mismatch at sample {bad[0]}, column {bad[1]}: " \
                        f"RTL {bad[2]} model {bad[3]}"


@cocotb.test()
async def scenario_bit_exact(dut):
    """The scenario back to back (one sample per clock): every column, every sample."""
    cfg = config()
    sc = encsig.scenario(os.environ["HG_SCENARIO"], int(os.environ["HG_SAMPLES"]))
    await reset(dut)
    rtl, lat = await stream(dut, sc)
    if os.environ.get("HG_DUMP"):  # the benchmark measures the RTL's own positions
        np.save(os.environ["HG_DUMP"], rtl["pos"])
    check(rtl, sc, cfg)
    assert_latency(lat, cfg)


@cocotb.test()
async def gaps_latency_and_pulses(dut):
    """Samples with random idle clocks between them, control pulses in the idle clocks: the
    results are the same, and the latency is LATENCY clocks of simulation time."""
    cfg = config()
    sc = encsig.scenario("dropout_controls", int(os.environ.get("HG_GAPS_SAMPLES", "3000")))
    rng = np.random.default_rng(3)
    gaps = rng.integers(1, 4, sc.a.size)
    await reset(dut)
    rtl, lat = await stream(dut, sc, gaps=gaps, pulses_between=True)
    check(rtl, sc, cfg)
    assert_latency(lat, cfg)


@cocotb.test()
async def reset_mid_stream(dut):
    """A reset in the middle of a run starts the axis afresh: outputs equal a fresh model run."""
    cfg = config()
    sc = encsig.scenario("const150_ideal", 600)
    await reset(dut)
    await stream(dut, sc)
    await reset(dut)
    rtl, _ = await stream(dut, sc)
    check(rtl, sc, cfg)


@cocotb.test()
async def square_table(dut):
    """SQ_RAM = 1: every entry of the signal-loss square table is the square of its code read as
    two's complement (computed here, not taken from the RTL), so no code can shift the
    amplitude window."""
    p = tbutil.params()
    assert p.get("SQ_RAM") == 1, "square_table needs a build with SQ_RAM = 1"
    await reset(dut)
    tab = dut.g_nocal.g_sq_ram.sq_tab
    codes = np.arange(256, dtype=np.int64)
    want = np.where(codes < 128, codes, codes - 256) ** 2
    got = np.array([int(tab[int(c)].value) for c in codes], dtype=np.int64)
    bad = np.flatnonzero(got != want)
    assert bad.size == 0, f"square table wrong at codes {bad[:8].tolist()}: {got[bad[:8]].tolist()}"
