"""The C host library and the CHAI3D shims (host/, docs/native-host.md), end to end: the
library's programs on a real pty served by the virtual device (Verilated gateware, unchanged
firmware, plant: hapgate.commands.device.Server), the test programs built with ASan+UBSan.

Every time asserted is device time (the FPGA tick counter the states carry). One axis is
simulated (axes=(1,)); the others are held, which the link does not care about. The force-law
budget is tb/host/test_host.py's.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import serial
from hapgate.commands.device import Server
from hapgate.golden import pclink
from hapgate.host import Device, cbuild

AXES = (1,)
OPEN_S = 120.0        # the first open may wait for the harness build of a fresh checkout
RUN_S = 120.0         # a bound on any program's wall time (never a figure under test)
TTL_MS = 10
F32 = np.float32

# CHAI3D's frame from the device's (docs/native-host.md): x toward the operator (device -z),
# y to the right (device -x), z up (device +y); positions about the workspace box's centre.
R = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


@pytest.fixture(scope="module")
def host() -> Path:
    return cbuild.build("check")


@pytest.fixture
def served(host: Path) -> Iterator[Server]:
    with Server(axes=AXES, pace="free") as srv:
        yield srv


@pytest.fixture
def served_rt(host: Path) -> Iterator[Server]:
    """Paced to real time, as a board is: a loaded machine slows the device, never the PC
    against it (how many forces reach the device is then the PC's to decide, not asserted)."""
    with Server(axes=AXES, pace="realtime") as srv:
        yield srv


def run(args: list, env: dict | None = None, timeout: float = RUN_S) -> subprocess.CompletedProcess:
    return subprocess.run([str(a) for a in args], capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, **(env or {})})


def rows(out: str, tag: str) -> list[list[str]]:
    return [ln.split(",")[1:] for ln in out.splitlines() if ln.startswith(tag + ",")]


def pushes(out: str) -> np.ndarray:
    """P lines of hg-client: seq, ctr, live, enabled, code0..2, f0..2."""
    return np.array([[float(x) for x in r] for r in rows(out, "P")])


def rest_state(port: str) -> tuple[np.ndarray, np.ndarray]:
    """The resting handle (device frame) and the workspace box's centre, read with the Python
    API (forces off on open and close)."""
    with Device.open(port, timeout=5.0, open_timeout=OPEN_S) as dev:
        info = dev.info()
        p = np.array(dev.state().p)
    return p, 0.5 * (np.array(info.box_lo) + np.array(info.box_hi))


def test_unit_tests_pass_under_sanitizers(host: Path) -> None:
    r = run([host / "bin" / "hg-unit"])
    last = r.stdout.strip().splitlines()[-1]
    m = re.fullmatch(r"(\d+) passed, (\d+) failed", last)
    assert m and int(m[2]) == 0 and int(m[1]) >= 8 and r.returncode == 0, r.stdout + r.stderr


def test_c_loop_renders_the_wall_at_1khz(served_rt: Server, host: Path, tmp_path: Path) -> None:
    """The example's servo loop: the wall 1 mm into the resting handle (normal -y), the hand
    holding it. Every rendered force is the float32 of what the callback returned for it, and
    in steady contact the force law holds within tb/host's budget (k |v| L + b |dv|)."""
    k, b = 2000.0, 10.0
    csv = tmp_path / "wall.csv"
    r = run([host / "bin" / "hg-wall-san", served_rt.port, "--duration", "1", "--k", k, "--b", b,
             "--depth-mm", "1", "--rate", "1000", "--ttl-ms", TTL_MS, "--timeout", "10",
             "--csv", csv])
    assert r.returncode == 0, r.stdout + r.stderr
    lat_max = float(re.search(r"loop latency .* max ([\d.]+) ms", r.stdout)[1])
    head = csv.read_text().splitlines()[0]
    first_ctr = int(re.search(r"first_counter=(\d+)", head)[1])
    p0 = np.array([float(x) for x in re.search(r"p0=(\S+)", head)[1].split(",")])
    d = np.genfromtxt(csv, delimiter=",", skip_header=2)
    seq, p, v, f = d[:, 0], d[:, 1:4], d[:, 4:7], d[:, 7:10]
    ctr, live, cmd = d[:, 10].astype(int), d[:, 12] == 1, d[:, 17:20]
    assert np.allclose(p0, p[0] + [0.0, -1e-3, 0.0], atol=2e-6)   # the plane, 1 mm in
    # exactness: row k's force went out with counter first_ctr + k
    k_of = (ctr - first_ctr) % 65536
    ok = live & (k_of < len(d) - 1)
    assert ok.sum() > 100                                  # enough for the checks below
    assert np.array_equal(F32(cmd[k_of[ok]]), F32(f[ok]))
    # the law, recomputed here: exact at the state each force answered, and within the law's
    # own Lipschitz bound k |dp| + b |dv| of the law at the position measured when rendered
    n = np.array([0.0, -1.0, 0.0])

    def law(p: np.ndarray, v: np.ndarray) -> np.ndarray:
        depth = (p0 - p) @ n
        return np.where((depth > 0)[:, None],
                        np.maximum(0.0, k * depth - b * (v @ n))[:, None] * n, 0.0)

    use, a = ok, k_of[ok]                       # rendered rows, the rows they answered
    assert np.abs(f[use] - law(p[a], v[a])).max() <= 1e-5            # float32 rounding
    # (the law is discontinuous at the surface when b > 0: both states in contact)
    both = ((p0 - p[use]) @ n > 0) & ((p0 - p[a]) @ n > 0)
    assert both.sum() > 100
    bound = k * np.linalg.norm(p[use] - p[a], axis=1) + b * np.linalg.norm(v[use] - v[a], axis=1)
    err = np.linalg.norm(f[use] - law(p[use], v[use]), axis=1)
    assert np.all(err[both] <= bound[both] + 1e-5)
    assert lat_max >= 1.0
    steady = (seq - seq[0] > 200) & (np.linalg.norm(v, axis=1) < 5e-3) & live
    assert steady.sum() > 50
    assert 0.1 < np.linalg.norm(f[steady], axis=1).mean() < 2.0


def test_ttl_expiry_zero_torque_from_the_next_tick(served: Server, host: Path) -> None:
    r = run([host / "bin" / "hg-client", "ttl", served.port, 60, TTL_MS])
    assert r.returncode == 0, r.stdout + r.stderr
    last = int(rows(r.stdout, "LAST")[0][0])
    P = pushes(r.stdout)
    seq, ctr, codes, f = P[:, 0], P[:, 1].astype(int), P[:, 4:7], P[:, 7:10]
    first = seq[ctr == last].min()                  # the first tick rendering the last force
    on = (seq >= first) & (seq < first + TTL_MS)
    off = seq >= first + TTL_MS
    assert on.sum() >= TTL_MS - 2 and off.sum() >= 20
    assert np.all(np.any(codes[on] != 0, axis=1))   # on for its whole TTL ...
    assert np.all(codes[off] == 0) and np.all(f[off] == 0.0)   # ... not a tick more


def test_garbage_counts_moves_nothing_and_resyncs(served: Server, host: Path) -> None:
    r = run([host / "bin" / "hg-client", "garbage", served.port, 11])
    assert r.returncode == 0, r.stdout + r.stderr
    stats = {}
    for block in ("BEFORE", "AFTER"):
        part = r.stdout.split(block + "\n")[1]
        stats[block] = {k: int(v) for k, v in rows(part, "STATS")[:10]}
    bad = ("bad_framing", "bad_crc", "bad_version", "bad_type", "bad_len")
    assert sum(stats["AFTER"][k] - stats["BEFORE"][k] for k in bad) == 20   # one per burst
    assert stats["AFTER"]["rejected"] == stats["BEFORE"]["rejected"]     # no strong force
    assert stats["AFTER"]["host_bad"] == 0
    P = pushes(r.stdout)
    assert len(P) == 100 and np.all(P[:, 4:7] == 0) and np.all(P[:, 7:10] == 0.0)
    assert rows(r.stdout, "STATE")[0] == ["1", "0"]          # resynchronised, still enabled


def test_server_killed_mid_loop_stops_it_with_link_lost(served: Server, host: Path) -> None:
    proc = subprocess.Popen([str(host / "bin" / "hg-client"), "loop", served.port],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "RUNNING"
    time.sleep(0.2)
    served.proc.kill()                               # the device end of the pty goes away
    served.proc.wait()
    out, err = proc.communicate(timeout=RUN_S)
    lost = str(-4)                                   # HG_E_LINK_LOST
    assert rows(out, "LOOP")[0][0] == lost, out + err
    assert int(rows(out, "LOOP")[0][1]) > 0
    assert rows(out, "AFTER")[0] == [lost]           # every call then reports it
    assert rows(out, "STATUS")[0][0] == lost and proc.returncode == 1


def test_reconnect_stays_disabled(served: Server, host: Path) -> None:
    proc = subprocess.Popen([str(host / "bin" / "hg-client"), "loop", served.port],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "RUNNING"
    time.sleep(0.2)
    proc.kill()                                      # the PC program dies with forces on
    proc.communicate()
    r = run([host / "bin" / "hg-client", "reconnect", served.port, 300])
    assert r.returncode == 0, r.stdout + r.stderr
    assert rows(r.stdout, "STATE")[0] == ["0", "0"]
    P = pushes(r.stdout)
    assert len(P) == 300 and np.all(P[:, 3] == 0) and np.all(P[:, 4:7] == 0)


def test_chai3d_loader_renders_a_wall_through_the_shims(served_rt: Server, host: Path,
                                                         tmp_path: Path) -> None:
    """CHAI3D's sequence (dlopen libHD.so, then libhdPhantom.so, 14 dlsym, open, the haptic
    thread's unpaced loop, close) on the production shims, with HAPGATE_LOG recording what
    crossed the link. The frame transform is checked against R above, independently of the
    shim: positions handed to the application, forces rendered by the device."""
    served = served_rt
    p_rest, c = rest_state(served.port)
    log = tmp_path / "link.log"
    k, b = 1000.0, 5.0
    r = run([host / "bin" / "chai3d-loader", "wall", 1.0, k, b, 1.0],
            env={"HAPGATE_PORT": served.port, "LD_LIBRARY_PATH": str(host / "lib"),
                 "HAPGATE_LOG": str(log), "HAPGATE_TIMEOUT_S": "10"})
    assert r.returncode == 0, r.stdout + r.stderr
    assert "devices 1" in r.stdout
    done = rows(r.stdout, "DONE")[0]
    radius, iterations = float(done[2]), int(done[0])
    box_half = np.array([0.086, 0.0415, 0.093])        # INFO's default box, half extents
    assert radius == pytest.approx(box_half.min(), abs=1e-6) and done[3] == "hapgate 3-DOF"
    g0 = np.array([float(x) for x in rows(r.stdout, "G")[0][1:]])
    assert np.allclose(g0, R @ (p_rest - c), atol=1e-6)   # where the application sees it
    lines = log.read_text().splitlines()
    P = np.array([[float(x) for x in ln.split(",")[1:]] for ln in lines if ln[0] == "P"])
    F = np.array([[float(x) for x in ln.split(",")[1:]] for ln in lines if ln[0] == "F"])
    G = np.array([[float(x) for x in ln.split(",")[1:]] for ln in lines if ln[0] == "G"])
    # the device's floats, logged with 9 digits: float32 gives back their exact values
    pseq, pp, pv, pf = P[:, 0], *(F32(P[:, i:i + 3]).astype(float) for i in (1, 4, 7))
    pctr, pflags = P[:, 10].astype(int), P[:, 12].astype(int)
    # positions: each one handed to the application is R (p - c) of the push it came from
    by_seq = {int(s): i for i, s in enumerate(pseq)}
    idx = np.array([by_seq[int(s)] for s in G[:, 0]])
    assert np.allclose(G[:, 1:4], (pp[idx] - c) @ R.T, rtol=0, atol=1e-12)
    # forces: what the device rendered is the float32 of R^T times what the application set
    assert np.array_equal(F32(F[:, 4:7]), F32(F[:, 1:4] @ R))
    live = (pflags & 4) != 0
    fi = {int(x): i for i, x in enumerate(F[:, 0])}
    have = live & np.isin(pctr, list(fi))
    assert have.sum() > 100
    assert np.array_equal(F32(pf[have]), F32(F[[fi[x] for x in pctr[have]], 4:7]))
    # pacing: each force was released by a newer state than the one before (never two
    # forces per state: the loop does not spin), and never more forces than states
    assert np.all(np.diff(F[:, 7]) > 0)
    assert len(F) <= len(P) + 2 and iterations >= len(F) - 1
    # the law in CHAI3D's frame, recomputed here at the state each rendered force answered
    # (the one GetPosition handed out before it was set): rendered in the device's frame,
    # within float32 rounding
    n = np.array([0.0, 0.0, -1.0])
    pc, vc = (pp - c) @ R.T, pv @ R.T
    p0 = g0 + [0.0, 0.0, -1e-3]
    depth = (p0 - pc) @ n
    law_d = np.where((depth > 0)[:, None],
                     np.maximum(0.0, k * depth - b * (vc @ n))[:, None] * n, 0.0) @ R
    answered = {int(x): by_seq.get(int(a), -1) for x, a in zip(F[:, 0], F[:, 7])}
    ans = np.array([answered.get(int(x), -1) for x in pctr])
    use = have & (ans >= 0)
    assert use.sum() > 100
    assert np.abs(pf[use] - law_d[ans[use]]).max() <= 1e-5
    steady = (pseq - pseq[0] > 200) & (np.linalg.norm(pv, axis=1) < 5e-3) & live
    assert steady.sum() > 50
    down = pf[steady].mean(axis=0)                     # the device is pushed down (-y)
    assert down[1] < -0.1 and abs(down[0]) < 0.05 * abs(down[1])


def test_no_device_means_zero_devices(host: Path) -> None:
    env = {"LD_LIBRARY_PATH": str(host / "lib"), "HAPGATE_TIMEOUT_S": "0.3"}
    loader = host / "bin" / "chai3d-loader"
    no_port = {k: v for k, v in os.environ.items() if k != "HAPGATE_PORT"}
    r = subprocess.run([str(loader), "count"], capture_output=True, text=True, timeout=RUN_S,
                       env={**no_port, **env})
    assert r.returncode == 0 and r.stdout.strip() == "devices 0", r.stdout + r.stderr
    assert "HAPGATE_PORT is not set" in r.stderr
    r = run([loader, "count"], env={**env, "HAPGATE_PORT": "/nonexistent/tty"})
    assert r.returncode == 0 and r.stdout.strip() == "devices 0" and "/nonexistent" in r.stderr
    master, slave = os.openpty()                    # a port nobody answers
    try:
        r = run([loader, "count"], env={**env, "HAPGATE_PORT": os.ttyname(slave)})
    finally:
        os.close(master)
        os.close(slave)
    assert r.returncode == 0 and r.stdout.strip() == "devices 0"
    # the shim exports the 14 entry points CHAI3D resolves, and nothing else
    nm = run(["nm", "-D", "--defined-only", host / "lib" / "libhdPhantom.so"]).stdout
    names = sorted(ln.split()[-1] for ln in nm.splitlines() if " T " in ln)
    assert len(names) == 14 and all(nm_.startswith("hdPhantom") for nm_ in names)


def _read_pushes(port: str, quiet_s: float = 2.0) -> list[pclink.Push]:
    """Raw pushes on the port until it has been silent for quiet_s (bounded by RUN_S)."""
    out: list[pclink.Push] = []
    buf = b""
    t_end = time.monotonic() + RUN_S
    last = time.monotonic()
    with serial.Serial(port, timeout=0.05) as s:
        while time.monotonic() - last < quiet_s and time.monotonic() < t_end:
            data = s.read(4096)
            if data:
                last = time.monotonic()
                buf += data
        for fr in pclink.split(buf):
            if fr.msg_type == pclink.STATE_PUSH and len(fr.data) == pclink.PUSH_LEN:
                out.append(pclink.parse_push(fr.data))
    return out


def test_application_killed_by_a_signal(served: Server, host: Path) -> None:
    """A CHAI3D application killed mid-loop never calls Close: its last force lasts its TTL,
    then the link-silence timeout disables forces and stops the stream."""
    proc = subprocess.Popen([str(host / "bin" / "chai3d-loader"), "wall", "60", "1000", "5",
                             "1.0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "HAPGATE_PORT": served.port,
                                 "LD_LIBRARY_PATH": str(host / "lib"),
                                 "HAPGATE_TIMEOUT_S": "10"})
    assert proc.stdout is not None
    while not proc.stdout.readline().startswith("R,200,"):
        assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    seen = _read_pushes(served.port)               # (some may predate the kill)
    live = [i for i, s in enumerate(seen) if s.flags & 4]
    if live:                                       # the last force: at most its TTL of ticks,
        last = seen[live[-1]].force_counter        # then zero torque
        assert sum(1 for i in live if seen[i].force_counter == last) <= TTL_MS
        assert all(s.code == (0, 0, 0) for s in seen[live[-1] + 1:])
    with Device.open(served.port, timeout=5.0, open_timeout=OPEN_S) as dev:
        st = dev.stats()
        s = dev.state()
    assert st.device["timeouts"] == 1 and not s.enabled and s.error == 0
