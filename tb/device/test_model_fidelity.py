"""The virtual device at model fidelity (tb/native/device/model_harness.cpp, hapgate.device.model):
the golden models at transaction level in the gateware's place, against the Verilated gateware on
the short scene. Bounds are derived in each docstring (README "Model fidelity"); times are
simulated. One model build per session (cached), the RTL build is the one test_closed_loop uses."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hapgate.base.paths import ROOT
from hapgate.commands.cli import main as cli_main
from hapgate.device import model, runner
from hapgate.device import scene as sc
from hapgate.flows import regmap
from hapgate.golden import kinematics

SCENES = ROOT / "scenes"
COUNTS_PER_RAD = (1 << 20) / (2 * math.pi)
TORQUE_FS_NM = 0.48          # the firmware's torque code full scale: 8 A x 0.06 N m/A
DAC_FS = 8191


def _short(**changes: object) -> sc.Scene:
    return sc.load(SCENES / "short.toml").override(changes)


@pytest.fixture(scope="module")
def pair() -> tuple[runner.Raw, runner.Raw, runner.Raw, sc.Scene]:
    """The short scene once at rtl fidelity, once at model fidelity with the 1 us plant, once with
    the default multirate plant."""
    s = _short()
    m = s.override({"run.fidelity": "model"})
    return runner.simulate(s), model.simulate(m, mech_us=1), model.simulate(m), s



def assert_same_run(rtl: runner.Raw, mdl: runner.Raw, min_frames: int) -> None:
    """Every frame, tick and load record of the two runs equal, field by field, but for the one
    documented difference (tb/native/device/README.md, "Model fidelity": index crossings after
    the release are not tracked): the RTL's sticky STATUS.INDEX of axis 1, which sets from the
    tick after the short scene's hand moves beta across its index (0.25 deg below the start
    pose), and which the model leaves as it was at the release. Every other STATUS bit equal."""
    assert rtl.frames.size == mdl.frames.size > min_frames
    for name in runner.FRAME_DT.names:
        assert np.array_equal(rtl.frames[name], mdl.frames[name]), name
    assert rtl.ticks.size == mdl.ticks.size >= 20
    for name in runner.TICK_DT.names:
        if name != "status":
            assert np.array_equal(rtl.ticks[name], mdl.ticks[name]), name
    f = regmap.load().by_name()["STATUS"].field("INDEX")
    index = np.uint32(((1 << f.width) - 1) << f.lsb)
    rs, ms = rtl.ticks["status"], mdl.ticks["status"]
    assert np.array_equal(rs & ~index, ms & ~index)
    assert not (ms & index).any()                            # never crossed before the release
    seen = (rs & index) == np.uint32(1 << (f.lsb + 1))       # axis 1's bit alone, sticky
    assert seen.any() and seen[np.argmax(seen):].all() and not (rs[~seen] & index).any()
    q_index = runner.start_pose(_short())[1] - np.deg2rad(0.25)
    first = int(np.argmax(seen))                             # at the index: within one line
    assert first > 0 and abs(rtl.ticks["q_true"][first, 1] - q_index) <= 2 * np.pi / 1024
    assert np.array_equal(rtl.loads, mdl.loads)

def test_model_with_the_1us_plant_is_bit_identical_to_the_rtl(pair):
    """Same plant path (1 us): every frame (q, p, F_hand, tau, currents, the six DAC codes), every
    firmware tick and every DAC load (edge, channel, code) equal bit for bit: the register file,
    the servo tick, the snapshot timing, the interpolator's positions and velocities, the
    commutator's sine table and arithmetic and the output stage are exact at the grid's timing."""
    rtl, mdl, _, _ = pair
    assert_same_run(rtl, mdl, 1000)
    assert np.abs(mdl.frames["dac"]).max() > 100            # it was driving
    for k in ("fw_err", "last_key_edge", "clocks", "enabled_t"):
        assert rtl.summary[k] == mdl.summary[k], k


def test_multirate_model_stays_within_its_bound(pair):
    """The multirate plant (mechanics every 16 us with the amplifier's mean current, the true
    angle linear within a step) lags the 1 us integration by at most one step: joint angles within
    M = dt_mech * max|qd| (the whole step, twice the half-step lag of a first-order scheme, for
    the current-loop prediction). A DAC code then differs through (a) the angle code (bits 18..9
    of the position: ceil(M / 512) + 1 codes of 2 pi / 1024 on the frame's amplitude) and (b) the
    firmware's torque, which the wall makes k * |J|^2 * M / COUNTS_PER_RAD N m (8191 codes per
    0.48 N m), plus 1 for rounding."""
    rtl, _, mdl, s = pair
    fr, fm = rtl.frames, mdl.frames
    assert fr.size == fm.size
    qd = np.abs(np.diff(fr["q"], axis=0)).max() / 16e-6
    m_counts = model.MECH_US * 1e-6 * qd * COUNTS_PER_RAD
    dq = np.abs(fr["q"] - fm["q"]).max() * COUNTS_PER_RAD
    assert dq <= m_counts, (dq, m_counts)
    amp = np.abs(fr["dac"]).max()
    jn = np.linalg.norm(kinematics.jacobian(s.q0_rad), 2)
    torque_codes = s.env.k * jn * jn * m_counts / COUNTS_PER_RAD * DAC_FS / TORQUE_FS_NM
    bound = amp * 2 * math.pi / 1024 * (math.ceil(m_counts / 512) + 1) + torque_codes + 1
    ddac = np.abs(fr["dac"].astype(int) - fm["dac"].astype(int)).max()
    assert ddac <= bound, (ddac, bound)
    assert mdl.summary["fw_err"] == "0" and np.abs(fm["dac"]).max() > 100


def test_model_at_48_mhz_takes_the_dac_schedule_and_matches_the_rtl():
    """At the shipped 48 MHz the DAC's t_WCS lengthens the write strobe (3 clocks instead of 1)
    and every load moves to 11 clocks after its slot start (9 up to 20 MHz): the model takes the
    schedule from the run's configuration (golden.top.TopConfig, as runner.build's
    HG_LOAD_CLOCKS). With the 1 us plant and every axis built it is bit-identical to the
    gateware's full 48 MHz build (the one test_closed_loop's skip test uses: cached): every
    frame, tick and DAC load (edge, channel, code). The multirate model gives the same frames
    and ticks at 48 MHz as at 6 MHz (its events keep their order at any clock, README)."""
    s = _short(**{"run.duration_s": 0.012})
    rtl = runner.simulate(s, clk_hz=runner.FULL_CLK_HZ, mask=7)
    m = s.override({"run.fidelity": "model"})
    mdl = model.simulate(m, clk_hz=runner.FULL_CLK_HZ, mask=7, mech_us=1)
    d = runner.FULL_CLK_HZ // 1_000_000
    offsets = (mdl.loads["edge"] - mdl.loads["ch"] * 2 * d) % (16 * d)
    assert set(offsets.tolist()) == {11}                      # not the 9 clocks of <= 20 MHz
    assert_same_run(rtl, mdl, 700)
    assert np.abs(mdl.frames["dac"]).max() > 100
    for k in ("fw_err", "last_key_edge", "clocks", "enabled_t"):
        assert rtl.summary[k] == mdl.summary[k], k
    fast, low = (model.simulate(m, clk_hz=c, mask=7)
                 for c in (runner.FULL_CLK_HZ, runner.MIN_CLK_HZ))
    for name in runner.FRAME_DT.names:
        assert np.array_equal(fast.frames[name], low.frames[name]), name
    for name in runner.TICK_DT.names:
        assert np.array_equal(fast.ticks[name], low.ticks[name]), name


def test_wall_law_at_model_fidelity_within_the_rtl_budget():
    """The wall test of test_closed_loop at model fidelity: its steady-state force against
    k * depth within the same budget as the gateware's (the budget's derivation is there)."""
    from test_closed_loop import _wall_budget
    s = _short(**{"run.duration_s": 0.04, "run.fidelity": "model"})
    r = runner.run(s)
    assert r.fidelity == "model" and any("golden models" in b for b in r.built)
    assert np.linalg.norm(r.arrays["f_hand"][-1]) > 0.3
    assert r.metrics["force_samples"] > 1000
    budget = _wall_budget(s, 1.2, r.metrics["force_speed_max"])
    assert r.metrics["force_error_n"] <= budget, (r.metrics, budget)
    assert r.metrics["fw_error"] == "NONE"


@pytest.mark.parametrize("kind, axis, err", [("dropout", 1, "AXIS_FAULT"),
                                             ("watchdog", None, "WATCHDOG"),
                                             ("hang", None, "OVERRUN")])
def test_fault_means_zero_torque_at_model_fidelity(kind, axis, err):
    """The fault scenes at model fidelity: every affected channel zero within one frame (16 us)
    plus the load pipeline (9 clocks) of the cause, and the firmware latches the same error as on
    the gateware (test_closed_loop)."""
    fault = {"at_s": 0.01, "kind": kind} | ({"axis": axis} if axis is not None else {})
    dur = 0.016 if kind == "dropout" else 0.025 if kind == "watchdog" else 0.03
    r = runner.run(_short(**{"run.duration_s": dur, "fault": [fault], "run.fidelity": "model"}))
    assert len(r.events) == 1
    ev = r.events[0]
    assert 0 <= ev["reaction_us"] <= 16.0 + 10 / r.clk_hz * 1e6, ev
    assert r.metrics["fw_error"] == err
    t = r.arrays["t"]
    assert np.abs(r.arrays["dac"][(t > 0.009) & (t < 0.0099)]).max() > 50


def test_unsupported_combinations_exit_2(tmp_path, capsys):
    """A waveform or the ADC record at model fidelity: refused, naming the file and key, exit 2,
    nothing written."""
    src = (SCENES / "short.toml").read_text()
    rec = 'record = ["q", "p", "f_hand", "tau", "dac"]'
    assert rec in src
    traced = src.replace("[run]\n", '[run]\nfidelity = "model"\ntrace = true\n')
    adc = src.replace(rec, 'fidelity = "model"\nrecord = ["q", "adc"]')
    for text, key in ((traced, "run.trace"), (adc, "run.record")):
        bad = tmp_path / "bad.toml"
        bad.write_text(text)
        out = tmp_path / "out"
        assert cli_main(["scene", "run", str(bad), "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert str(bad) in err and key in err, err
        assert not out.exists() or not any(out.iterdir())


def test_fault_kinds_are_named_in_the_run_configuration(tmp_path):
    """The harnesses read a fault's kind by the scene's name (harness_common.h kFaultKinds): a
    named kind runs and takes effect, an unknown name or a number is refused with exit 2,
    naming the file and the key, before anything is written."""
    import subprocess

    from hapgate.device import harness

    s = _short()
    q0 = harness.start_pose(s)
    exe = model.build()
    base = model.run_config(s, q0, harness.choose_clock(s), harness.axis_mask(s), model.MECH_US)
    assert "\nfault = " not in base
    (tmp_path / "plant.cfg").write_text(harness.plant_config(s, q0))
    results = {}
    for line in ("fault = 0.002 watchdog 0", "fault = 0.002 meltdown 0", "fault = 0.002 3 0"):
        out = tmp_path / line.split()[3]
        out.mkdir()
        (out / "run.cfg").write_text(base + line + "\n")
        p = subprocess.run([str(exe), str(tmp_path / "plant.cfg"), str(out / "run.cfg"), str(out)],
                           capture_output=True, text=True, timeout=120)
        results[line.split()[3]] = (p, sorted(x.name for x in out.iterdir()))
    ok, files = results["watchdog"]
    assert ok.returncode == 0, ok.stderr
    assert "fw_err=6 " in ok.stdout                   # HG_ERR_WATCHDOG: the key writes were lost
    for name in ("meltdown", "3"):
        p, files = results[name]
        assert p.returncode == 2
        assert str(tmp_path / name / "run.cfg") in p.stderr and "fault: unknown kind" in p.stderr
        assert files == ["run.cfg"]
