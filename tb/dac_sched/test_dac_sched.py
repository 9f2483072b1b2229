"""DAC scheduler (rtl/dac_sched/dac_sched.v): timing in simulation time at every clock we ship
(the 48 MHz default and the iCE40 board's 12 MHz, neither a whole number of ps: see
hapgate.golden.dacsched.period_ps for the simulated period and the tolerance it implies), at
50 and 12.5 MHz (exact periods) and a shorter frame, both simulators; the DAC strobe high from
power-up before the first clock (RTL of the commutator and of the whole top, and the iCE40
netlist); bad configurations fail at elaboration; the schedule checker itself rejects wrong
schedules."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hapgate.base.block import Block
from hapgate.flows import blocks, boards, flow
from hapgate.golden import commutation as cm
from hapgate.golden import configs
from hapgate.golden.dacsched import Load, check_schedule, period_ps, spec_tolerance_ps
from hapgate.runners import sim

HERE = Path(__file__).parent
CONFIGS = {
    "c48_default": cm.CommutationConfig(),                     # shipped: the 48 MHz default
    "c12_board": cm.CommutationConfig(clk_hz=12_000_000),      # shipped: iCE40-HX8K oscillator
    "c50": cm.CommutationConfig(clk_hz=50_000_000),
    "c12m5": cm.CommutationConfig(clk_hz=12_500_000),
    # a faster frame: 1 us skew in an 8 us frame with an 8 us DAC (parameters, not registers)
    "c25_fast": cm.CommutationConfig(clk_hz=25_000_000, skew_ns=1000, frame_ns=8000,
                                     settle_ns=8000),
}


@pytest.mark.parametrize("simulator", sim.simulators())
@pytest.mark.parametrize("name", list(CONFIGS))
def test_schedule_timing_rtl(simulator: str, name: str) -> None:
    cfg = CONFIGS[name]
    sim.run_cocotb(blocks.get("commutator"), simulator, "cocotb_dac_sched", HERE,
                   params=cfg.rtl_params(), testcase="schedule_timing",
                   extra_env={"HG_MODEL": json.dumps(cfg.to_json())})


@pytest.mark.parametrize("simulator", sim.simulators())
def test_strobe_high_from_power_up(simulator: str) -> None:
    """The commutator (its scheduler's strobe) at the iCE40 board's clock, on the build of the
    schedule test, and the whole top's DAC pin register (Icarus, on tb/top's build)."""
    cfg = CONFIGS["c12_board"]
    sim.run_cocotb(blocks.get("commutator"), simulator, "cocotb_dac_sched", HERE,
                   params=cfg.rtl_params(), testcase="power_up")
    if simulator == "icarus":
        sim.run_cocotb(blocks.get("hapgate_top"), "icarus", "cocotb_dac_sched", HERE,
                       params=configs.get("paper").replace(clk_hz=50_000_000).rtl_params(),
                       testcase="power_up")


def test_strobe_high_from_power_up_ice40_netlist() -> None:
    """What the FPGA does: the scheduler synthesized for iCE40, whose flip-flops configure to 0
    (SB_DFF's model starts at 0), simulated with Yosys's cell models: the initial value became
    logic (an inverted flip-flop), and the strobe is high before the first clock."""
    if "icarus" not in sim.simulators():
        pytest.fail("the gate-level netlist runs on Icarus (apt-get install iverilog)")
    rtl = blocks.get("dac_sched")
    net = flow.netlist(rtl, rtl.params(), "ice40")
    gate = Block(name=f"dac_sched_ice40_netlist_{net.parent.name[-10:]}", top=rtl.top,
                 sources=(str(net), str(flow.simlib("ice40"))), params=dict, doc="netlist")
    sim.run_cocotb(gate, "icarus", "cocotb_dac_sched", HERE, params={}, testcase="power_up",
                   build_args=["-DNO_ICE40_DEFAULT_ASSIGNMENTS"])


@pytest.mark.parametrize("change, message", [
    ({"SKEW_NS": 3000}, "dac_sched_CHANNELS_times_SKEW_must_not_exceed_FRAME"),
    ({"SETTLE_NS": 20000}, "dac_sched_FRAME_NS_must_be_at_least_SETTLE_NS"),
    ({"CLK_HZ": 48_001_000}, "dac_sched_SKEW_NS_and_FRAME_NS_must_be_whole_clocks_of_CLK_HZ"),
    ({"CLK_HZ": 1_000_000},
     "dac_sched_needs_1_le_WR_CYCLES_le_15_and_SKEW_CYCLES_ge_WR_CYCLES_plus_3"),
    ({"CLK_HZ": 1_500_000, "PIPE_CYCLES": 20}, "dac_sched_last_write_must_end_within_the_frame"),
])
def test_bad_configuration_fails_at_elaboration(change: dict[str, int], message: str) -> None:
    block = blocks.get("dac_sched")
    params = {**block.params(), **change}
    assert flow.lint_verilator(block, block.params()).ok   # the default is fine
    f = flow.lint_verilator(block, params)
    assert not f.ok and message in f.detail, f.detail
    g = flow.lint_icarus(block, params)
    assert not g.ok and message in g.detail, g.detail


def _ideal_loads(cfg: cm.CommutationConfig, starts: list[int]) -> list[Load]:
    p = 10**12 // cfg.clk_hz
    return [Load(int(s + c * p), k, 0) for s in starts
            for k, c in enumerate(cm.load_clocks(cfg))]


def test_checker_accepts_spec_and_rejects_wrong_schedules() -> None:
    cfg = cm.CommutationConfig(clk_hz=50_000_000)
    fp = cfg.frame_ns * 1000
    starts = [0, fp, 2 * fp, 3 * fp]
    good = _ideal_loads(cfg, starts)
    assert check_schedule(good, starts[1:], cfg, t0_ps=0).shape == (3, 6)
    late = [Load(ld.t_ps + (20000 if i == 9 else 0), ld.addr, 0) for i, ld in enumerate(good)]
    with pytest.raises(AssertionError, match="skew"):
        check_schedule(late, starts[1:], cfg, t0_ps=0)
    swapped = [Load(ld.t_ps, [1, 0][ld.addr] if ld.addr < 2 else ld.addr, 0) for ld in good]
    with pytest.raises(AssertionError, match="order"):
        check_schedule(swapped, starts[1:], cfg, t0_ps=0)
    nonzero = [Load(ld.t_ps, ld.addr, 5 if i == 2 else 0) for i, ld in enumerate(good)]
    with pytest.raises(AssertionError, match="not zero"):
        check_schedule(nonzero, starts[1:], cfg, t0_ps=0)
    shifted = [Load(ld.t_ps + 20000, ld.addr, 0) for ld in good]
    with pytest.raises(AssertionError, match="latency"):
        check_schedule(shifted, starts[1:], cfg, t0_ps=0)


def test_load_times_are_the_paper_schedule() -> None:
    """Model load times at 48 MHz: 2.000 us apart, first one 8 clocks after the frame start."""
    cfg = cm.CommutationConfig()
    t = cm.load_times_ns(cfg)
    assert np.allclose(np.diff(t), 2000.0, rtol=0, atol=1e-9)
    assert abs(t[0] - 8 * 1e9 / 48e6) < 1e-9
    assert cfg.frame_clocks == 768 and cfg.skew_clocks == 96


def test_every_shipped_clock_is_simulated() -> None:
    """The clocks of the default build and of every board are among the simulated configs."""
    shipped = {cm.CommutationConfig().clk_hz} | {b.clk_hz for b in boards.BOARDS.values()}
    assert shipped <= {c.clk_hz for c in CONFIGS.values()}, shipped


def _sim_loads(cfg: cm.CommutationConfig, starts: list[int], shift: dict[int, int] | None = None
               ) -> list[Load]:
    """Loads where the RTL puts them, timed with the simulated period (shift: load -> clocks)."""
    p = period_ps(cfg)
    shift = shift or {}
    out = []
    for s in starts:
        for k, c in enumerate(cm.load_clocks(cfg)):
            i = len(out)
            out.append(Load(int(s + (c + shift.get(i, 0)) * p), k, 0))
    return out


@pytest.mark.parametrize("clk_hz", [48_000_000, 12_000_000])
def test_checker_tolerance_at_inexact_periods(clk_hz: int) -> None:
    """At 48 and 12 MHz the simulated period is 2/3 ps long: the checker accepts the RTL's
    schedule within the derived tolerance (64 ps per 2 us skew at 48 MHz) and still rejects a
    load one clock early or late."""
    cfg = cm.CommutationConfig(clk_hz=clk_hz)
    p = period_ps(cfg)
    assert p % 2 == 0 and abs(p - 10**12 / clk_hz) < 1
    tol = spec_tolerance_ps(cfg, cfg.skew_ns * 1000)
    assert 0 < tol < p / 100
    if clk_hz == 48_000_000:
        assert p == 20834 and tol == 64
    fp = cfg.frame_clocks * p
    starts = [0, fp, 2 * fp, 3 * fp]
    assert check_schedule(_sim_loads(cfg, starts), starts[1:], cfg, t0_ps=0).shape == (3, 6)
    for shift in (1, -1):
        with pytest.raises(AssertionError, match="skew"):
            check_schedule(_sim_loads(cfg, starts, {9: shift}), starts[1:], cfg, t0_ps=0)
    with pytest.raises(ValueError, match="not a whole number of clocks"):
        spec_tolerance_ps(cm.CommutationConfig(clk_hz=clk_hz, skew_ns=1001), 1001 * 1000)
