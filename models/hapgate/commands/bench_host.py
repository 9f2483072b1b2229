"""`make bench` rows for the PC link: the virtual device served on a pty at several baud rates,
driven by hapgate.host. Per baud: the loop rate the API allows and the one achieved, the loop
latency (state tick -> the force's first tick) and the request round trip in device time and
in wall time, beside the PC wall's force error. Printed, never asserted."""

from __future__ import annotations

import time

import numpy as np

from ..base.report import table, write_csv
from ..host import Device
from ..host.example_wall import run_wall
from .device import Server

BAUDS = (1_000_000, 460_800, 115_200)


def _rtt(dev: Device, n: int) -> tuple[np.ndarray, np.ndarray]:
    """n back-to-back GET_STATE: wall seconds each, and device ticks between replies."""
    wall, seq = np.empty(n), np.empty(n, dtype=np.int64)
    for i in range(n):
        t0 = time.perf_counter()
        s = dev.state()
        wall[i] = time.perf_counter() - t0
        seq[i] = s.seq
    return wall, np.diff(seq)


def run(quick: bool = False) -> bool:
    dur = 0.3 if quick else 1.0
    n_rtt = 100 if quick else 300
    headers = ["baud", "API max Hz", "loop Hz", "latency p50/p99/max ms (dev)",
               "RTT mean/p99/max ms (dev)", "RTT p50/p99/max ms (wall)",
               "force err p50/p99/max N", "dev s", "wall s"]
    rows = []
    print("== PC link: hapgate.host over a pty, virtual device (axis 1), PC wall k=2000 b=10 ==",
          flush=True)
    for baud in BAUDS:
        t0 = time.perf_counter()
        with Server(axes=(1,), pace="free", baud=baud) as srv, \
                Device.open(srv.port, timeout=5.0, open_timeout=300.0) as dev:
            info = dev.info()
            wall_rtt, dev_rtt = _rtt(dev, n_rtt)
            r = run_wall(dev, duration_s=dur, rate_hz=None)
        lat, e = r.latency_ms, r.force_err_n
        print(f"  {baud} baud: {r.loop_hz:.0f} Hz in {time.perf_counter() - t0:.1f} s", flush=True)
        rows.append([
            baud, f"{info.max_loop_hz:.0f}", f"{r.loop_hz:.0f}",
            f"{lat['p50']:.1f}/{lat['p99']:.1f}/{lat['max']:.1f}",
            f"{dev_rtt.mean():.2f}/{np.percentile(dev_rtt, 99):.0f}/{dev_rtt.max():.0f}",
            "/".join(f"{x * 1e3:.2f}" for x in np.percentile(wall_rtt, [50, 99, 100])),
            f"{e['p50']:.4f}/{e['p99']:.3f}/{e['max']:.3f}",
            f"{r.device_s:.2f}", f"{time.perf_counter() - t0:.1f}"])
    print(table(headers, rows))
    print(f"csv: {write_csv('bench_host_link.csv', headers, rows)}")
    print("device-time RTT: ticks (1 ms) between back-to-back GET_STATE replies; force error: "
          "|rendered - law at the measured position| over the contact samples (the first "
          "~0.1 s of each run is the contact transient)")
    return True
