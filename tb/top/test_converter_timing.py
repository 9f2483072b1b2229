"""The FPGA's converter pins against the converters' datasheet timing, in simulation time, at
every clock we ship or document (rtl/top/README.md, "Converter timing"): 12 MHz (the HX8K
board's oscillator, with its ADC pair adapter taking the pins one clock before the core),
24 MHz, 48 MHz (the default and the ECP5 board's PLL clock); both DAC profiles (the DAC7625
the boards are wired for, the 14-bit AD7836 of the paper's class). Icarus: the build is
instant and a few frames are all it takes. Two deliberately broken ADC clocks must fail, and
the clocks the ADC clock cannot serve must be refused at elaboration."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest
from hapgate.flows import blocks, flow
from hapgate.golden import configs
from hapgate.golden import converters as cv
from hapgate.runners import sim

HERE = Path(__file__).parent
SHIPPED = [(12_000_000, 1), (24_000_000, 0), (48_000_000, 0)]   # (CLK_HZ, ADC_CAPTURE_LEAD)


@pytest.mark.parametrize("dac", ["dac7625", "ad7836"])
@pytest.mark.parametrize("clk_hz,lead", SHIPPED)
def test_converter_timing(clk_hz: int, lead: int, dac: str, tmp_path: Path) -> None:
    part = cv.DAC_PARTS[dac]
    cfg = configs.get("paper").replace(clk_hz=clk_hz, dac_twr_ns=part.t_wr_ns)
    # the strobe is derived from the DAC's t_WR: DAC7625 1, 2, 3 clocks (83, 83, 62.5 ns);
    # AD7836 (100 ns) 2, 3, 5 clocks (167, 125, 104 ns)
    want = {"dac7625": {12: 1, 24: 2, 48: 3}, "ad7836": {12: 2, 24: 3, 48: 5}}[dac]
    assert cfg.top().comm.wr_cycles == want[clk_hz // 1_000_000]
    assert not cv.adc_refusals(cv.adc_plan(clk_hz, lead=lead))
    rep = tmp_path / "report.json"
    sim.run_cocotb(blocks.get("hapgate_top"), "icarus", "cocotb_converter_timing", HERE,
                   config=cfg, params={**cfg.rtl_params(), "ADC_CAPTURE_LEAD": lead},
                   testcase="converter_timing",
                   extra_env={"HG_DAC_PART": dac, "HG_CONV_REPORT": str(rep)})
    r = json.loads(rep.read_text())
    assert r["adc_captures"] >= 80 * (2 if lead else 1) and r["dac_writes"] >= 24


# Broken ADC clocks, made by editing a copy of hapgate_top.v after its elaboration checks (so
# the checks still pass): the simulation's judges must catch them.
BROKEN = {
    # the clock rises at the capture edge (as when the converters were clocked by the capture
    # strobe): data may change at the capture; the capture follows the wrong rise
    "rise_at_capture": ("localparam integer ADC_PH0_I  = (ADC_Q + ADC_DIV - 1) %",
                        "localparam integer ADC_PH0_I  = (ADC_DIV - 1) %",
                        "before the next ADC clock edge"),
    # the clock decoded from the phase in one expression (no set / clear): after reset it rises
    # at once, a runt period before its first real rise. Every edge is still clear of the
    # captures, but the extra rise puts the pipeline one cycle ahead of the documented one
    "runt_after_reset": ("if (adc_ph_next == {ADC_CW{1'b0}}) adc_clk <= 1'b1;\n"
                         "            else if (adc_ph_next == ADC_FALL) adc_clk <= 1'b0;",
                         "adc_clk <= adc_ph_next < ADC_FALL;",
                         "clock period"),
}


@pytest.mark.parametrize("variant", sorted(BROKEN))
def test_broken_adc_clock_fails(variant: str, tmp_path: Path) -> None:
    find, replace, problem = BROKEN[variant]
    base = blocks.get("hapgate_top")
    src = (base.source_paths()[-1]).read_text()
    assert base.sources[-1] == "top/hapgate_top.v" and src.count(find) == 1
    mutated = tmp_path / "hapgate_top.v"
    mutated.write_text(src.replace(find, replace))
    blk = dataclasses.replace(base, name=f"hapgate_top_broken_{variant}",
                              sources=(*base.sources[:-1], str(mutated)))
    rep = tmp_path / "report.json"
    cfg = configs.get("paper").replace(clk_hz=12_000_000)
    with pytest.raises(SystemExit):   # how the cocotb runner fails under pytest
        sim.run_cocotb(blk, "icarus", "cocotb_converter_timing", HERE, config=cfg,
                       testcase="adc_timing", extra_env={"HG_CONV_REPORT": str(rep)},
                       quiet=True)
    r = json.loads(rep.read_text())
    assert any(problem in p for p in r["adc_problems"]), r["adc_problems"]
    assert r["adc_alignment"], "the pipeline alignment check did not see the broken clock"


@pytest.mark.parametrize("clk_mhz", [2, 3, 4])
def test_adc_clock_refused_where_it_cannot_be_met(clk_mhz: int) -> None:
    """2 and 3 clocks per sample leave no clock between the ADC clock's edges and the capture:
    hapgate_top refuses them at elaboration (the model says why); 4 is the least it serves."""
    clk = clk_mhz * 1_000_000
    why = cv.adc_refusals(cv.adc_plan(clk))
    assert bool(why) == (clk_mhz < 4), why
    base = blocks.get("hapgate_top")
    blk = dataclasses.replace(base, name=f"hapgate_top_adc_refusal_{clk_mhz}")
    f = flow.lint_icarus(blk, configs.get("paper").replace(clk_hz=clk).rtl_params())
    assert f.ok == (clk_mhz >= 4), f.detail
    if clk_mhz < 4:
        assert "hapgate_top_ADC_capture" in f.detail, f.detail


def test_adc_plan_judges() -> None:
    """The plan and the judge on synthetic edges: the shipped plans clear the figures with
    margin; a capture one ADC-setup too early, or a clock high for one 48 MHz clock (the old
    strobe: 20.8 ns < t_PW 23 ns), is a problem."""
    for clk, lead in SHIPPED:
        p = cv.adc_plan(clk, lead=lead)
        assert p.su * 10**9 // clk >= cv.HI1175.tod_ns + cv.IoBudget().out_in_ns
        tc = 10**12 // clk
        rises = [k * p.div * tc for k in range(20)]
        falls = [r + p.hi * tc for r in rises]
        caps = [r + (p.q - lead) * tc for r in rises]                 # the B (or only) read
        if lead:                                                      # the adapter's A read,
            caps += [c - p.s * tc for c in caps]                      # in the same high phase
            assert all(r < c < r + p.hi * tc for r in rises[:1] for c in (caps[0], caps[20]))
        assert not cv.judge_adc(rises, falls, sorted(caps), p.div * tc).problems
        early = [r + 50_000 for r in rises]                  # 50 ns after the rise
        assert any("t_OD" in s for s in cv.judge_adc(rises, falls, early, p.div * tc).problems)
    tc = 20_834
    rises = [k * 48 * tc for k in range(20)]
    v = cv.judge_adc(rises, [r + tc for r in rises], [r + 24 * tc for r in rises], 48 * tc)
    assert any("t_PW" in s for s in v.problems)
