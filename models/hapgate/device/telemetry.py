"""The live view's feed from the device harness (tb/native/device/view_link.h, docs/view.md).

`Feed` makes the two pipes the harness is given (telemetry out, commands in), reads the
telemetry in a thread and keeps the newest state, a short history for the scopes, the safety
events and the newest burst capture. The harness writes without blocking: a line the pipe
cannot take is dropped there and counted (`dropped_device`), so a slow reader never slows the
simulation. `Replay` gives the same interface over a finished run's run.npz.
"""

from __future__ import annotations

import json
import math
import os
import threading
import time
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np

from ..golden import pclink

ERR_NAMES = ("NONE", "NONFINITE", "AXIS_FAULT", "ENCODER", "STALE", "OVERRUN", "WATCHDOG",
             "FPGA_ID", "CONFIG", "FPGA_FAULT")  # HG_ERR_* (runner.ERR_NAMES, hg_servo.h)
PERIOD_S = 0.02          # telemetry period, simulated time (50 Hz at real time)
HISTORY = 500            # telemetry frames kept for the scopes (10 s of simulated time)
VECTORS = {"q": 3, "p": 3, "f": 3, "tau": 3, "i": 6, "dac": 6, "ffw": 3, "taufw": 3}
HIST_KEYS = ("t", "q", "p", "f", "tau", "taufw")


class ViewInputError(ValueError):
    """A run folder the replay cannot use (no run.npz, a corrupt one, no time axis)."""


def parse_line(line: str) -> tuple[str, dict[str, Any]]:
    """('T'|'E'|'B', fields) of one harness line; vectors as float lists, the rest as numbers
    or strings."""
    kind, _, rest = line.strip().partition(" ")
    out: dict[str, Any] = {}
    for word in rest.split():
        key, _, val = word.partition("=")
        if key in VECTORS or key == "link":
            out[key] = [float(x) for x in val.split(",")]
        else:
            try:
                out[key] = float(val)
            except ValueError:
                out[key] = val
    return kind, out


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


class _Base:
    """What the page reads: state(), history(), burst(), events; command() for live runs."""

    live = False
    can_pause = False
    can_move_target = False

    def __init__(self, scene: Any = None) -> None:
        self.scene = scene
        self.lock = threading.Lock()
        self.events: list[dict[str, Any]] = []
        self.dropped_view = 0
        self.done = False

    def command(self, text: str) -> bool:
        return False

    def burst(self) -> dict[str, np.ndarray] | None:
        return None


class Feed(_Base):
    """The live feed of one harness run: `cfg, fds = feed.open()` before starting the harness
    (cfg goes into run.cfg, fds to pass_fds), `feed.started(outdir)` after."""

    live = True

    def __init__(self, scene: Any = None, period_s: float = PERIOD_S, can_pause: bool = True,
                 target0: np.ndarray | None = None) -> None:
        super().__init__(scene)
        self.period_s = float(period_s)
        self.can_pause = can_pause
        self.can_move_target = can_pause and scene is not None and scene.hand.kind == "spring"
        self.target = None if target0 is None else np.asarray(target0, float)
        self._fds: tuple[int, int, int, int] | None = None
        self._thread: threading.Thread | None = None
        self._outdir: Path | None = None
        self._state: dict[str, Any] = {}
        self._hist: deque[dict[str, Any]] = deque(maxlen=HISTORY)
        self._rate: deque[tuple[float, float, float]] = deque(maxlen=60)   # wall, t, link good
        self._burst: dict[str, np.ndarray] | None = None
        self.frames = 0
        self.bursts = 0

    def open(self) -> tuple[str, tuple[int, int]]:
        tel_r, tel_w = os.pipe()
        ctl_r, ctl_w = os.pipe()
        os.set_blocking(ctl_w, False)
        self._fds = (tel_r, tel_w, ctl_r, ctl_w)
        cfg = f"view_fd = {tel_w}\nctl_fd = {ctl_r}\nview_period_s = {self.period_s!r}\n"
        return cfg, (tel_w, ctl_r)

    def started(self, outdir: Path) -> None:
        """The harness runs (it holds the child ends): read its telemetry from now on."""
        assert self._fds is not None
        os.close(self._fds[1])
        os.close(self._fds[2])
        self._outdir = Path(outdir)
        self._thread = threading.Thread(target=self._read, name="view-feed", daemon=True)
        self._thread.start()

    def finished(self) -> None:
        """The harness ended: wait for the last lines, close the command pipe."""
        if self._thread is not None:
            self._thread.join(timeout=10)
        if self._fds is not None:
            try:
                os.close(self._fds[3])
            except OSError:
                pass
        with self.lock:
            self.done = True

    def command(self, text: str) -> bool:
        """Send one command to the harness (pause, resume, forces_off, burst, target X Y Z);
        False when it cannot take it now (ended, or its pipe is full)."""
        if self._fds is None or self.done:
            return False
        try:
            os.write(self._fds[3], (text.strip() + "\n").encode())
        except OSError:
            return False
        if text.startswith("target "):
            self.target = np.array([float(v) for v in text.split()[1:4]])
        return True

    def _read(self) -> None:
        assert self._fds is not None
        with os.fdopen(self._fds[0], "r", buffering=1) as f:
            for line in f:
                try:
                    kind, d = parse_line(line)
                    if kind == "T":
                        self._frame(d)
                    elif kind == "E":
                        self._event(d)
                    elif kind == "B":
                        self._load_burst(str(d["file"]))
                except (ValueError, KeyError, OSError):
                    continue          # a malformed line is skipped, never fatal to the view

    def _frame(self, d: dict[str, Any]) -> None:
        now = time.monotonic()
        link = d.get("link")
        with self.lock:
            self.frames += 1
            self._rate.append((now, d["t"], link[0] if link else 0.0))
            self._state = d
            if not self._hist or d["t"] > self._hist[-1]["t"]:
                self._hist.append(d)

    def _event(self, d: dict[str, Any]) -> None:
        ev = {"t_s": d["cause"], "kind": str(d["kind"]),
              "axis": None if int(d["axis"]) < 0 else int(d["axis"]),
              "reaction_us": d["react_us"], "zero_torque_s": d["zero"],
              "seen_t_s": d["zero"]}        # published at the load that zeroed the torque
        n = int(d["n"])
        with self.lock:
            while len(self.events) <= n:
                self.events.append({})
            self.events[n] = ev

    def _load_burst(self, name: str) -> None:
        assert self._outdir is not None
        raw = (self._outdir / name).read_bytes()
        nf, na = np.frombuffer(raw[:8], dtype="<i4")
        fr = np.frombuffer(raw[8:8 + nf * 128], dtype="<f8").reshape(nf, 16)
        adc = np.frombuffer(raw[8 + nf * 128:8 + nf * 128 + na * 6], dtype=np.int8).reshape(na, 6)
        with self.lock:
            self._burst = {"t": fr[:, 0].copy(), "dac": fr[:, 1:7].copy(),
                           "i_ab": fr[:, 7:13].copy(), "tau": fr[:, 13:16].copy(),
                           "adc": adc.copy()}
            self.bursts += 1
        (self._outdir / name).unlink(missing_ok=True)

    def burst(self) -> dict[str, np.ndarray] | None:
        with self.lock:
            return self._burst

    def history(self) -> dict[str, np.ndarray]:
        with self.lock:
            rows = list(self._hist)
        if not rows:
            return {}
        return {k: np.array([r[k] for r in rows], dtype=float) for k in HIST_KEYS}

    def _rates(self) -> tuple[float | None, float | None]:
        """Real-time factor and the PC's frame rate over the last second of wall time."""
        r = list(self._rate)
        if len(r) < 2:
            return None, None
        now = r[-1][0]
        old = next((x for x in r if now - x[0] <= 1.0), r[0])
        if old is r[-1]:
            old = r[-2]
        dw, dt = r[-1][0] - old[0], r[-1][1] - old[1]
        rtf = dt / dw if dw > 0 else None
        pc = (r[-1][2] - old[2]) / dt if dt > 0 else None
        return rtf, pc

    def state(self) -> dict[str, Any]:
        """The newest frame as the page and `GET /state` read it (docs/view.md). Before the
        first frame the answer has the same keys, the frame's values None (FRAME_KEYS)."""
        with self.lock:
            d = dict(self._state)
            events = [e for e in self.events if e]
            frames, done = self.frames, self.done
            rtf, pc_hz = self._rates()
        return {**(_from_frame(d, rtf, pc_hz) if d else dict.fromkeys(FRAME_KEYS)),
                "events": events,
                "target": None if self.target is None else [float(v) for v in self.target],
                "frames": frames, "dropped_view": self.dropped_view, "bursts": self.bursts,
                "done": done, "source": "live"}


# The keys of a live state taken from the telemetry frame (_from_frame; None before the first)
FRAME_KEYS = ("t_s", "q", "p", "f_hand", "tau", "i_ab", "dac", "f_fw", "tau_fw", "rtf",
              "fw_error", "fw_error_axis", "fpga_fault", "enabled", "driving", "status", "paused",
              "forces_off", "link", "pc_loop_hz", "pc_force_age_ms", "dropped_device")


def _from_frame(d: dict[str, Any], rtf: float | None, pc_hz: float | None) -> dict[str, Any]:
    """A live state's values from one telemetry frame `d` (the keys of FRAME_KEYS)."""
    link, err = d.get("link"), int(d["err"])
    return {
        "t_s": d["t"], "q": d["q"], "p": d["p"], "f_hand": d["f"], "tau": d["tau"],
        "i_ab": d["i"], "dac": [int(x) for x in d["dac"]], "f_fw": d["ffw"],
        "tau_fw": d["taufw"], "rtf": 0.0 if d["paused"] else rtf,
        "fw_error": ERR_NAMES[err] if err < len(ERR_NAMES) else str(err),
        "fw_error_axis": int(d["eax"]),
        "fpga_fault": pclink.fpga_fault_causes(err, int(d["eax"])),   # the FPGA alarm's causes
        "enabled": bool(d["en"]),
        "driving": bool(d["drv"]), "status": int(d["st"]), "paused": bool(d["paused"]),
        "forces_off": bool(d["off"]),
        "link": None if link is None else dict(zip(("good", "bad", "replayed", "timeouts"),
                                                   (int(x) for x in link))),
        "pc_loop_hz": pc_hz if link is not None else None,
        "pc_force_age_ms": _finite(d["pcage"] * 1e3), "dropped_device": int(d["drop"]),
    }


class Replay(_Base):
    """A finished run's run.npz (and its summary.json when present), played at device time
    with a cursor the page's slider moves."""

    def __init__(self, run_dir: Path) -> None:
        super().__init__(None)
        self.run_dir = Path(run_dir)
        npz = self.run_dir / "run.npz"
        if not self.run_dir.is_dir():
            raise ViewInputError(f"{self.run_dir}: not a folder")
        if not npz.is_file():
            raise ViewInputError(f"{npz}: no run.npz in this folder (a `hapgate scene run` "
                                 "output folder has one)")
        try:
            with np.load(npz, allow_pickle=False) as z:
                self.a = {k: np.asarray(z[k]) for k in z.files}
        except Exception as exc:  # noqa: BLE001 - any unreadable file is the same user error
            raise ViewInputError(f"{npz}: not a readable npz file ({exc})") from exc
        t = self.a.get("t")
        if t is None or t.ndim != 1 or t.size == 0:
            raise ViewInputError(f"{npz}: no time axis 't' (or it is empty)")
        self.t = t.astype(float)
        n = self.t.size
        for k in ("q", "p", "f_hand", "tau"):
            if k not in self.a or self.a[k].shape != (n, 3):
                self.a[k] = np.full((n, 3), np.nan)
        self.summary: dict[str, Any] = {}
        sj = self.run_dir / "summary.json"
        if sj.is_file():
            try:
                self.summary = json.loads(sj.read_text())
            except (OSError, ValueError):
                self.summary = {}
        self.events = [{"t_s": e.get("cause_s"), "kind": e.get("kind"), "axis": e.get("axis"),
                        "reaction_us": e.get("reaction_us"),
                        "zero_torque_s": e.get("zero_torque_s")}
                       for e in self.summary.get("events", []) or []]
        self.index = 0
        self.playing = True

    @property
    def fw_error(self) -> str:
        return str((self.summary.get("metrics") or {}).get("fw_error", "NONE"))

    def seek(self, t_s: float) -> None:
        with self.lock:
            self.index = int(np.clip(np.searchsorted(self.t, t_s, side="right") - 1, 0,
                                     self.t.size - 1))

    def history(self) -> dict[str, np.ndarray]:
        with self.lock:
            i = self.index
        lo = int(np.searchsorted(self.t, self.t[i] - HISTORY * PERIOD_S))
        sel = np.unique(np.linspace(lo, i, min(HISTORY, i - lo + 1)).astype(int))
        return {"t": self.t[sel], "q": self.a["q"][sel], "p": self.a["p"][sel],
                "f": self.a["f_hand"][sel], "tau": self.a["tau"][sel]}

    def state(self) -> dict[str, Any]:
        with self.lock:
            i = self.index
        t = float(self.t[i])

        def row(k: str) -> list[float | None]:
            return [_finite(float(v)) for v in self.a[k][i]]

        return {"t_s": t, "q": row("q"), "p": row("p"), "f_hand": row("f_hand"),
                "tau": row("tau"), "rtf": self.summary.get("rtf"),
                "fw_error": self.fw_error,
                "events": [e for e in self.events if e["t_s"] is not None and e["t_s"] <= t],
                "index": i, "last_index": int(self.t.size - 1), "t_end_s": float(self.t[-1]),
                "playing": self.playing, "done": i == self.t.size - 1, "source": "replay",
                "frames": i + 1, "dropped_view": self.dropped_view}
