"""PC side of the dsp-fw PC link (dsp-fw/README.md): COBS frames delimited by 0x00, raw frame
= version, type, seq, data, CRC-16/CCITT-FALSE (big-endian). Encoder, stream decoder and the
message layouts, for host tools and tests (pyserial gives the byte stream on real hardware).
Protocol version 2 adds INFO, STREAM / STATE_PUSH and FORCE (TTL, counter, latency); the
version-1 messages are unchanged and answered in the version of the request."""

from __future__ import annotations

import struct
from dataclasses import dataclass

VERSION = 1                  # the first protocol version (its frames are answered unchanged)
VERSION2 = 2                 # the current one
VERSIONS = (VERSION, VERSION2)
PING, GET_STATE, SET_FORCE, SET_SCENE, ENABLE, GET_STATS, CLEAR_ERROR = range(1, 8)
INFO, STREAM, FORCE = 8, 9, 10           # version 2
SET_CALIB, GET_CALIB = 0x0B, 0x0C        # version 2 (issue 26)
BU_START, BU_PROGRESS, BU_RESULT, BU_CHECK, BU_ABORT = 0x0D, 0x0E, 0x0F, 0x10, 0x11  # v2 bring-up
CAP_READ = 0x12                          # version 2: entries of the FPGA's capture buffer
CAP_READ_MAX = 30                        # entries per CAP_READ reply
STATE_PUSH = 0x8A                        # version 2, device -> PC only
REPLY, NAK = 0x80, 0xFF
NAK_RANGE, NAK_ERROR_LATCHED, NAK_REPLAY, NAK_UNCALIBRATED, NAK_ENABLED = 1, 2, 3, 4, 5
NAK_BRINGUP = 6
NAK_REASONS = {NAK_RANGE: "value out of range", NAK_ERROR_LATCHED: "an error is latched",
               NAK_REPLAY: "force counter not newer (replay)",
               NAK_UNCALIBRATED: "an axis is not calibrated (homed and aligned)",
               NAK_ENABLED: "not while the forces are enabled",
               NAK_BRINGUP: "a bring-up step is running (or the device has no bring-up)"}
# the FPGA's integrity alarm (HG_ERR_FPGA_FAULT, dsp-fw/include/hg_servo.h): the latched
# error's axis byte carries HW_FAULT's cause bits [4:0] (rtl/regs/hapgate.rdl), bit i = name i
ERR_FPGA_FAULT = 9
HW_FAULT_CAUSES = ("REGS", "COMM", "DAC", "TICK", "POS")


def fpga_fault_causes(err: int, axis: int) -> list[str]:
    """The causes of a latched FPGA integrity alarm (empty for any other error)."""
    if err != ERR_FPGA_FAULT:
        return []
    return [n for i, n in enumerate(HW_FAULT_CAUSES) if axis >> i & 1]


# bring-up (dsp-fw/include/hg_bringup.h): steps, states, errors, the message layouts
BU_STEPS = {"align": 1, "homing": 2, "restart": 3, "guided": 4, "dynamics": 5, "encoder": 6}
BU_STATES = ("IDLE", "ALIGN_LOCK", "ALIGN_FWD", "ALIGN_BACK", "HOME_SEARCH", "RETURN",
             "GUIDED_WAIT", "IDENT_RUN", "IDENT_SETTLE", "IDENT_MOVE", "ENC_SWEEP")
BU_ERRORS = ("OK", "ARG", "BUSY", "NOT_READY", "SERVO", "FAULT", "WDOG", "STALE", "SPEED",
             "TRAVEL", "TIME", "ABORT", "LINK", "NO_MOVE", "POLE_PAIRS", "FIT", "NO_INDEX",
             "GUIDED_TIMEOUT", "CONFIG", "CAPTURE")
BU_START_FMT = "<BBbbbI"      # step, axis, expect[3], seed
BU_START_ACK_FMT = "<Bff"     # result, value, limit
BU_PROGRESS_FMT = "<BBBBIIffIH"   # state, step, axis, err, ticks, tick_limit, value, limit, SEQ, Hz
BU_RESULT0_FMT = "<BBBbbB6f3i3f"  # axis, page, flags, scan_sign, dir_base, 0, ... (README table)
BU_RESULT1_FMT = "<BBBB12f"       # axis, page, 0, 0, J, b, c, g, kt_amp, resid, durations[6]
BU_RESULT3_FMT = "<BBBB9f"        # axis, page, 0, 0, IDENT pose q[3], held excursion, lag, se[4]
BU_RESULT4_FMT = "<BBBBfIIff5I"   # axis, page, captured, 0, duration s, decim, entries, speed
#                                  rad/s, sample Hz, CAL_CTRL, _STAT, _OFS, _GAIN, _PHASE
BU_CHECK_FMT = "<BBBBff32s12s"    # axis, check, count, flags, value, limit, name, unit
CALIB_FMT = "<BBbBBiH"     # axis, flags, enc_dir, phases_swapped, pole_pairs, index_to_zero,
#                            comm_offset (hg_axis_calib_t): SET_CALIB request, GET_CALIB reply
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
    version: int = VERSION


def decode(chunk: bytes) -> Frame:
    """One frame without its delimiter; ValueError if it is not a valid version-1/2 frame."""
    raw = cobs_decode(chunk)
    if len(raw) < 5 or crc16(raw[:-2]) != int.from_bytes(raw[-2:], "big"):
        raise ValueError("short frame or bad CRC")
    if raw[0] not in VERSIONS:
        raise ValueError(f"protocol version {raw[0]}")
    return Frame(raw[1], raw[2], raw[3:-2], raw[0])


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


def set_calib(axis: int, words: tuple[int, int, int, int, int, int]) -> bytes:
    """SET_CALIB's data: the axis and hapgate.golden.calib.AxisCalib.words()."""
    return struct.pack(CALIB_FMT, axis, *words)


def parse_calib(data: bytes) -> tuple[int, tuple[int, int, int, int, int, int]]:
    """GET_CALIB's reply: (axis, words)."""
    v = struct.unpack(CALIB_FMT, data)
    return v[0], (v[1], v[2], v[3], v[4], v[5], v[6])


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
STATS2_FIELDS = STATS_FIELDS + ("replayed", "pushed", "push_dropped", "timeouts")


def parse_stats(data: bytes) -> dict[str, int]:
    """The 28-byte version-1 reply or the 44-byte version-2 one."""
    names = STATS_FIELDS if len(data) == 28 else STATS2_FIELDS
    return dict(zip(names, struct.unpack(f"<{len(names)}I", data)))


# ---------------------------------------------------------------------------- version 2
INFO_FMT = "<HBBIHHI6f3fHH"
PUSH_FMT = "<I9f4B3hHH"
FORCE_FMT = "<3fHHI"
PUSH_LEN = struct.calcsize(PUSH_FMT)      # 54
FORCE_LEN = struct.calcsize(FORCE_FMT)    # 20


@dataclass(frozen=True)
class Info:
    fw_version: int
    protocol: int
    fpga_id: int
    servo_hz: int
    link_timeout_ms: int      # silence beyond this disables forces (0: never)
    baud: int                 # the device UART's rate (0: unknown, e.g. USB)
    box_lo: tuple[float, float, float]   # m, workspace box
    box_hi: tuple[float, float, float]
    f_max_n: float
    k_max_n_per_m: float
    b_max_ns_per_m: float
    ttl_max_ms: int           # longest TTL a FORCE may carry
    force_counter: int        # counter of the last FORCE the device accepted


def parse_info(data: bytes) -> Info:
    v = struct.unpack(INFO_FMT, data)
    return Info(v[0], v[1], v[3], v[4], v[5], v[6], v[7:10], v[10:13], v[13], v[14], v[15],
                v[16], v[17])


@dataclass(frozen=True)
class Push:
    """The compact streamed state (STATE_PUSH)."""
    seq: int                                  # FPGA tick of the sample (device time)
    p: tuple[float, float, float]             # m
    v: tuple[float, float, float]             # m/s
    f: tuple[float, float, float]             # N, the force rendered at that tick
    flags: int     # bit 0 enabled, 1 error latched, 2 this tick rendered a PC force, 3 link
    #                timeout armed
    err: int
    err_axis: int
    scene: int
    code: tuple[int, int, int]                # torque codes written at that tick
    force_counter: int                        # last FORCE accepted
    force_latency_ticks: int                  # its first tick minus the tick it answered


def parse_push(data: bytes) -> Push:
    v = struct.unpack(PUSH_FMT, data)
    return Push(v[0], v[1:4], v[4:7], v[7:10], v[10], v[11], v[12], v[13], v[14:17], v[17],
                v[18])


def force(f: tuple[float, float, float], ttl_ms: int, counter: int, answers_seq: int) -> bytes:
    """FORCE data: F [N], TTL [ms], counter (must be newer than the last accepted one, modulo
    2^16), and the SEQ of the state the force was computed from (for the latency)."""
    return struct.pack(FORCE_FMT, *f, ttl_ms, counter & 0xFFFF, answers_seq & 0xFFFFFFFF)


def stream(period_ticks: int) -> bytes:
    return struct.pack("<H", period_ticks)


def wire_bytes(data_len: int) -> int:
    """Bytes a frame with this much data takes on the line: header and CRC (5), one COBS
    overhead byte per 254, the delimiter."""
    raw = data_len + 5
    return raw + (raw + 253) // 254 + 1


def max_stream(baud: int, servo_hz: int, headroom: float = 0.3) -> tuple[int, float]:
    """The shortest push period (ticks) and its rate [Hz] for which pushes one way and FORCE
    frames the other fit the link with `headroom` to spare (10 bit-times per byte)."""
    per_s = (1.0 - headroom) * baud / 10.0
    per_exchange = max(wire_bytes(PUSH_LEN), wire_bytes(FORCE_LEN))   # full duplex
    hz_max = per_s / per_exchange
    period = max(1, -(-servo_hz // int(hz_max)) if hz_max >= 1 else servo_hz)
    while servo_hz / period > hz_max:
        period += 1
    return period, servo_hz / period


def cap_read(start: int, n: int) -> bytes:
    """CAP_READ request: n (1..CAP_READ_MAX) entries from entry start."""
    return struct.pack("<HB", start, n)


def parse_cap_read(data: bytes) -> tuple[int, list[int]]:
    """CAP_READ reply: (first entry, the raw 16-bit entries {B, A})."""
    start, n = struct.unpack_from("<HB", data)
    if len(data) != 4 + 2 * n:
        raise ValueError(f"CAP_READ reply of {len(data)} bytes for {n} entries")
    return start, list(struct.unpack_from(f"<{n}H", data, 4))


def parse_ping(data: bytes) -> tuple[int, int, int]:
    """(firmware version, FPGA ID register, servo rate in Hz)"""
    return struct.unpack("<HIH", data)
