"""The integrity alarms of the `hardened` configuration (rtl/top/README.md, "Integrity alarms"),
one targeted injection each into exactly the flip-flops a countermeasure protects (the saboteur
netlist's site names): in `hardened` the alarm latches its HW_FAULT cause, the FPGA zeroes every
DAC channel within the stated bound and the firmware latches HG_ERR_FPGA_FAULT with the cause; the
same injection in `paper` raises no such alarm (so each test can fail). Plus: a fault-free run of
`hardened` loads the same DAC words at the same clocks as `paper`."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hapgate.base.paths import ROOT
from hapgate.device import runner, seu

AT = 5e-3                   # injection time, scene s
FRAME = 16e-6               # the DAC frame (the spec's 16 us)
ERR_FPGA_FAULT = 9          # dsp-fw/include/hg_servo.h
CAUSE = {"REGS": 1, "COMM": 2, "DAC": 4, "TICK": 8, "POS": 16}   # HW_FAULT bits (hapgate.rdl)


def _scene(tmp: Path, name: str, config: str) -> Path:
    """scenes/seu/rest.toml, 15 ms, on the named configuration."""
    text = (ROOT / "scenes" / "seu" / "rest.toml").read_text()
    assert "duration_s = 0.04" in text and "[run]\n" in text
    f = tmp / f"{name}.toml"
    f.write_text(text.replace("duration_s = 0.04", "duration_s = 0.015")
                 .replace("[run]\n", f'[run]\nconfig = "{config}"\n'))
    return f


@pytest.fixture(scope="module")
def scenes(tmp_path_factory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("seu_hardened")
    return {c: _scene(tmp, f"rest15_{c}", c) for c in ("paper", "hardened")}


def inject(scene: Path, site: str, mode: str, frames: int = 0) -> tuple[dict, np.ndarray]:
    """One injection: its classification and the firmware's error axis byte per tick."""
    sc, design, _clk = seu.setup(scene)
    inj = seu.injection(design, site, mode, AT, frames)
    ref = seu.reference(sc, design)
    raw = runner.simulate(sc, gate=False, saboteur=design, extra=inj.cfg_line(design),
                          timeout_s=seu.RUN_TIMEOUT_S)
    rec = seu.classify(ref, seu.Trace.of(raw), AT, int(sc.run.servo_hz))
    return rec, raw.ticks["err_axis"][raw.ticks["err"] == ERR_FPGA_FAULT]


# (cause, site, mode, frames, bound on the zero after AT, s): the bound is the output stage's
# FRAME + WR + 1 clocks after the alarm (rtl/top/README.md), the alarm one clock after the
# check fails: at AT for a checked register; COMM: at the corrupted word's load, within a frame;
# DAC (stuck): the pins carry the stuck bit until it is released, FRAMES frames after AT
CASES = [
    ("REGS", "u_bus.u_regs.torque_q[30]", "stuck1", 32, FRAME + 1e-6),
    ("COMM", "u_comm.tq_q[30]", "flip", 0, 2 * FRAME + 1e-6),
    ("DAC", "dac_data[12]", "stuck1", 8, 9 * FRAME + 1e-6),
    ("TICK", "u_bus.u_regs.tick_cnt[20]", "flip", 0, FRAME + 1e-6),
    ("POS", "u_interp.g_axis[1].u_axis.qc[2]", "flip", 0, FRAME + 1e-6),
]


@pytest.mark.parametrize(("cause", "site", "mode", "frames", "bound"), CASES,
                         ids=[c[0] for c in CASES])
def test_alarm_fires_latches_and_zeroes(scenes, cause, site, mode, frames, bound):
    rec, eax = inject(scenes["hardened"], site, mode, frames)
    assert rec["class"] == "detected", rec
    assert rec["fw_err"] == ERR_FPGA_FAULT and rec["status_new"] & 0x10000   # STATUS.HW_FAULT
    assert eax.size and int(eax[0]) & CAUSE[cause], eax[:3]
    assert AT <= rec["t_zero_s"] <= AT + bound
    # the same fault in the paper's design: no integrity alarm
    rec_p, eax_p = inject(scenes["paper"], site, mode, frames)
    assert eax_p.size == 0 and rec_p["fw_err"] != ERR_FPGA_FAULT
    assert rec_p["class"] != "detected", rec_p


def test_hardened_loads_the_papers_dac_words(scenes):
    """Without a fault the countermeasures change no output: every DAC load (clock, channel,
    word), frame and servo tick of `hardened` equals `paper`'s on the resting-hand scene."""
    a = runner.simulate(seu.setup(scenes["paper"])[0])
    b = runner.simulate(seu.setup(scenes["hardened"])[0])
    assert a.loads.size > 1000 and a.ticks.size > 10
    for k in ("frames", "ticks", "loads"):
        assert getattr(a, k).tobytes() == getattr(b, k).tobytes(), k


ERR_AXIS_FAULT = 2          # dsp-fw/include/hg_servo.h


def test_a_reported_axis_fault_holds_until_cleared(scenes):
    """SEC_REGS's fault hold (rtl/top/hapgate_top.v, g_fault_hold): the interpolator's reported
    fault copy m_faults stuck at 1 for 20 frames (the interpolator's own sticky flag never set).
    In `hardened` the axis stays at zero torque and STATUS.FAULT holds, so the firmware latches
    HG_ERR_AXIS_FAULT at its next tick and zeroes every axis within seu.REACT_S of it: detected.
    In `paper` the axis drops to zero for the 20 frames and steps back with nothing latched: a
    silent violation."""
    site = "u_interp.g_axis[1].u_axis.m_faults[2]"
    rec, _ = inject(scenes["hardened"], site, "stuck1", 20)
    assert rec["class"] == "detected" and rec["fw_err"] == ERR_AXIS_FAULT, rec
    assert AT <= rec["t_zero_s"] <= AT + 1e-3 + seu.REACT_S     # the next 1 kHz tick
    rec_p, _ = inject(scenes["paper"], site, "stuck1", 20)
    assert rec_p["class"] == "silent" and rec_p["fw_err"] != ERR_AXIS_FAULT, rec_p
