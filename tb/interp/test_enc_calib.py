"""Online calibration (rtl/interp/enc_calib.v inside enc_interp, CAL = 1) on both simulators via
cocotb: bit-exact against the model on every sample with calibration on, off and frozen.
Long runs, error against truth, convergence, freeze and robustness: test_calib_native.py."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import pytest
from hapgate.flows import blocks
from hapgate.golden import interp
from hapgate.runners import sim

HERE = Path(__file__).parent
SAMPLES = {"verilator": 5000, "icarus": 2000}


@pytest.mark.parametrize("simulator", sim.simulators())
def test_calibration_bit_exact(simulator: str) -> None:
    # one line per block, so a short run updates the state a few hundred times
    cfg = interp.InterpConfig(cal=True, cal_lines_log2=0)
    sim.run_cocotb(blocks.get("enc_interp"), simulator, "cocotb_enc_calib", HERE,
                   params=cfg.rtl_params(),
                   testcase=["calibration_bit_exact", "calibration_bit_exact_with_gaps"],
                   extra_env={"HG_MODEL": json.dumps(asdict(cfg)),
                              "HG_SAMPLES": str(SAMPLES[simulator])})
