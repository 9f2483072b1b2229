"""`make bench` rows for the PC link: the virtual device served on a pty at several baud rates,
driven by hapgate.host. Per baud: the loop rate the API allows and the one achieved, the loop
latency (state tick -> the force's first tick) and the request round trip in device time and
in wall time, beside the PC wall's force error. Then the C library's servo loop (host/,
hg-wall) beside the Python loop, the device paced to real time as a board is. Printed, never
asserted."""

from __future__ import annotations

import re
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from ..base.report import table, write_csv
from ..host import Device, cbuild
from ..host.example_wall import run_wall, wall_force
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


def _c_wall(port: str, duration_s: float, k: float = 2000.0, b: float = 10.0) -> dict:
    """hg-wall (the C library's servo loop) on the port: its printed figures, and the force
    error against the wall law at the measured position in contact, from its records."""
    exe = cbuild.build() / "bin" / "hg-wall"
    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "wall.csv"
        out = subprocess.run([str(exe), port, "--duration", str(duration_s), "--k", str(k),
                              "--b", str(b), "--timeout", "10", "--csv", str(csv)],
                             capture_output=True, text=True, check=True, timeout=600).stdout
        head = csv.read_text().splitlines()[0]
        d = np.genfromtxt(csv, delimiter=",", skip_header=2)
    p0 = np.array([float(x) for x in re.search(r"p0=(\S+)", head)[1].split(",")])
    p, v, f, live = d[:, 1:4], d[:, 4:7], d[:, 7:10], d[:, 12] == 1
    law = wall_force(p, v, p0, np.array([0.0, -1.0, 0.0]), k, b)
    contact = live & ((p0 - p) @ np.array([0.0, -1.0, 0.0]) > 0)
    err = np.linalg.norm(f - law, axis=1)[contact]
    three = re.compile(r"p50 ([\d.]+)\s+p99 ([\d.]+)\s+max ([\d.]+)")
    return {"api_max": float(re.search(r"loop at most (\d+) Hz", out)[1]),
            "loop_hz": float(re.search(r"loop rate\s+([\d.]+) Hz", out)[1]),
            "interval": [float(x) for x in three.search(out.split("loop interval")[1])
                         .groups()],
            "latency": [float(x) for x in three.search(out.split("loop latency")[1]).groups()],
            "err": np.percentile(err, [50, 99, 100]) if err.size else [np.nan] * 3,
            "device_s": float(re.search(r"over ([\d.]+) s device time", out)[1])}


def run_c(quick: bool = False) -> bool:
    """The C servo loop beside the Python loop, per baud, the device paced to real time."""
    dur = 0.5 if quick else 2.0
    headers = ["baud", "client", "API max Hz", "loop Hz", "interval p50/p99/max ms (dev)",
               "latency p50/p99/max ms (dev)", "force err p50/p99/max N", "dev s", "wall s"]
    rows = []
    print("== PC loop in C (host/, hg-wall) beside Python (hapgate.host), PC wall k=2000 b=10, "
          "virtual device (axis 1) paced to real time ==", flush=True)
    fmt = "{:.1f}/{:.1f}/{:.1f}".format
    for baud in BAUDS:
        for client in ("C", "Python"):
            t0 = time.perf_counter()
            with Server(axes=(1,), pace="realtime", baud=baud) as srv:
                if client == "C":
                    r = _c_wall(srv.port, dur)
                    api, hz, ivl, lat, e, dev_s = (r["api_max"], r["loop_hz"], r["interval"],
                                                   r["latency"], r["err"], r["device_s"])
                else:
                    with Device.open(srv.port, timeout=5.0, open_timeout=300.0) as dev:
                        api = dev.info().max_loop_hz
                        w = run_wall(dev, duration_s=dur, rate_hz=None)
                    hz, dev_s = w.loop_hz, w.device_s
                    ivl = [w.interval_ms[q] for q in ("p50", "p99", "max")]
                    lat = [w.latency_ms[q] for q in ("p50", "p99", "max")]
                    e = [w.force_err_n[q] for q in ("p50", "p99", "max")]
            wall_s = time.perf_counter() - t0
            print(f"  {baud} baud, {client}: {hz:.0f} Hz in {wall_s:.1f} s", flush=True)
            rows.append([baud, client, f"{api:.0f}", f"{hz:.0f}", fmt(*ivl), fmt(*lat),
                         "{:.4f}/{:.3f}/{:.3f}".format(*e), f"{dev_s:.2f}", f"{wall_s:.1f}"])
    print(table(headers, rows))
    print(f"csv: {write_csv('bench_host_c.csv', headers, rows)}")
    print("loop Hz: forces that reached the device per device second; interval: device time "
          "between the states the forces answered; latency: state tick -> the force's first "
          "tick; force error: |rendered - law at the measured position| in contact (the "
          "contact transient included)")
    return True
