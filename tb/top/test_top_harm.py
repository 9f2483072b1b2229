"""The ratio angle stage and the harmonic table through the whole FPGA (hapgate_top with
ANGLE = 1, HARM = 1): the table learned from the FPGA's own positions, loaded and read back over
the bus (HARM_ADDR / HARM_DATA), enabled per axis (HARM_CTRL); positions bit-exact against the
models on every sample, every read against the register model, each entry and the error against
the float truth within their budgets (0.35 deg RMS with 1 % h3: issue 13).

Verilator runs on test_top_calib's Verilator build (the same parameters: CAL = 1, disabled here,
50 MHz), so the two share one build; Icarus builds the stages alone, at 8 MHz, shorter."""

from __future__ import annotations

from pathlib import Path

import pytest
from hapgate.base import tables
from hapgate.flows import blocks, flow
from hapgate.golden import configs
from hapgate.runners import sim

HERE = Path(__file__).parent
RUN = {"verilator": {"HG_LEARN": "2000", "HG_ON": "3000"},
       "icarus": {"HG_LEARN": "1200", "HG_ON": "2200"}}


def config(simulator: str) -> configs.Config:
    hires = configs.get("hires")
    if simulator == "verilator":   # = tb/top/test_top_calib.py's config("verilator")
        return hires.replace(clk_hz=50_000_000, cal_lines_log2=0)
    return hires.replace(clk_hz=8_000_000, cal=False)


@pytest.mark.parametrize("simulator", sim.simulators())
def test_top_harmonic_table(simulator: str, monkeypatch: pytest.MonkeyPatch) -> None:
    if simulator == "verilator":
        # the precompiled-header flag (docs/design/TOOLCHAIN.md)
        monkeypatch.setenv("MAKEFLAGS", "CFG_CXXFLAGS_PCH_I=-include")
    sim.run_cocotb(blocks.get("hapgate_top"), simulator, "cocotb_top_harm", HERE,
                   config=config(simulator), extra_env=RUN[simulator])


@pytest.mark.parametrize("change, stop", [
    ({"LUT_BITS": 9}, "hapgate_top_ANGLE_1_needs_LUT_BITS_7"),
    ({"CLK_HZ": 1_000_000}, "hapgate_top_HARM_needs_CLK_HZ_at_least_2_SAMPLE_HZ"),
    ({"ANGLE": 0}, "enc_interp_HARM_must_be_0_or_1_and_needs_ANGLE_1"),
    ({"HARM_LOG2": 9}, "hg_regfile_HARM_must_be_0_or_1_and_HARM_LOG2_4_to_8"),
])
def test_refused_configurations(change: dict[str, int], stop: str) -> None:
    """Combinations that cannot work stop the elaboration with a message naming the parameter
    (Icarus elaboration, no simulation); the registry refuses them before any build
    (tb/test_configs.py)."""
    block = blocks.get("hapgate_top_hires")
    good = flow.lint_icarus(block, block.params())
    assert good.ok, good.detail
    bad = flow.lint_icarus(block, block.params() | change)
    assert not bad.ok and stop in bad.detail, bad.detail


def test_top_config_refusals() -> None:
    hires = configs.get("hires")
    with pytest.raises(configs.ConfigError, match="'hires': lut_bits: .*1024 counts per line"):
        hires.replace(lut_bits=9)
    with pytest.raises(configs.ConfigError, match="'hires': clk_hz: .*clk_hz >= 2"):
        hires.replace(clk_hz=1_000_000)
    # the harmonic table without the ratio stage cannot be written: no angle mode gives it
    assert not [m for m, v in configs.ANGLES.items() if v["harm"] and not v["ratio"]]
    p = hires.rtl_params()
    assert (p["ANGLE"], p["HARM"], p["HARM_LOG2"], p["RATIO_BITS"]) == (1, 1, 6, 10)
    assert Path(str(p["RATIO_FILE"])) in tables.write_tables(p)
    assert Path(str(p["RATIO_FILE"])).is_file()
    assert not {"ANGLE", "HARM", "RATIO_FILE", "ANGLE_REG"} & set(
        configs.get("paper").rtl_params())
