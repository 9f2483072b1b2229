"""The host API: a small synchronous object over any pyserial URL (`serial_for_url`), talking
the dsp-fw PC-link protocol (dsp-fw/README.md, versions 1 and 2).

    with Device.open("/dev/pts/5") as dev:       # forces off on open and on close
        print(dev.info())
        dev.set_scene(Scene.PC_FORCE); dev.enable()
        dev.start_stream(1000)                   # STATE_PUSH every servo tick
        for s in dev.pushes(n=1000):
            dev.set_force(law(s.p, s.v), ttl_ms=10, answers=s)

No threads: every call reads the port itself, with a timeout. Pushes that arrive while a
request waits for its reply are queued (bounded) for `next_push()`.
"""

from __future__ import annotations

import collections
import math
import struct
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any

import numpy as np

from ..golden import calib, pclink

DEFAULT_TTL_MS = 10          # a PC force outlives ten missed 1 kHz updates, no more
PUSH_QUEUE = 4096
ERR_NAMES = ("NONE", "NONFINITE", "AXIS_FAULT", "ENCODER", "STALE", "OVERRUN", "WATCHDOG",
             "FPGA_ID", "CONFIG", "FPGA_FAULT")


class HapticError(Exception):
    """Everything the host API raises about the device or the link."""


class LinkLost(HapticError):
    """The port failed (closed, unplugged) or a running stream went silent."""


class Timeout(HapticError):
    """No reply within the timeout on a live port."""


class ProtocolError(HapticError):
    """The device answered something this API does not expect."""


class Refused(HapticError):
    """The device refused a good request (NAK) or the link cannot carry what was asked."""

    def __init__(self, request: int, reason: int, text: str = "") -> None:
        self.request, self.reason = request, reason
        super().__init__(text or f"request 0x{request:02x} refused: "
                         f"{pclink.NAK_REASONS.get(reason, f'reason {reason}')}")


class DeviceFault(HapticError):
    """The device has latched a safety error (cleared only by clear_error())."""

    def __init__(self, err: int, axis: int) -> None:
        self.err, self.axis = err, axis
        self.name = ERR_NAMES[err] if err < len(ERR_NAMES) else str(err)
        self.causes = pclink.fpga_fault_causes(err, axis)   # FPGA_FAULT: HW_FAULT's causes
        where = f"causes {', '.join(self.causes)}" if self.causes else f"on axis {axis}"
        super().__init__(f"device fault {self.name} (code {err}) {where}")


class Scene(IntEnum):
    NONE = pclink.SCENE_NONE
    WALL = pclink.SCENE_WALL
    SPRING = pclink.SCENE_SPRING
    VISCOUS = pclink.SCENE_VISCOUS
    PC_FORCE = pclink.SCENE_PC_FORCE


@dataclass(frozen=True)
class Info:
    fw_version: str
    protocol: int
    fpga_id: int
    servo_hz: int
    link_timeout_ms: int
    baud: int
    box_lo: tuple[float, float, float]
    box_hi: tuple[float, float, float]
    f_max_n: float
    k_max_n_per_m: float
    b_max_ns_per_m: float
    ttl_max_ms: int
    max_loop_hz: float          # highest stream rate the link carries with 30 % headroom
    max_loop_period: int        # the same as a push period in servo ticks


@dataclass(frozen=True)
class State:
    t_s: float                  # device time: FPGA tick / servo rate
    seq: int
    p: tuple[float, float, float]
    v: tuple[float, float, float]
    q: tuple[float, float, float] | None      # joint angles (GET_STATE only)
    f: tuple[float, float, float]             # force the device rendered at that tick
    enabled: bool
    error: int
    error_axis: int
    pc_force_live: bool
    scene: int
    flags: int
    fpga_status: int | None = None            # GET_STATE only
    code: tuple[int, int, int] | None = None  # torque codes (pushes only)
    force_counter: int | None = None          # pushes only
    force_latency_ticks: int | None = None    # pushes only
    rx_wall_s: float = 0.0                    # host clock when it arrived

    @property
    def torque_zero(self) -> bool:
        """No motor is driven (pushes: every code zero; states: disabled or faulted)."""
        if self.code is not None:
            return all(c == 0 for c in self.code)
        return not self.enabled or self.error != 0


@dataclass
class Stats:
    device: dict[str, int]                     # the firmware's counters (GET_STATS)
    host_bad: dict[str, int]                   # frames the host dropped, by cause
    rtt_wall_s: dict[str, float]               # request round trip p50/p99/max (host clock)
    loop_latency_ticks: dict[str, float]       # state tick -> force's first tick, p50/p99/max
    pushes: int
    dropped_push_seq: int                      # gaps in the push frame counter
    stray: int                                 # replies nobody waited for
    extra: dict[str, Any] = field(default_factory=dict)


def _pct(x: Sequence[float]) -> dict[str, float]:
    if not len(x):
        return {"p50": math.nan, "p99": math.nan, "max": math.nan, "n": 0}
    a = np.asarray(x, dtype=float)
    return {"p50": float(np.percentile(a, 50)), "p99": float(np.percentile(a, 99)),
            "max": float(a.max()), "n": int(a.size)}


class Device:
    """One device on one serial port. Use `Device.open(url)`; see the module text."""

    def __init__(self, port: Any, timeout: float = 1.0) -> None:
        self.port = port
        self.timeout = float(timeout)
        self._buf = bytearray()
        self._rx: collections.deque[tuple[pclink.Frame, float]] = collections.deque()
        self._seq = 0
        self._pushes: collections.deque[State] = collections.deque(maxlen=PUSH_QUEUE)
        self._nak_async: list[tuple[int, int]] = []
        self._info: Info | None = None
        self._counter = 0
        self._sent: dict[int, tuple[float, float, float]] = {}
        self._rtt: collections.deque[float] = collections.deque(maxlen=100_000)
        self._lat: collections.deque[int] = collections.deque(maxlen=100_000)
        self._bad = {"framing": 0, "crc": 0, "version": 0}
        self._n_push = 0
        self._push_seq: int | None = None
        self._dropped = 0
        self._stray = 0
        self._last_lat_ctr: int | None = None
        self.streaming = 0

    # ---------------------------------------------------------------- opening and closing
    @classmethod
    def open(cls, url: str, timeout: float = 1.0, open_timeout: float | None = None,
             baudrate: int = 1_000_000, **serial_kw: Any) -> Device:
        """Open any pyserial URL; stop a stream left running and switch forces off."""
        import serial

        try:
            port = serial.serial_for_url(url, baudrate=baudrate, timeout=0.02,
                                         write_timeout=timeout, **serial_kw)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise LinkLost(f"{url}: {exc}") from exc
        dev = cls(port, timeout)
        try:
            port.reset_input_buffer()
            dev.info(timeout=open_timeout)
            dev.stop_stream()
            dev.disable()
            dev._counter = dev._info_counter
        except BaseException:
            port.close()
            raise
        return dev

    def close(self) -> None:
        """Stop the stream, switch forces off, wait until the device reports zero torque."""
        if self.port is None:
            return
        try:
            self.stop_stream()
            self.disable()
            s0 = self.state().seq
            deadline = time.monotonic() + self.timeout
            while True:                    # one whole tick with the servo disabled
                s = self.state()
                if s.seq >= s0 + 2 and s.torque_zero:
                    break
                if time.monotonic() > deadline:
                    raise Timeout("the device did not report zero torque after disable")
        finally:
            try:
                self.port.close()
            finally:
                self.port = None

    def __enter__(self) -> Device:
        return self

    def __exit__(self, exc_type: object, *rest: object) -> None:
        if exc_type is not None and issubclass(exc_type, LinkLost):   # type: ignore[arg-type]
            if self.port is not None:
                self.port.close()
                self.port = None
            return
        self.close()

    # ---------------------------------------------------------------- transport
    def _write(self, frame: bytes) -> None:
        import serial

        if self.port is None:
            raise LinkLost("the device is closed")
        try:
            self.port.write(frame)
        except (serial.SerialException, OSError) as exc:
            raise LinkLost(f"write failed: {exc}") from exc

    def _pump(self) -> None:
        """Read what the port has now (waits at most its short read timeout) and queue the
        decoded frames with their arrival time; nothing is lost between calls."""
        frames = self._read_some()
        wall = time.perf_counter()
        self._rx.extend((fr, wall) for fr in frames)

    def _read_some(self) -> list[pclink.Frame]:
        """What the port has now (waits at most its short read timeout); decoded frames."""
        import serial

        if self.port is None:
            raise LinkLost("the device is closed")
        try:
            n = self.port.in_waiting
            data = self.port.read(n if n else 1)
        except (serial.SerialException, OSError) as exc:
            raise LinkLost(f"read failed: {exc}") from exc
        if not data:
            return []
        self._buf += data
        out = []
        while True:
            i = self._buf.find(0)
            if i < 0:
                if len(self._buf) > 4 * pclink.wire_bytes(64):    # junk without delimiters
                    self._bad["framing"] += 1
                    self._buf.clear()
                return out
            chunk = bytes(self._buf[:i])
            del self._buf[:i + 1]
            if not chunk:
                continue
            try:
                out.append(pclink.decode(chunk))
            except ValueError as exc:
                msg = str(exc)
                self._bad["version" if "version" in msg else "crc" if "CRC" in msg
                          else "framing"] += 1

    def _take(self, fr: pclink.Frame, wall: float) -> None:
        """A frame nobody asked for: a push, an asynchronous NAK (FORCE), or a stray reply."""
        if fr.msg_type == pclink.STATE_PUSH and len(fr.data) == pclink.PUSH_LEN:
            if self._push_seq is not None:
                self._dropped += (fr.seq - self._push_seq - 1) & 0xFF
            self._push_seq = fr.seq
            self._n_push += 1
            st = self._push_state(pclink.parse_push(fr.data), wall)
            self._pushes.append(st)
            if st.force_counter is not None and st.force_counter != self._last_lat_ctr \
                    and st.force_counter in self._sent:
                self._last_lat_ctr = st.force_counter
                self._lat.append(int(st.force_latency_ticks or 0))
        elif fr.msg_type == pclink.NAK and len(fr.data) == 2 and fr.data[0] == pclink.FORCE:
            self._nak_async.append((fr.data[0], fr.data[1]))
        else:
            self._stray += 1

    def _request(self, msg_type: int, data: bytes = b"", version: int = pclink.VERSION2,
                 timeout: float | None = None) -> bytes:
        self._seq = (self._seq + 1) & 0xFF
        seq = self._seq
        t0 = time.perf_counter()
        self._write(pclink.encode(msg_type, seq, data, version))
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        while True:
            while self._rx:
                fr, wall = self._rx.popleft()
                force_nak = fr.msg_type == pclink.NAK and fr.data[:1] == bytes([pclink.FORCE])
                if fr.seq == seq and fr.msg_type in (msg_type | pclink.REPLY, pclink.NAK) \
                        and not force_nak:
                    self._rtt.append(wall - t0)
                    if fr.msg_type == pclink.NAK:
                        if len(fr.data) != 2:
                            raise ProtocolError(f"NAK with {len(fr.data)} data bytes")
                        if fr.data[1] == pclink.NAK_ERROR_LATCHED:
                            st = self.state()
                            raise DeviceFault(st.error, st.error_axis)
                        raise Refused(fr.data[0], fr.data[1])
                    return fr.data
                self._take(fr, wall)
            if time.monotonic() > deadline:
                raise Timeout(f"no reply to request 0x{msg_type:02x} within "
                              f"{self.timeout if timeout is None else timeout:.3g} s")
            self._pump()

    # ---------------------------------------------------------------- requests
    def info(self, timeout: float | None = None) -> Info:
        d = self._request(pclink.INFO, timeout=timeout)
        if len(d) != struct_size(pclink.INFO_FMT):
            raise ProtocolError(f"INFO reply of {len(d)} bytes")
        i = pclink.parse_info(d)
        period, hz = (pclink.max_stream(i.baud, i.servo_hz) if i.baud else (1, float(i.servo_hz)))
        self._info_counter = i.force_counter
        self._info = Info(f"{i.fw_version >> 8}.{i.fw_version & 0xFF}", i.protocol, i.fpga_id,
                          i.servo_hz, i.link_timeout_ms, i.baud, i.box_lo, i.box_hi, i.f_max_n,
                          i.k_max_n_per_m, i.b_max_ns_per_m, i.ttl_max_ms, hz, period)
        return self._info

    @property
    def servo_hz(self) -> int:
        return (self._info or self.info()).servo_hz

    def state(self) -> State:
        d = self._request(pclink.GET_STATE)
        if len(d) != 60:
            raise ProtocolError(f"GET_STATE reply of {len(d)} bytes")
        s = pclink.parse_state(d)
        return State(t_s=s.seq / self.servo_hz, seq=s.seq, p=s.p, v=s.v, q=s.q, f=s.f,
                     enabled=bool(s.flags & 1), error=s.err, error_axis=s.err_axis,
                     pc_force_live=bool(s.flags & 4), scene=s.scene, flags=s.flags,
                     fpga_status=s.fpga_status, rx_wall_s=time.perf_counter())

    def _push_state(self, p: pclink.Push, wall: float) -> State:
        return State(t_s=p.seq / self.servo_hz, seq=p.seq, p=p.p, v=p.v, q=None, f=p.f,
                     enabled=bool(p.flags & 1), error=p.err, error_axis=p.err_axis,
                     pc_force_live=bool(p.flags & 4), scene=p.scene, flags=p.flags,
                     code=p.code, force_counter=p.force_counter,
                     force_latency_ticks=p.force_latency_ticks, rx_wall_s=wall)

    def set_scene(self, kind: Scene | int, p0: Sequence[float] = (0.0, 0.0, 0.0),
                  n: Sequence[float] = (0.0, 0.0, 0.0), k: float = 0.0, b: float = 0.0,
                  ki: float = 0.0) -> None:
        """Wall (p0 on the plane, n into free space), spring/PID to p0, viscous field, or
        PC_FORCE (the device renders set_force())."""
        self._request(pclink.SET_SCENE, pclink.set_scene(int(kind), tuple(p0), tuple(n),  # type: ignore[arg-type]
                                                         k, b, ki))

    def set_calib(self, axis: int, cal: calib.AxisCalib) -> None:
        """Give one axis its calibration (hapgate.golden.calib.AxisCalib, the conventions of
        calibration.toml; calib.load(path) reads one). Only while the forces are disabled
        (else Refused with NAK_ENABLED); a malformed one is Refused with NAK_RANGE."""
        if axis not in (0, 1, 2):
            raise ValueError(f"axis {axis}: 0, 1 or 2")
        self._request(pclink.SET_CALIB, pclink.set_calib(axis, cal.words()))

    def get_calib(self, axis: int) -> calib.AxisCalib:
        """One axis's calibration as the firmware holds it (its offset quantised to the
        FPGA's 360/1024 deg electrical)."""
        d = self._request(pclink.GET_CALIB, bytes([axis]))
        if len(d) != struct_size(pclink.CALIB_FMT):
            raise ProtocolError(f"GET_CALIB reply of {len(d)} bytes")
        got, words = pclink.parse_calib(d)
        if got != axis:
            raise ProtocolError(f"GET_CALIB answered axis {got}, asked {axis}")
        return calib.from_words(words)

    # ---------------------------------------------------------------- bring-up (v2)
    def bu_start(self, step: int, axis: int = 0, expect: Sequence[int] = (0, 0, 0),
                 seed: int = 1) -> tuple[int, float, float]:
        """Start a bring-up step (pclink.BU_STEPS); (result, value, limit): result 0 started,
        else the refusal (pclink.BU_ERRORS) with its figures."""
        d = self._request(pclink.BU_START, struct.pack(pclink.BU_START_FMT, step, axis,
                                                       *(int(e) for e in expect), seed))
        if len(d) != struct_size(pclink.BU_START_ACK_FMT):
            raise ProtocolError(f"BU_START reply of {len(d)} bytes")
        rc, v, lim = struct.unpack(pclink.BU_START_ACK_FMT, d)
        return int(rc), float(v), float(lim)

    def bu_progress(self) -> dict[str, Any]:
        """The step's progress: state, step, axis, err (names), ticks, tick_limit, value,
        limit, seq, rate_hz, t_s (device time into the step)."""
        d = self._request(pclink.BU_PROGRESS)
        if len(d) != struct_size(pclink.BU_PROGRESS_FMT):
            raise ProtocolError(f"BU_PROGRESS reply of {len(d)} bytes")
        st, step, ax, err, ticks, lim_t, v, lim, seq, hz = struct.unpack(pclink.BU_PROGRESS_FMT, d)
        return {"state": _name(pclink.BU_STATES, st), "step": step, "axis": ax,
                "err": _name(pclink.BU_ERRORS, err), "ticks": ticks, "tick_limit": lim_t,
                "value": v, "limit": lim, "seq": seq, "rate_hz": hz,
                "t_s": ticks / hz if hz else 0.0}

    def bu_result(self, axis: int, page: int) -> tuple[Any, ...]:
        """One page of an axis's results (dsp-fw/README.md, BU_RESULT): page 0 and 1 as the
        struct tuples of pclink.BU_RESULT0_FMT / BU_RESULT1_FMT, page 2 the calibration bring-up
        found (hapgate.golden.calib.AxisCalib), page 3 IDENT's pose, hold and standard errors as
        pclink.BU_RESULT3_FMT, page 4 the ENCODER step's capture and CAL_* registers as
        pclink.BU_RESULT4_FMT."""
        d = self._request(pclink.BU_RESULT, bytes([axis, page]))
        fmt = {0: pclink.BU_RESULT0_FMT, 1: pclink.BU_RESULT1_FMT, 2: pclink.CALIB_FMT,
               3: pclink.BU_RESULT3_FMT, 4: pclink.BU_RESULT4_FMT}[page]
        if len(d) != struct_size(fmt):
            raise ProtocolError(f"BU_RESULT page {page} reply of {len(d)} bytes")
        if page == 2:
            return (calib.from_words(pclink.parse_calib(d)[1]),)
        return struct.unpack(fmt, d)

    def bu_check(self, axis: int, check: int) -> dict[str, Any]:
        """One check: {name, value, limit, unit, ge, done, pass, count}."""
        d = self._request(pclink.BU_CHECK, bytes([axis, check]))
        if len(d) != struct_size(pclink.BU_CHECK_FMT):
            raise ProtocolError(f"BU_CHECK reply of {len(d)} bytes")
        _, _, n, fl, v, lim, name, unit = struct.unpack(pclink.BU_CHECK_FMT, d)
        return {"name": name.split(b"\0")[0].decode(), "value": float(v), "limit": float(lim),
                "unit": unit.split(b"\0")[0].decode(), "ge": bool(fl & 1), "done": bool(fl & 2),
                "pass": bool(fl & 4), "count": int(n)}

    def cap_read(self, start: int, n: int) -> list[int]:
        """n raw entries {B, A} of the FPGA's capture buffer from entry start, in CAP_READ
        requests of at most pclink.CAP_READ_MAX (hapgate.golden.capture.unpack decodes them).
        Refused (NAK_BRINGUP) while a bring-up step runs, (NAK_RANGE) past the buffer's end."""
        out: list[int] = []
        while len(out) < n:
            k = min(pclink.CAP_READ_MAX, n - len(out))
            d = self._request(pclink.CAP_READ, pclink.cap_read(start + len(out), k))
            try:
                got, words = pclink.parse_cap_read(d)
            except (ValueError, struct.error) as exc:
                raise ProtocolError(str(exc)) from None
            if got != start + len(out) or len(words) != k:
                raise ProtocolError(f"CAP_READ answered {len(words)} entries from {got}, asked "
                                    f"{k} from {start + len(out)}")
            out += words
        return out

    def bu_abort(self) -> None:
        """Stop the running bring-up step: zero torque before the reply."""
        self._request(pclink.BU_ABORT)

    def enable(self) -> None:
        self._request(pclink.ENABLE, b"\x01")

    def disable(self) -> None:
        self._request(pclink.ENABLE, b"\x00")

    def clear_error(self) -> None:
        self._request(pclink.CLEAR_ERROR)

    def set_force(self, f: Sequence[float], ttl_ms: int = DEFAULT_TTL_MS,
                  answers: State | int | None = None) -> int:
        """Send a PC force [N] that lasts ttl_ms on the device (no reply; a refusal surfaces
        as Refused on a later call). `answers`: the state it was computed from (latency).
        Returns the force's counter."""
        self._raise_async()
        ref = answers.seq if isinstance(answers, State) else (answers or 0)
        self._counter = (self._counter + 1) & 0xFFFF
        fv = (float(f[0]), float(f[1]), float(f[2]))
        self._sent[self._counter] = fv
        if len(self._sent) > 4096:
            for key in list(self._sent)[:2048]:
                del self._sent[key]
        self._seq = (self._seq + 1) & 0xFF
        self._write(pclink.encode(pclink.FORCE, self._seq,
                                  pclink.force(fv, int(ttl_ms), self._counter, ref),
                                  pclink.VERSION2))
        return self._counter

    def sent_force(self, counter: int) -> tuple[float, float, float] | None:
        """The force this object sent with that counter (for checks of what the device did)."""
        return self._sent.get(counter)

    def _raise_async(self) -> None:
        if self._nak_async:
            req, reason = self._nak_async.pop(0)
            raise Refused(req, reason)

    # ---------------------------------------------------------------- streaming
    def max_loop_hz(self) -> float:
        """The highest PC loop rate the link carries (pushes one way, forces the other, 30 %
        headroom), from the device's baud; the servo rate if the device does not know it."""
        return (self._info or self.info()).max_loop_hz

    def start_stream(self, rate_hz: float | None = None, allow_overload: bool = False) -> float:
        """Ask for a STATE_PUSH at rate_hz (default: the highest that fits). Refused if the link
        cannot carry it (unless allow_overload: then the device drops what does not fit and
        counts it). Returns the rate set (servo rate / whole ticks)."""
        info = self._info or self.info()
        hz = info.max_loop_hz if rate_hz is None else float(rate_hz)
        if hz <= 0 or hz > info.servo_hz:
            raise ValueError(f"stream rate {hz} Hz: expected (0, {info.servo_hz}]")
        period = max(1, round(info.servo_hz / hz))
        if period < info.max_loop_period and not allow_overload:
            raise Refused(pclink.STREAM, pclink.NAK_RANGE,
                          f"{info.servo_hz / period:.0f} Hz does not fit a {info.baud} baud link:"
                          f" it carries at most {info.max_loop_hz:.1f} Hz "
                          f"(period {info.max_loop_period} ticks)")
        self._request(pclink.STREAM, pclink.stream(period))
        self.streaming = period
        self._push_seq = None
        return info.servo_hz / period

    def stop_stream(self) -> None:
        self._request(pclink.STREAM, pclink.stream(0))
        self.streaming = 0
        self._pushes.clear()
        self._rx = collections.deque(x for x in self._rx if x[0].msg_type != pclink.STATE_PUSH)

    def next_push(self, timeout: float | None = None) -> State:
        """The next streamed state, in order. A stream silent for the timeout: LinkLost."""
        self._raise_async()
        if self._pushes:
            return self._pushes.popleft()
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        while not self._pushes:
            while self._rx and not self._pushes:
                self._take(*self._rx.popleft())
            self._raise_async()
            if self._pushes:
                break
            if time.monotonic() > deadline:
                raise LinkLost("the state stream went silent")
            self._pump()
        return self._pushes.popleft()

    def latest_push(self, timeout: float | None = None) -> State:
        """The newest streamed state (older queued ones are skipped: a loop that fell behind
        catches up instead of lagging)."""
        st = self.next_push(timeout)
        if self.port is not None and self.port.in_waiting:
            self._pump()
        while self._rx:
            self._take(*self._rx.popleft())
        while self._pushes:
            st = self._pushes.popleft()
        return st

    def pushes(self, n: int | None = None, timeout: float | None = None) -> Iterator[State]:
        k = 0
        while n is None or k < n:
            st = self.next_push(timeout)
            if st.error:
                raise DeviceFault(st.error, st.error_axis)
            yield st
            k += 1

    # ---------------------------------------------------------------- statistics
    def stats(self) -> Stats:
        d = pclink.parse_stats(self._request(pclink.GET_STATS))
        return Stats(device=d, host_bad=dict(self._bad), rtt_wall_s=_pct(self._rtt),
                     loop_latency_ticks=_pct(self._lat), pushes=self._n_push,
                     dropped_push_seq=self._dropped, stray=self._stray)


def _name(names: Sequence[str], i: int) -> str:
    return names[i] if i < len(names) else str(i)


def struct_size(fmt: str) -> int:
    import struct

    return struct.calcsize(fmt)
