"""The calibration over the PC link (issue 26): hapgate.host's set_calib / get_calib against
the firmware itself (dsp-fw's link-pipe on a pty), the torque gating an uncalibrated axis
brings (NAK_UNCALIBRATED), and the calibration words' codec (hapgate.golden.calib)."""

from __future__ import annotations

import os
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from hapgate.golden import calib, pclink
from hapgate.host import Device, Refused

ROOT = Path(__file__).resolve().parents[2]
FW = ROOT / "dsp-fw"
BUILD = ROOT / "build" / "dsp-fw"
PIPE = BUILD / "link-pipe"


@pytest.fixture
def dev() -> Iterator[Device]:
    r = subprocess.run(["make", "-s", "-C", str(FW), f"BUILD={BUILD}", "link-pipe"],
                       check=False, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    master, slave = os.openpty()
    proc = subprocess.Popen([PIPE], stdin=master, stdout=master)
    os.close(master)
    try:
        d = Device.open(os.ttyname(slave), timeout=2.0)
        yield d
        d.port.close()
    finally:
        proc.kill()
        proc.wait()
        os.close(slave)


def test_set_calib_round_trip_and_gating(dev: Device) -> None:
    # every field, each axis a different error; what the firmware holds comes back
    sent = [calib.AxisCalib(-123456, 90.0, False, 1, 2, dir_confirmed=True),
            calib.AxisCalib(77, -45.0, True, 1, 2),
            calib.AxisCalib(5000, 170.0, False, -1, 2)]
    for ax, c in enumerate(sent):
        dev.set_calib(ax, c)
    for ax, c in enumerate(sent):
        got = dev.get_calib(ax)
        assert got.words() == c.words()
        assert (got.index_to_zero_counts, got.phases_swapped, got.encoder_dir, got.pole_pairs,
                got.dir_confirmed, got.homed, got.aligned) == \
            (c.index_to_zero_counts, c.phases_swapped, c.encoder_dir, 2, c.dir_confirmed,
             True, True)
        assert got.comm_offset_elec_deg == pytest.approx(c.comm_offset_elec_deg,
                                                         abs=360 / 1024 / 2)
    # calibrated: enable works; a calibration while enabled is refused
    dev.enable()
    with pytest.raises(Refused) as r:
        dev.set_calib(0, sent[0])
    assert (r.value.request, r.value.reason) == (pclink.SET_CALIB, pclink.NAK_ENABLED)
    dev.disable()
    # a pole-pair count the FPGA does not have: refused, nothing changes
    with pytest.raises(Refused) as r:
        dev.set_calib(2, calib.AxisCalib(0, 0.0, False, 1, 3))
    assert r.value.reason == pclink.NAK_RANGE
    assert dev.get_calib(2).words() == sent[2].words()
    # axis 1 not aligned: ENABLE and forces refused with NAK_UNCALIBRATED
    dev.set_calib(1, calib.AxisCalib(77, 0.0, False, 1, 0, aligned=False))
    assert not dev.get_calib(1).aligned
    with pytest.raises(Refused) as r:
        dev.enable()
    assert (r.value.request, r.value.reason) == (pclink.ENABLE, pclink.NAK_UNCALIBRATED)
    dev.set_force((0.5, 0.0, 0.0), ttl_ms=50)       # no reply: its NAK surfaces later
    st = dev.state()
    with pytest.raises(Refused) as r:
        dev.set_force((0.5, 0.0, 0.0), ttl_ms=50)
    assert (r.value.request, r.value.reason) == (pclink.FORCE, pclink.NAK_UNCALIBRATED)
    assert not st.enabled and not st.pc_force_live


@pytest.mark.parametrize("swapped", [False, True])
@pytest.mark.parametrize("enc_dir", [1, -1])
def test_offset_code_conventions(swapped: bool, enc_dir: int) -> None:
    """The OFFSET code: for the plain axis it is c itself; swapped phases mirror it and add
    -60 deg (winding 0 sees the field at -te - 60 deg); a reversed encoder adds the quarter
    line's pole_pairs * 256 / 2^20 of a cycle (0.5 code at 2 pole pairs). from_words inverts."""
    for c in (-180.0, -91.3, 0.0, 11.25, 90.0, 179.0):
        a = calib.AxisCalib(0, c, swapped, enc_dir, 2)
        sigma = -1 if swapped else 1
        quarter_line = 2 * 256 / 2**20 * 360 if enc_dir == -1 else 0.0   # deg electrical
        extra = (-60.0 if swapped else 0.0) - enc_dir * sigma * quarter_line
        assert a.offset_code() == round((sigma * c + extra) / 360 * 1024) % 1024
        back = calib.from_words(a.words()).comm_offset_elec_deg
        assert abs((back - c + 180) % 360 - 180) <= 360 / 1024 / 2 + 1e-9
    assert calib.AxisCalib(0, 11.25, False, 1, 2).offset_code() == 32
    assert calib.AxisCalib(0, 0.0, True, 1, 2).offset_code() == 853    # -60 deg
