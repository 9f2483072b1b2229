"""The simulation-only stage clocks (HG_SIM_GATE, tb/native/device/README.md "Stage clocks")
against the same top with every register on clk, under a random stimulus the firmware never
produces (tb/native/device/gate_equiv.cpp): every output pin after every clock edge is the same.

The closed-loop check (test_closed_loop.test_stage_clocks_change_nothing) runs the firmware's own
traffic; this one reaches what it never does — unmapped accesses, dropped and doubled strobes,
configuration errors, FAULT_CLR while a fault is live, SNAP, HOME_ARM, IRQ acknowledges — at two
clocks and two axis masks. The stimulus is checked to have done what it claims (loads with
non-zero codes, interrupts, reads that returned data, ready and output-enable), so a stimulus
gone quiet cannot pass for an equivalence."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest
from hapgate.device import runner

OUT_DT = np.dtype([("bus_data_out", "<u4"), ("dac_data", "<u2"), ("dac_addr", "u1"),
                   ("dac_wr_n", "u1"), ("irq", "u1"), ("bus_data_oe", "u1"),
                   ("bus_ready", "u1"), ("pad", "u1")])
CLOCKS = 1_000_000


def _run(clk_hz: int, mask: int, gate: bool, seed: int, tmp_path) -> np.ndarray:
    exe = runner.build_gate_equiv(clk_hz, mask, gate)
    out = tmp_path / f"out-{int(gate)}-{seed}.bin"
    res = subprocess.run([str(exe), str(seed), str(CLOCKS), str(out)], capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert f"out_bytes={OUT_DT.itemsize}" in res.stdout, res.stdout
    return np.fromfile(out, dtype=OUT_DT)


@pytest.mark.parametrize("clk_hz, mask", [(6_000_000, 7), (24_000_000, 5)])
def test_stage_clocks_equal_the_clk_build_on_random_stimulus(clk_hz, mask, tmp_path):
    for seed in (1, 2):
        gated = _run(clk_hz, mask, True, seed, tmp_path)
        plain = _run(clk_hz, mask, False, seed, tmp_path)
        assert gated.size == plain.size == CLOCKS
        diff = np.flatnonzero(gated != plain)
        assert diff.size == 0, (f"seed {seed}: first difference after clock {diff[0]}: "
                                f"gated {gated[diff[0]]}, clk {plain[diff[0]]}")
        # the stimulus did what the module docstring says
        wr = gated["dac_wr_n"].astype(int)
        loads = np.flatnonzero((wr[1:] == 1) & (wr[:-1] == 0)) + 1
        codes = gated["dac_data"][loads].astype(int)
        codes[codes >= 8192] -= 16384
        assert loads.size > 10_000 and np.count_nonzero(codes) > 500, (loads.size, codes)
        irq = gated["irq"].astype(int)
        assert np.count_nonzero((irq[1:] == 1) & (irq[:-1] == 0)) >= 3
        assert np.unique(gated["bus_data_out"]).size > 50
        assert gated["bus_ready"].sum() > 1000 and gated["bus_data_oe"].sum() > 1000
