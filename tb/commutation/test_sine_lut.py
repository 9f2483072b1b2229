"""Sine ROM (rtl/commutation/sine_lut.v): bit-exact vs the model and error vs float sin, both
simulators; plus model-level checks that a wrong table cannot pass."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest
from hapgate.base import tables
from hapgate.flows import blocks
from hapgate.golden import sine
from hapgate.runners import sim

HERE = Path(__file__).parent
CONFIGS = [sine.SineRomConfig(), sine.SineRomConfig(addr_bits=6, fs=2047)]


@pytest.mark.parametrize("simulator", sim.simulators())
@pytest.mark.parametrize("cfg", CONFIGS, ids=lambda c: c.name)
def test_sine_lut_rtl(simulator: str, cfg: sine.SineRomConfig) -> None:
    block = blocks.get("sine_lut")
    sim.run_cocotb(block, simulator, "cocotb_sine_lut", HERE,
                   params=sine.rtl_params(cfg),
                   extra_env={"HG_MODEL": json.dumps(asdict(cfg))})


@pytest.mark.parametrize("cfg", CONFIGS, ids=lambda c: c.name)
def test_model_error_within_budget(cfg: sine.SineRomConfig) -> None:
    codes = np.arange(4 * cfg.entries)
    err = sine.error_vs_truth(sine.sine_model(codes, cfg), cfg)
    assert np.abs(err).max() <= sine.ERROR_BUDGET_LSB
    # symmetry the unfolding promises: s(k + N*2) = -s(k), s(2N - 1 - k) = s(k)
    s = sine.sine_model(codes, cfg)
    n2 = 2 * cfg.entries
    assert np.array_equal(s[n2:], -s[:n2])
    assert np.array_equal(s[:n2][::-1], s[:n2])


def test_rom_file_is_the_generators_table(tmp_path: Path) -> None:
    cfg = sine.SineRomConfig()
    path = sine.write_rom(cfg, tmp_path)
    assert np.array_equal(tables.read_hex(path, cfg.mag_bits), sine.quarter_table(cfg))
    assert len(path.read_text().split()) == 256


@pytest.mark.parametrize("delta", [+1, -1])
def test_corrupted_entry_is_caught_by_truth_check(delta: int) -> None:
    """A table generated wrong is identical in RTL and model, so only the truth check sees it:
    corrupt one entry and the error budget must be exceeded."""
    cfg = sine.SineRomConfig()
    table = sine.quarter_table(cfg).copy()
    table[137] += delta
    codes = np.arange(4 * cfg.entries)
    err = sine.error_vs_truth(sine.unfold(codes, table, cfg.addr_bits), cfg)
    assert np.abs(err).max() > sine.ERROR_BUDGET_LSB
