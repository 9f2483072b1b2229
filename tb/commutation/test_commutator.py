"""Commutator (rtl/commutation/commutator.v): bit-exact codes, DAC timing, saturation, safety and
the paper's figures on both simulators; model-level checks of the golden model against the truth."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hapgate.flows import blocks
from hapgate.golden import commutation as cm
from hapgate.golden.sine import SineRomConfig
from hapgate.runners import sim

HERE = Path(__file__).parent
CHECKS = ["random_bit_exact", "saturation_extremes", "safety_paths", "paper_figures"]
CONFIGS = {
    # 16 MHz, two's complement, the paper's 256-entry ROM, two pole pairs (+ the figure sweep)
    "c16_tc": cm.CommutationConfig(clk_hz=16_000_000),
    # board-like 50 MHz, offset binary, a 128-entry ROM, three pole pairs, a 2-clock strobe
    "c50_ob": cm.CommutationConfig(clk_hz=50_000_000, offset_binary=True, pole_pairs=3,
                                   rom=SineRomConfig(addr_bits=7), wr_cycles=2),
    # the LUT-only HX8K build's shift-add multiplier (16 clocks later) near its 12 MHz clock
    # (12 MHz itself is not a whole number of ps periods: 12.5 MHz, SKEW = 25 clocks)
    "c12m5_serial": cm.CommutationConfig(clk_hz=12_500_000, serial_mul=True),
}


@pytest.mark.parametrize("simulator", sim.simulators())
@pytest.mark.parametrize("name", list(CONFIGS))
def test_commutator_rtl(simulator: str, name: str) -> None:
    cfg = CONFIGS[name]
    # the figure sweep needs a power-of-two pole count (one electrical cycle in whole counts)
    checks = CHECKS if cfg.pole_pairs & (cfg.pole_pairs - 1) == 0 else CHECKS[:3]
    sim.run_cocotb(blocks.get("commutator"), simulator, "cocotb_commutator", HERE,
                   params=cfg.rtl_params(), testcase=checks,
                   extra_env={"HG_MODEL": json.dumps(cfg.to_json()), "HG_FRAMES": "250"})


# ---------------------------------------------------------------------------- model vs truth

def test_model_sine_matches_truth_within_budget() -> None:
    """SINE codes against the float truth: angle error <= 1/2 code on a (1/2 + 1/3 on b: the
    341-code step), plus 1/2 LSB rounding and the 32767/32768 scale."""
    cfg = cm.CommutationConfig()
    rng = np.random.default_rng(7)
    n = 20000
    pos = rng.integers(0, 1 << 32, (n, 3))
    torque = rng.integers(-32767, 32768, (n, 3))
    off = rng.integers(0, 1024, (n, 3))
    got = cm.commutate(cm.Frames.make(pos, torque, offset=off), cfg)
    want = cm.truth(pos, torque, off, cfg)
    step = 2 * np.pi / cfg.codes * np.abs(np.repeat(torque, 2, axis=1)) / 32767 * cfg.max_code
    budget = step * np.array([0.5, 0.5 + 1 / 3] * 3) + 0.5 + cfg.max_code / 32768
    assert np.all(np.abs(got - want) <= budget)
    # and the budget is tight: the worst case uses most of it on channel b
    assert np.max(np.abs(got - want)[:, 1] / budget[:, 1]) > 0.9


def test_channel_b_is_341_codes_behind() -> None:
    cfg = cm.CommutationConfig()
    pos = (np.arange(1024) << 9)[:, None] * np.ones(3, dtype=np.int64)
    codes, _ = cm.channel_samples(cm.Frames.make(pos, 1), cfg)
    assert np.array_equal(codes[:, 0], np.arange(1024))           # bits 18..9 with 2 pole pairs
    assert np.all((codes[:, 0] - codes[:, 1]) % 1024 == 341)      # round(1024/3)


def test_six_step_levels_match_the_hall_pattern() -> None:
    """Six-step levels against the float Hall pattern: a = +1 on [30, 150) deg, -1 on [210, 330);
    b the same 120 deg later; and a + b + c = 0 with c = -(a + b) a three-level pattern too."""
    cfg = cm.CommutationConfig()
    rng = np.random.default_rng(3)
    pos = rng.integers(0, 1 << 20, (5000, 3))
    off = rng.integers(0, 1024, (5000, 3))
    _, v = cm.channel_samples(cm.Frames.make(pos, 1, offset=off, mode=cm.SIX_STEP), cfg)
    deg = np.mod((pos * 2 % (1 << 20)) * 360 / (1 << 20) + off * 360 / 1024, 360)

    def hall(d: np.ndarray) -> np.ndarray:
        d = np.mod(d, 360)
        return np.where((d >= 30) & (d < 150), 1, np.where((d >= 210) & (d < 330), -1, 0))

    assert np.array_equal(v[:, 0::2] // cfg.rom.fs, hall(deg))
    assert np.array_equal(v[:, 1::2] // cfg.rom.fs, hall(deg - 120))
    c = -(v[:, 0::2] + v[:, 1::2]) // cfg.rom.fs
    assert np.array_equal(c, hall(deg - 240))


def test_safety_and_limit_model() -> None:
    cfg = cm.CommutationConfig()
    f = cm.Frames.make(np.zeros((4, 3), dtype=np.int64), 20000, offset=256,
                       enable=[1, 0, 1, 1], fault=[[0, 0, 0], [0, 0, 0], [0, 1, 0], [0, 0, 0]],
                       limit=[65535, 65535, 65535, 1000])
    c = cm.commutate(f, cfg)
    assert np.all(c[1] == 0) and np.all(c[2, 2:4] == 0) and np.all(c[2, [0, 1, 4, 5]] != 0)
    assert abs(c[3, 0]) <= round(1000 * cfg.max_code / 32768) + 1 and c[3, 0] != 0
    # zero torque in offset binary is mid-scale
    assert cm.encode(np.array([0]), cfg.with_(offset_binary=True))[0] == 1 << 13


def test_figures_from_model_codes() -> None:
    """The same figures from the model's codes (the RTL test feeds the RTL's codes)."""
    cfg = cm.CommutationConfig()
    codes, sweeps = {}, {}
    for mode in (cm.SINE, cm.SIX_STEP):
        sw, fr = cm.sweep_frames(cfg, mode)
        sweeps[mode], codes[mode] = sw, cm.commutate(fr, cfg)
    fig = cm.figures(cfg, codes, sweeps)
    assert abs(fig["six_step_ripple"] - 0.13397) < 2e-4
    assert fig["sine_ripple"] <= 0.003
    assert round(fig["mean_ratio"], 3) == 0.907


def test_phase_error_shows_up_in_ripple() -> None:
    """The sine ripple check can fail: a channel b placed 1 code further off (342) exceeds it."""
    cfg = cm.CommutationConfig()
    sw, fr = cm.sweep_frames(cfg, cm.SINE)
    c = cm.commutate(fr, cfg)
    k_a = (sw.pos * 2 % (1 << 20)) >> 10
    lut = cm.unfold(np.arange(1024), cm.quarter_table(cfg.rom), 8)
    b_bad = cm.scale(lut[(k_a - 342) % 1024], 32767, cfg)
    good = cm.torque_curve(c[:, 0], c[:, 1], sw, cfg)
    bad = cm.torque_curve(c[:, 0], b_bad, sw, cfg)
    assert float(good["ripple"]) <= 0.003 < float(bad["ripple"])


def test_commutator_latch_ram() -> None:
    """LATCH_RAM = 1 (the HX8K build: the frame-latched torques and limits in block RAM, read at
    stage C) with the shift-add multiplier, Icarus: random inputs changed mid-frame, every code
    bit-exact against the same model, and the safety paths."""
    cfg = CONFIGS["c12m5_serial"]
    sim.run_cocotb(blocks.get("commutator"), "icarus", "cocotb_commutator", HERE,
                   params=cfg.rtl_params() | {"LATCH_RAM": 1},
                   testcase=["random_bit_exact", "safety_paths"],
                   extra_env={"HG_MODEL": json.dumps(cfg.to_json()), "HG_FRAMES": "100"})
