"""The host API without a device: pyserial's loop:// port with the device's replies written
into it in advance. Checks the exception tree and the link-capacity arithmetic."""

from __future__ import annotations

import struct

import pytest
import serial
from hapgate.golden import pclink
from hapgate.host import Device, DeviceFault, LinkLost, ProtocolError, Refused, Timeout


def info_data(baud: int) -> bytes:
    return struct.pack(pclink.INFO_FMT, 0x0100, 2, 0, 0x48470001, 1000, 250, baud,
                       -0.086, 0.016, -0.093, 0.086, 0.099, 0.093, 10.0, 3500.0, 100.0, 100, 7)


def state_data(err: int = 0, axis: int = 0) -> bytes:
    return struct.pack("<I12f4BI", 42, *([0.0] * 12), 2 if err else 0, err, axis, 0, 0)


def reply(msg_type: int, seq: int, data: bytes = b"") -> bytes:
    return pclink.encode(msg_type | pclink.REPLY, seq, data, pclink.VERSION2)


@pytest.fixture
def dev() -> Device:
    return Device(serial.serial_for_url("loop://", timeout=0.01), timeout=0.2)


def test_info_and_the_rate_a_115200_link_carries(dev: Device) -> None:
    dev.port.write(reply(pclink.INFO, 1, info_data(115200)))
    info = dev.info()
    # 0.7 * 11520 B/s / 61 B per push = 132.2 Hz -> the fastest whole-tick period is 8 (125 Hz)
    assert (info.baud, info.max_loop_period, info.max_loop_hz) == (115200, 8, 125.0)
    assert info.box_hi[1] == pytest.approx(0.099) and info.f_max_n == 10.0
    with pytest.raises(Refused, match="at most 125"):
        dev.start_stream(1000)


def test_exception_tree(dev: Device) -> None:
    dev.port.write(reply(pclink.INFO, 1, info_data(1_000_000)))
    assert dev.info().max_loop_hz == 1000.0
    dev.port.write(pclink.encode(pclink.NAK, 2, bytes([pclink.SET_SCENE, 1]), 2))
    with pytest.raises(Refused) as r:
        dev.set_scene(1, k=9999.0)
    assert (r.value.request, r.value.reason) == (pclink.SET_SCENE, pclink.NAK_RANGE)
    dev.port.write(pclink.encode(pclink.NAK, 3, bytes([pclink.ENABLE, 2]), 2)
                   + reply(pclink.GET_STATE, 4, state_data(err=3, axis=2)))
    with pytest.raises(DeviceFault) as f:
        dev.enable()
    assert (f.value.err, f.value.axis, f.value.name) == (3, 2, "ENCODER")
    dev.port.write(reply(pclink.GET_STATE, 5, b"\x00" * 12))
    with pytest.raises(ProtocolError):
        dev.state()
    with pytest.raises(Timeout):                       # nobody answers
        dev.state()


def test_open_errors() -> None:
    with pytest.raises(LinkLost):
        Device.open("/dev/hapgate-no-such-port")
    with pytest.raises(Timeout):                       # loop:// echoes the request: no reply
        Device.open("loop://", timeout=0.1)
