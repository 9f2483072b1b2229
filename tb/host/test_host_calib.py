"""The calibration over a real pty (issue 26): the virtual device serving scenes/unaligned.toml
(its firmware uncalibrated) refuses ENABLE and forces with NAK_UNCALIBRATED until the host
sends each axis its calibration (set_calib, here the plant's own values), then renders."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from hapgate.base.paths import ROOT
from hapgate.commands.device import Server
from hapgate.device import scene as sc
from hapgate.golden import pclink
from hapgate.host import Device, Refused, Scene

OPEN_S = 120.0           # the first open may wait for the harness build
UNALIGNED = ROOT / "scenes" / "unaligned.toml"


@pytest.fixture
def served() -> Iterator[Server]:
    # axis 1 simulated (its amplifier phases swapped), 0 and 2 held
    with Server(scene=sc.load(UNALIGNED), axes=(1,), pace="free") as srv:
        yield srv


def test_uncalibrated_device_refuses_until_set_calib(served: Server) -> None:
    with Device.open(served.port, timeout=5.0, open_timeout=OPEN_S) as dev:
        assert not any(dev.get_calib(i).homed or dev.get_calib(i).aligned for i in range(3))
        dev.set_scene(Scene.SPRING, p0=(-0.002, 0.0732, 0.0011), k=1000.0)
        with pytest.raises(Refused) as r:
            dev.enable()
        assert (r.value.request, r.value.reason) == (pclink.ENABLE, pclink.NAK_UNCALIBRATED)
        dev.start_stream(100)
        pushes = list(dev.pushes(10, timeout=30.0))
        assert not any(p.enabled for p in pushes)
        assert all(c == 0 for p in pushes for c in p.code)
        dev.stop_stream()
        # the plant's own calibration, axis by axis: what the firmware holds comes back
        truth = sc.load(UNALIGNED).override({"firmware.calibration": "truth"}).calib()
        for i, c in enumerate(truth):
            dev.set_calib(i, c)
        assert [dev.get_calib(i).words() for i in range(3)] == [c.words() for c in truth]
        dev.enable()
        dev.start_stream(100)
        pushes = list(dev.pushes(10, timeout=30.0))
        assert all(p.enabled and p.error == 0 for p in pushes)
        assert any(p.code[1] != 0 for p in pushes)        # the spring reaches motor 1
