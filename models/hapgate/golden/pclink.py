"""PC side of the dsp-fw PC link (dsp-fw/README.md): COBS frames delimited by 0x00, raw frame
= version, type, seq, data, CRC-16/CCITT-FALSE (big-endian). Encoder, stream decoder and the
message layouts, for host tools and tests (pyserial gives the byte stream on real hardware)."""

from __future__ import annotations

import struct
from dataclasses import dataclass

VERSION = 1
PING, GET_STATE, SET_FORCE, SET_SCENE, ENABLE, GET_STATS, CLEAR_ERROR = range(1, 8)
REPLY, NAK = 0x80, 0xFF
SCENE_NONE, SCENE_WALL, SCENE_SPRING, SCENE_VISCOUS, SCENE_PC_FORCE = range(5)


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no final xor."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021 if crc & 0x8000 else crc << 1) & 0xFFFF
    return crc


def cobs_encode(data: bytes) -> bytes:
    out, block = bytearray(), bytearray()
    for i, byte in enumerate(data):
        if byte == 0:
            out += bytes([len(block) + 1]) + block
            block.clear()
            continue
        block.append(byte)
        if len(block) == 254 and i + 1 < len(data):
            out += b"\xff" + block
            block.clear()
    return bytes(out + bytes([len(block) + 1]) + block)


def cobs_decode(data: bytes) -> bytes:
    out, i = bytearray(), 0
    while i < len(data):
        code = data[i]
        if code == 0 or i + code > len(data) or 0 in data[i + 1:i + code]:
            raise ValueError("malformed COBS")
        out += data[i + 1:i + code]
        i += code
        if code < 0xFF and i < len(data):
            out.append(0)
    return bytes(out)


def encode(msg_type: int, seq: int, data: bytes = b"", version: int = VERSION) -> bytes:
    raw = bytes([version, msg_type, seq & 0xFF]) + data
    return cobs_encode(raw + crc16(raw).to_bytes(2, "big")) + b"\x00"


@dataclass(frozen=True)
class Frame:
    msg_type: int
    seq: int
    data: bytes


def decode(chunk: bytes) -> Frame:
    """One frame without its delimiter; ValueError if it is not a valid version-1 frame."""
    raw = cobs_decode(chunk)
    if len(raw) < 5 or crc16(raw[:-2]) != int.from_bytes(raw[-2:], "big"):
        raise ValueError("short frame or bad CRC")
    if raw[0] != VERSION:
        raise ValueError(f"protocol version {raw[0]}")
    return Frame(raw[1], raw[2], raw[3:-2])


def split(stream: bytes) -> list[Frame]:
    """All valid frames in a byte stream (resynchronising on 0x00, dropping bad ones)."""
    frames = []
    for chunk in stream.split(b"\x00"):
        if chunk:
            try:
                frames.append(decode(chunk))
            except ValueError:
                pass
    return frames


def set_force(fx: float, fy: float, fz: float) -> bytes:
    return struct.pack("<3f", fx, fy, fz)


def set_scene(kind: int, p0: tuple[float, float, float] = (0, 0, 0),
              n: tuple[float, float, float] = (0, 0, 0), k: float = 0, b: float = 0,
              ki: float = 0) -> bytes:
    return struct.pack("<B9f", kind, *p0, *n, k, b, ki)


@dataclass(frozen=True)
class State:
    seq: int
    p: tuple[float, float, float]
    v: tuple[float, float, float]
    q: tuple[float, float, float]
    f: tuple[float, float, float]
    flags: int       # bit 0 enabled, bit 1 error latched, bit 2 PC force live
    err: int
    err_axis: int
    scene: int
    fpga_status: int


def parse_state(data: bytes) -> State:
    v = struct.unpack("<I12f4BI", data)
    return State(v[0], v[1:4], v[4:7], v[7:10], v[10:13], *v[13:18])


STATS_FIELDS = ("good", "bad_framing", "bad_crc", "bad_version", "bad_type", "bad_len", "rejected")


def parse_stats(data: bytes) -> dict[str, int]:
    return dict(zip(STATS_FIELDS, struct.unpack("<7I", data)))


def parse_ping(data: bytes) -> tuple[int, int, int]:
    """(firmware version, FPGA ID register, servo rate in Hz)"""
    return struct.unpack("<HIH", data)
