"""Encoder interpolator, one axis (rtl/interp/enc_interp.v), on both simulators via cocotb:
bit-exact against hapgate.golden.interp on every sample of every stress scenario; latency; controls.
Long runs (>= 10^6 samples), error vs truth, slip, velocity and fault timing are in
test_interp_native.py (the Verilator native harness)."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import pytest
from hapgate.flows import blocks
from hapgate.golden import configs, encsig, interp
from hapgate.runners import sim

HERE = Path(__file__).parent
SAMPLES = {"verilator": 6000, "icarus": 2500}   # per scenario (Icarus is the slow second opinion)


def _run(simulator: str, cfg: interp.InterpConfig, testcase: str | list[str],
         scenario: str = "", gaps_samples: int = 3000,
         extra: dict[str, int] | None = None) -> None:
    sim.run_cocotb(blocks.get("enc_interp"), simulator, "cocotb_enc_interp", HERE,
                   params=cfg.rtl_params() | (extra or {}), testcase=testcase,
                   extra_env={"HG_MODEL": json.dumps(asdict(cfg)), "HG_SCENARIO": scenario,
                              "HG_SAMPLES": str(SAMPLES[simulator]),
                              "HG_GAPS_SAMPLES": str(gaps_samples)})


@pytest.mark.parametrize("simulator", sim.simulators())
@pytest.mark.parametrize("scenario", encsig.SCENARIOS)
def test_scenario_bit_exact(simulator: str, scenario: str) -> None:
    _run(simulator, interp.InterpConfig(), "scenario_bit_exact", scenario)


@pytest.mark.parametrize("simulator", sim.simulators())
def test_gaps_latency_pulses_reset(simulator: str) -> None:
    _run(simulator, interp.InterpConfig(), ["gaps_latency_and_pulses", "reset_mid_stream"])


@pytest.mark.parametrize("simulator", sim.simulators())
def test_direction_invert(simulator: str) -> None:
    _run(simulator, interp.InterpConfig(invert=True), "scenario_bit_exact", "dropout_controls")


def test_fit_options_bit_exact() -> None:
    """The HX8K board's fit options (rtl/boards/README.md, "Fit"), Icarus: SQ_RAM = 1 (squares
    from a block-RAM table: the table entry by entry, and back-to-back samples with A/B swapped so
    both table reads are used either way round) and HOLD_C = 1 (no stage-D copies: samples with
    idle clocks between them, as the board's strobe has) are bit-exact against the same model."""
    cfg = interp.InterpConfig()
    fit = configs.FITS[configs.get("hx8k").fit]     # the board's fit, as one axis takes it
    _run("icarus", cfg, ["square_table", "gaps_latency_and_pulses"],
         extra={k: fit[k] for k in ("SQ_RAM", "HOLD_C")})
    cfg = interp.InterpConfig(invert=True)
    _run("icarus", cfg, "scenario_bit_exact", "dropout_controls", extra={"SQ_RAM": fit["SQ_RAM"]})


@pytest.mark.parametrize("simulator", sim.simulators())
@pytest.mark.parametrize("lut_bits", [5, 9])
def test_other_lut_density(simulator: str, lut_bits: int) -> None:
    """The LUT density is a parameter (the bench sweeps 5..9): bit-exact at both ends."""
    cfg = interp.InterpConfig(lut_bits=lut_bits, vel_log2w=4, loss_samples=3)
    _run(simulator, cfg, "scenario_bit_exact", "reversals_paper")


@pytest.mark.parametrize("cfg", [interp.InterpConfig(angle_reg=True),
                                 interp.InterpConfig(ratio=True, lut_bits=9, angle_reg=True),
                                 interp.InterpConfig(ratio=True, harm=True)],
                         ids=["angle_reg", "ratio4096_angle_reg", "ratio_harm_off"])
def test_angle_stage_variants(cfg: interp.InterpConfig) -> None:
    """The angle register stage (ANGLE_REG = 1, issue 15) and the ratio stage at 4096 counts per
    line (ANGLE = 1, LUT_BITS = 9) on Icarus (no build cost; Verilator where Icarus is missing):
    bit-exact on every sample and
    column with idle clocks and pulses between samples, and the latency of each variant in
    simulation time (5 + 1, 5 + 1 + 11 clocks), and the harmonic table's stage (HARM = 1, table
    disabled: the plain ratio angle, 5 + 11 + 1 clocks). The native harness runs the ratio stage
    and the harmonic table at 1024 counts per line over 10^6 samples (test_ratio_native.py)."""
    # 1200 samples of the dropout scenario (its dropout, clears and arms scale with n)
    _run(sim.simulators()[-1], cfg, ["gaps_latency_and_pulses"], gaps_samples=1200)
