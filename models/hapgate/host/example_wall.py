"""Example PC program: a virtual wall computed on the PC, the force sent every servo tick.

    python -m hapgate.host.example_wall PORT [--duration 2] [--k 2000] [--depth-mm 1]

PORT is any pyserial URL: the `port:` line of `hapgate device serve`, or a real board's
serial device (/dev/ttyACM0). The wall is the plane `depth_mm` behind where the handle rests
(normal -y, free space towards the user), F = n max(0, k d - b v.n) for depth d > 0, the same
law as the firmware's own WALL scene. The hand resting on the handle pushes it into the wall.

Prints the loop rate achieved, the jitter and latency percentiles in device time (the FPGA tick
counter of the streamed states, so a slow simulation does not distort them) and the force
error against the wall law at the position the device measured at that tick.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass

import numpy as np

from . import Device, HapticError, Scene

F32 = np.float32


def wall_force(p: np.ndarray, v: np.ndarray, p0: np.ndarray, n: np.ndarray, k: float,
               b: float) -> np.ndarray:
    """The wall law for rows of positions [m] and velocities [m/s]: N, never pulling."""
    depth = (p0 - p) @ n
    mag = np.maximum(0.0, k * depth - b * (v @ n))
    return np.where((depth > 0)[..., None], mag[..., None] * n, 0.0)


@dataclass
class WallResult:
    rate_hz: float            # stream rate asked for
    loop_hz: float            # forces that reached the device per device second
    samples: int
    device_s: float
    wall_s: float
    interval_ms: dict[str, float]     # between forces' first ticks (device time)
    latency_ms: dict[str, float]      # state tick -> first tick of the force computed from it
    force_err_n: dict[str, float]     # |rendered - law(measured p, v)|, in contact
    contact_samples: int
    exact: bool               # every rendered force is the float32 of the one the PC sent
    seq: np.ndarray           # per push: tick, position, rendered force, counter
    p: np.ndarray
    f: np.ndarray
    ctr: np.ndarray
    live: np.ndarray
    stats: object
    v: np.ndarray | None = None       # per push: the device's velocity
    answered: np.ndarray | None = None  # per push: the tick of the state its force answered
    p0: np.ndarray | None = None      # the wall plane's point (normal: `normal`)


def _pct(x: np.ndarray, scale: float = 1.0) -> dict[str, float]:
    if x.size == 0:
        return {"p50": float("nan"), "p99": float("nan"), "max": float("nan")}
    return {"p50": float(np.percentile(x, 50)) * scale, "p99": float(np.percentile(x, 99)) * scale,
            "max": float(x.max()) * scale}


def run_wall(dev: Device, duration_s: float = 2.0, k: float = 2000.0, b: float = 10.0,
             depth_mm: float = 1.0, rate_hz: float | None = None, ttl_ms: int = 10,
             normal: tuple[float, float, float] = (0.0, -1.0, 0.0)) -> WallResult:
    """Enable a PC_FORCE scene, render the wall for duration_s of device time, disable."""
    info = dev.info()
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    rest = np.asarray(dev.state().p, float)
    p0 = rest + n * depth_mm * 1e-3          # the plane: depth_mm behind the resting handle
    dev.set_scene(Scene.PC_FORCE)
    dev.enable()
    rate = dev.start_stream(rate_hz)
    pushes, sent_ref = [], {}
    w0 = time.perf_counter()
    first = None
    try:
        while True:
            s = dev.next_push()
            first = s.t_s if first is None else first
            pushes.append(s)
            f = wall_force(np.asarray(s.p), np.asarray(s.v), p0, n, k, b)
            mag = float(np.linalg.norm(f))
            if mag > 0.999 * info.f_max_n:             # the device refuses more than f_max
                f = f * (0.999 * info.f_max_n / mag)
            c = dev.set_force(tuple(f), ttl_ms=ttl_ms, answers=s)
            sent_ref[c] = s.seq
            if s.t_s - first >= duration_s:
                break
    finally:
        wall = time.perf_counter() - w0
        dev.stop_stream()
        dev.disable()
    stats = dev.stats()
    seq = np.array([s.seq for s in pushes], dtype=np.int64)
    p = np.array([s.p for s in pushes])
    v = np.array([s.v for s in pushes])
    f = np.array([s.f for s in pushes])
    ctr = np.array([s.force_counter for s in pushes], dtype=np.int64)
    lat = np.array([s.force_latency_ticks for s in pushes], dtype=np.int64)
    live = np.array([s.pc_force_live for s in pushes])
    # the forces that reached the device: one row per new counter seen in the pushes
    new = np.r_[True, np.diff(ctr) != 0] & np.isin(ctr, list(sent_ref))
    ref = np.array([sent_ref.get(int(c), -1) for c in ctr[new]], dtype=np.int64)
    first_tick = ref + lat[new]
    tick_s = 1.0 / info.servo_hz
    dev_s = float((seq[-1] - seq[0]) * tick_s) if seq.size > 1 else 0.0
    # exactness: what the device rendered at each live tick is the float32 of what was sent
    sent = np.array([dev.sent_force(int(c)) or (np.nan,) * 3 for c in ctr])
    exact = bool(np.all(F32(sent[live]) == F32(f[live]))) if live.any() else False
    law = wall_force(p, v, p0, n, k, b)
    big = np.maximum(np.linalg.norm(law, axis=1, keepdims=True), 1e-30)
    law = law * np.minimum(1.0, 0.999 * info.f_max_n / big)     # the PC clamps as it sends
    contact = live & ((p0 - p) @ n > 0)
    err = np.linalg.norm(f - law, axis=1)[contact]
    return WallResult(rate_hz=rate, loop_hz=(new.sum() - 1) / dev_s if dev_s > 0 else 0.0,
                      samples=int(seq.size), device_s=dev_s, wall_s=wall,
                      interval_ms=_pct(np.diff(first_tick).astype(float), tick_s * 1e3),
                      latency_ms=_pct(lat[new].astype(float), tick_s * 1e3),
                      force_err_n=_pct(err), contact_samples=int(contact.sum()), exact=exact,
                      seq=seq, p=p, f=f, ctr=ctr, live=live, stats=stats, v=v,
                      answered=np.array([sent_ref.get(int(c), -1) for c in ctr], dtype=np.int64),
                      p0=p0)


def report(r: WallResult) -> str:
    st = r.stats
    rtt = st.rtt_wall_s  # type: ignore[attr-defined]
    lines = [
        f"loop rate      {r.loop_hz:8.1f} Hz  (stream {r.rate_hz:.0f} Hz; {r.samples} states "
        f"over {r.device_s:.3f} s device time, {r.wall_s:.2f} s wall)",
        "loop interval  p50 {p50:.3f}  p99 {p99:.3f}  max {max:.3f} ms (device time)".format(
            **r.interval_ms),
        "loop latency   p50 {p50:.3f}  p99 {p99:.3f}  max {max:.3f} ms (device time, state "
        "tick -> force's first tick)".format(**r.latency_ms),
        f"request RTT    p50 {rtt['p50'] * 1e3:.3f}  p99 {rtt['p99'] * 1e3:.3f}  "
        f"max {rtt['max'] * 1e3:.3f} ms (wall time)",
        "force error    p50 {p50:.4f}  p99 {p99:.4f}  max {max:.4f} N against the wall law "
        "at the measured position".format(**r.force_err_n)
        + f" ({r.contact_samples} samples in contact)",
        f"rendered = sent (float32) at every tick: {'yes' if r.exact else 'NO'}",
        f"device link counters: {st.device}",  # type: ignore[attr-defined]
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hapgate.host.example_wall",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("port", help="pyserial URL (the 'port:' line of hapgate device serve)")
    ap.add_argument("--duration", type=float, default=2.0, help="device seconds (default 2)")
    ap.add_argument("--k", type=float, default=2000.0, help="wall stiffness N/m")
    ap.add_argument("--b", type=float, default=10.0,
                    help="wall damping N s/m (default 10; at 0 the delayed wall chatters)")
    ap.add_argument("--depth-mm", type=float, default=1.0,
                    help="the wall plane this far behind the resting handle")
    ap.add_argument("--rate", type=float, default=None,
                    help="loop rate Hz (default: the highest the link carries, at most the "
                    "servo rate)")
    ap.add_argument("--ttl-ms", type=int, default=10, help="life of each force on the device")
    ap.add_argument("--timeout", type=float, default=5.0, help="seconds per reply")
    a = ap.parse_args(argv)
    try:
        with Device.open(a.port, timeout=a.timeout, open_timeout=60.0) as dev:
            info = dev.info()
            print(f"device: firmware {info.fw_version}, protocol {info.protocol}, servo "
                  f"{info.servo_hz} Hz, link {info.baud} baud -> loop at most "
                  f"{info.max_loop_hz:.0f} Hz")
            r = run_wall(dev, a.duration, a.k, a.b, a.depth_mm, a.rate, a.ttl_ms)
    except HapticError as exc:
        print(f"error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    print(report(r))
    return 0


if __name__ == "__main__":
    sys.exit(main())
