"""The saboteur netlist in the closed loop (hapgate.flows.saboteur, tb/native/device/
fault_inject.h, hapgate.device.seu): with its injection ports at zero it is the design, record
for record; injections into known registers are classified as the budgets say; the harnesses
refuse an injection they cannot make; the campaign runs as a sweep, cached."""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np
import pytest
from hapgate.base.paths import ROOT
from hapgate.commands import seu as seu_cmd
from hapgate.commands import sweep as sweep_cmd
from hapgate.device import runner, seu
from hapgate.device.harness import DeviceError
from hapgate.device.scene import load as load_scene

AT = 5e-3                   # injection time, scene s
FRAME = 16e-6
TICK = 1e-3                 # the scene's 1 kHz servo


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory) -> Path:
    """scenes/seu/rest.toml, 15 ms."""
    text = (ROOT / "scenes" / "seu" / "rest.toml").read_text()
    assert "duration_s = 0.04" in text
    f = tmp_path_factory.mktemp("seu") / "rest15.toml"
    f.write_text(text.replace("duration_s = 0.04", "duration_s = 0.015"))
    return f


@pytest.fixture(scope="module")
def setup(scene_file):
    return seu.setup(scene_file)


def test_saboteur_without_injection_is_the_rtl(setup):
    """Every frame, servo tick and DAC load of the saboteur build with its ports at zero equals
    the RTL build's (the virtual device's default, with its stage clocks) bit for bit."""
    sc, design, _clk = setup
    a = runner.simulate(sc, saboteur=design, gate=False)
    b = runner.simulate(sc)
    assert a.loads.size > 1000 and a.ticks.size > 10
    for k in ("frames", "ticks", "loads"):
        assert getattr(a, k).tobytes() == getattr(b, k).tobytes(), k
    assert a.summary["fi_done"] == "0" and int(a.summary["fi_sites"]) == design.port_bits


def run(scene_file, setup, site: str, mode: str, frames: int = 0) -> dict:
    _sc, design, _clk = setup
    rec, ref, tr = seu.run_one(scene_file, seu.injection(design, site, mode, AT, frames))
    rec["_tr"], rec["_ref"] = tr, ref
    return rec


def test_stuck_torque_bit_is_a_silent_violation(scene_file, setup):
    """AXIS1.TORQUE bit 14 (16384 of 32767: 0.24 N m) stuck at 1 for 32 frames: the firmware
    neither reads the torque back nor sees it, the commutator latches it at the next frame."""
    r = run(scene_file, setup, "u_bus.u_regs.torque_q[30]", "stuck1", 32)
    assert r["class"] == "silent" and r["dangerous"] and not r["latched"]
    assert r["max_dev_nm"] > 0.1
    assert AT <= r["t_violation_s"] <= AT + 6 * FRAME
    tr, ref = r["_tr"], r["_ref"]
    before = tr.t < AT
    assert np.array_equal(tr.tau[before], ref.tau[before])       # nothing before it


def test_stuck_dac_word_is_a_silent_violation(scene_file, setup):
    """The DAC data pins' register, bit 12 (4096 of 8191: half the amplifier's 8 A) stuck at 1
    for 8 frames: every channel's load in those frames carries it."""
    r = run(scene_file, setup, "dac_data[12]", "stuck1", 8)
    assert r["class"] == "silent" and r["max_dev_nm"] > 0.05


def test_upset_of_a_torque_bit_lasts_until_the_next_write(scene_file, setup):
    r = run(scene_file, setup, "u_bus.u_regs.torque_q[28]", "flip")     # bit 12: 0.06 N m
    assert r["class"] == "silent"
    tr, ref = r["_tr"], r["_ref"]
    # the firmware writes every torque at each tick: a tick, the load and the amplifier's
    # lag (5 time constants of 80 us) after the upset the torque is back within the budget
    # (the firmware's own, a little off the reference's: the handle took the impulse)
    late = tr.t > AT + TICK + 0.5e-3
    assert np.abs(tr.tau[late] - ref.tau[late]).max() < seu.BUDGET_DEV_NM
    assert r["max_dev_nm"] > 0.03


def test_sticky_fault_bit_is_detected(scene_file, setup):
    """Axis 0's sticky overspeed flag held at 1 for one frame: it stays (sticky), the axis
    fault zeroes the DACs, the firmware latches AXIS_FAULT and drives zero."""
    r = run(scene_file, setup, "u_interp.g_axis[0].u_axis.flags[0]", "stuck1", 1)
    assert r["class"] == "detected" and r["latched"] and r["safe"]
    assert r["fw_err"] == 2 and r["status_new"] & 1                  # AXIS_FAULT, STATUS.FAULT0
    assert r["t_zero_s"] <= r["t_latch_s"] + seu.REACT_S


def test_unused_register_is_masked_and_identical(scene_file, setup):
    r = run(scene_file, setup, "u_bus.u_regs.scratch_q[5]", "flip")
    assert r["class"] == "masked" and r["identical"]


def test_the_harnesses_refuse_what_they_cannot_inject(setup):
    sc, design, _clk = setup
    with pytest.raises(DeviceError, match="needs the saboteur build"):
        runner.simulate(sc, extra="fault = 0.005 seu 3\n")
    for line, why in (("fault = 0.005 stuck 3 1\n", "SITE VALUE FRAMES"),
                      (f"fault = 0.005 seu {design.port_bits}\n", "site"),
                      ("fault = 0.005 stuck 3 2 4\n", "value 0 or 1"),
                      ("fault = 0.005 seu 3\nfault = 0.006 seu 4\n", "one seu or stuck")):
        with pytest.raises(DeviceError, match=why):
            runner.simulate(sc, saboteur=design, gate=False, extra=line)


def test_replay_refuses_a_bad_site(scene_file, capsys):
    args = argparse.Namespace(scene=scene_file, site="nope[0]", mode="flip", at_s=AT, frames=0,
                              out=None)
    assert seu_cmd.cmd_run(args) == 2
    assert "no flip-flop site 'nope[0]'" in capsys.readouterr().err
    args.site, args.mode = "dac_data[0]", "stuck0"                     # a stuck-at needs frames
    assert seu_cmd.cmd_run(args) == 2


def test_campaign_sweep_runs_and_resumes(tmp_path, capsys):
    """`hapgate sweep scenes/sweeps/seu.toml --limit 3` on two workers: every job classified,
    the tables written; the second run comes from the cache."""
    spec = ROOT / "scenes" / "sweeps" / "seu.toml"
    args = argparse.Namespace(spec=spec, scheduler=None, workers=2, out=tmp_path, no_cache=False,
                              limit=3, compare=[])
    assert sweep_cmd.main(args) == 0
    rows = list(csv.DictReader((tmp_path / "results.csv").open()))
    assert len(rows) == 3 and {r["class"] for r in rows} <= set(seu.CLASSES)
    assert all(r["replay"].startswith("hapgate seu run scenes/seu/rest.toml --site ") for r in rows)
    assert (tmp_path / "seu_blocks.csv").exists() and (tmp_path / "seu_worst.csv").exists()
    capsys.readouterr()
    assert sweep_cmd.main(args) == 0
    assert "3 jobs (3 from the cache" in capsys.readouterr().out
    assert load_scene(spec.parent / "../seu/rest.toml").run.duration_s == 0.04
