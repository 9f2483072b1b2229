"""The live view's page (docs/view.md): one viser server in the process that runs the device,
fanning the feed out to every browser that opens it.

`Page(source, host, port)` serves the 3-D linkage (KINEMATICS.md geometry from the recorded
joint angles), the scopes, the status and the controls; a thread redraws at most `REDRAW_HZ`
times a second from the newest state (frames in between are dropped and counted), so a slow
page never holds the feed up. `GET /state` returns `source.state()` as JSON.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import socket
import threading
import time
from typing import Any

import numpy as np

from ..golden import kinematics

LINK_RGB = (255, 120, 0)     # the linkage's colour (the browser test looks for it)
SHAFT_RGB = (90, 90, 90)
TRAIL_RGB = (40, 110, 230)
FORCE_RGB = (220, 30, 30)
TARGET_RGB = (30, 170, 60)
ENV_RGB = (120, 160, 255)
REDRAW_HZ = 20.0             # page redraws per second of wall time, at most
M_PER_N = 0.005              # force arrow: 5 mm per newton
TRAIL_S = 2.0                # endpoint trail: the last 2 s of simulated time
# the workspace box the firmware reports in INFO (dsp-fw/src/hg_link.c, default linkage), m
BOX_LO, BOX_HI = (-0.086, 0.016, -0.093), (0.086, 0.099, 0.093)


def box_edges(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> np.ndarray:
    """The 12 edges of an axis-aligned box, as (12, 2, 3) line segments."""
    c = np.array([[(hi if (k >> i) & 1 else lo)[i] for i in range(3)] for k in range(8)])
    pairs = [(a, a | 1 << i) for a in range(8) for i in range(3) if not a >> i & 1]
    return np.array([[c[a], c[b]] for a, b in pairs])
LINEAR: Any = {"x": {"time": False}}   # uPlot's x axis: numbers, not dates
CRANK_R = 0.03               # cranks drawn as 90-degree arcs of this radius


class ViewError(RuntimeError):
    """The page could not be served (the port is taken, the host cannot be bound)."""


# ------------------------------------------------------------------------ geometry
def _arc(a: np.ndarray, b: np.ndarray, r: float, n: int = 10) -> np.ndarray:
    """Segments (n, 2, 3) of the great-circle arc of radius r from direction a to b."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    om = math.acos(float(np.clip(a @ b, -1.0, 1.0)))
    s = np.linspace(0.0, 1.0, n + 1)[:, None]
    if om < 1e-9:
        pts = np.repeat(a[None] * r, n + 1, axis=0)
    else:
        pts = r * (np.sin((1 - s) * om) * a + np.sin(s * om) * b) / math.sin(om)
    return np.stack([pts[:-1], pts[1:]], axis=1)


def linkage(q: Any, lb: float = 0.05, lg: float = 0.05) -> tuple[np.ndarray, np.ndarray,
                                                                 np.ndarray]:
    """(linkage segments (n, 2, 3), shaft segments (3, 2, 3), endpoint) at joint angles q:
    the A crank tilting the parallelogram plane about z, the B and Γ cranks as 90° arcs from
    their shafts (−x, +x) to the arms, the parallelogram O–β arm–endpoint–γ arm and the handle
    (docs/design/KINEMATICS.md, h = 0)."""
    a, b, g = (float(v) for v in q)
    ca, sa = math.cos(a), math.sin(a)
    db = math.sqrt(math.cos(b) ** 2 + ca * ca * math.sin(b) ** 2)
    dg = math.sqrt(math.cos(g) ** 2 + ca * ca * math.sin(g) ** 2)
    u, z = np.array([-sa, ca, 0.0]), np.array([0.0, 0.0, 1.0])
    eb = (math.cos(b) / db) * u + (-ca * math.sin(b) / db) * z
    eg = (math.cos(g) / dg) * u + (ca * math.sin(g) / dg) * z
    o = np.zeros(3)
    pb, pg = lb * eb, lg * eg
    p = pb + pg
    bars = np.array([[o, pb], [pb, p], [o, pg], [pg, p], [p, p + 0.015 * u]])
    cranks = np.concatenate([_arc(z, u, CRANK_R), _arc(np.array([-1.0, 0, 0]), eb, CRANK_R),
                             _arc(np.array([1.0, 0, 0]), eg, CRANK_R)])
    shafts = np.array([[[0, 0, CRANK_R], [0, 0, CRANK_R + 0.02]],
                       [[-CRANK_R, 0, 0], [-CRANK_R - 0.02, 0, 0]],
                       [[CRANK_R, 0, 0], [CRANK_R + 0.02, 0, 0]]], dtype=float)
    return np.concatenate([bars, cranks]), shafts, p


def _quat_z_to(n: np.ndarray) -> tuple[float, float, float, float]:
    """wxyz of the rotation taking +z to the unit vector n."""
    n = n / np.linalg.norm(n)
    c = float(n[2])
    if c < -1 + 1e-9:
        return (0.0, 1.0, 0.0, 0.0)
    axis = np.cross([0.0, 0.0, 1.0], n)
    w = math.sqrt((1 + c) / 2)
    v = axis / (2 * w)
    return (w, float(v[0]), float(v[1]), float(v[2]))


def lissajous(adc: np.ndarray, size: int = 96) -> np.ndarray:
    """An RGB image (size, 3·size, 3) of the encoder's A against B per axis (ADC codes)."""
    img = np.full((size, 3 * size, 3), 250, dtype=np.uint8)
    img[:, ::size] = 180
    img[size // 2, :] = 220
    img[:, size // 2::size] = 220
    if adc is None or adc.size == 0:
        return img
    for ax in range(3):
        x = ((adc[:, 2 * ax].astype(int) + 128) * size) // 256
        y = size - 1 - ((adc[:, 2 * ax + 1].astype(int) + 128) * size) // 256
        img[np.clip(y, 0, size - 1), np.clip(x, 0, size - 1) + ax * size] = (200, 60, 0)
    return img


def free_port(host: str) -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


def check_port(host: str, port: int) -> None:
    """ViewError naming the port when host:port cannot be bound now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError as exc:
            raise ViewError(f"--view-port {port}: cannot serve on {host}:{port}: "
                            f"{exc.strerror or exc}") from exc


def _serve_with_state(host: str, port: int, state: Any) -> Any:
    """A viser server whose HTTP handler also answers GET /state with state() as JSON. viser
    serves its page and its websocket through websockets' process_request hook; the hook is
    wrapped here while the server starts (the constructor waits until it listens)."""
    import viser
    import websockets.asyncio.server as ws_server
    from websockets.datastructures import Headers
    from websockets.http11 import Response

    orig = ws_server.serve

    def serve(*args: Any, process_request: Any = None, **kw: Any) -> Any:
        def hook(conn: Any, request: Any) -> Any:
            if request.path.partition("?")[0] == "/state":
                body = json.dumps(state(), allow_nan=False, default=float).encode()
                return Response(200, "OK", Headers({"Content-Type": "application/json",
                                                    "Content-Length": str(len(body)),
                                                    "Cache-Control": "no-store"}), body)
            return process_request(conn, request) if process_request else None
        return orig(*args, process_request=hook, **kw)

    ws_server.serve = serve   # type: ignore[assignment]
    try:
        with contextlib.redirect_stdout(io.StringIO()):    # viser's banner: stdout is ours
            server = viser.ViserServer(host=host, port=port, label="hapgate", verbose=False)
    finally:
        ws_server.serve = orig   # type: ignore[assignment]
    if server.get_port() != port:     # viser moves on to the next free port; we do not
        server.stop()
        raise ViewError(f"--view-port {port}: in use on {host}")
    return server


def _json_safe(x: Any) -> Any:
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_safe(v) for v in x]
    return x


# ------------------------------------------------------------------------ the page
class Page:
    """The page over a source (telemetry.Feed, live; telemetry.Replay, a finished run)."""

    def __init__(self, source: Any, host: str = "127.0.0.1", port: int | None = None,
                 title: str = "", built: list[str] | None = None,
                 skipped: list[str] | None = None) -> None:
        self.source = source
        self.host = host
        self.port = free_port(host) if port is None or port == 0 else int(port)
        check_port(host, self.port)
        self.title = title
        self.built, self.skipped = built or [], skipped or []
        self.server = _serve_with_state(host, self.port, self.state)
        self._stop = threading.Event()
        self._shown = 0
        self._last_burst = 0
        self._setting_slider = False
        self._build()
        self._thread = threading.Thread(target=self._loop, name="view-page", daemon=True)
        self._thread.start()

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}/"

    def state(self) -> dict[str, Any]:
        return _json_safe(self.source.state())

    # -------------------------------------------------------------------- layout
    def _build(self) -> None:
        sc, gui = self.server.scene, self.server.gui
        src = self.source
        sc.set_up_direction("+y")
        self.server.initial_camera.position = (0.16, 0.17, 0.2)
        self.server.initial_camera.look_at = (0.0, 0.05, 0.0)
        gui.configure_theme(control_width="large", show_share_button=False)
        sc.add_line_segments("/workspace", box_edges(BOX_LO, BOX_HI), (160, 160, 160),
                             thickness=0.001)
        bars, shafts, p = linkage(kinematics.ik(np.array([0.0, 0.07, 0.0]))[0])
        self.h_link = sc.add_line_segments("/linkage", bars, LINK_RGB, thickness=0.004)
        self.h_shaft = sc.add_line_segments("/shafts", shafts, SHAFT_RGB, thickness=0.008)
        self.h_hand = sc.add_icosphere("/hand", radius=0.004, color=LINK_RGB, position=tuple(p))
        self.h_trail = sc.add_line_segments("/trail", np.zeros((1, 2, 3)), TRAIL_RGB,
                                            thickness=0.0015)
        self.h_force = sc.add_arrows("/force", np.array([[p, p + 1e-4]]), FORCE_RGB,
                                     shaft_radius=0.0012, head_radius=0.003, head_length=0.006)
        env = getattr(getattr(src, "scene", None), "env", None)
        if env is not None and env.kind == "wall":
            n = np.asarray(env.normal, float)
            sc.add_box("/wall", color=ENV_RGB, dimensions=(0.08, 0.08, 0.0008), opacity=0.45,
                       wxyz=_quat_z_to(n), position=tuple(float(v) for v in env.point))
        elif env is not None and env.kind == "spring":
            sc.add_icosphere("/spring", radius=0.003, color=ENV_RGB,
                             position=tuple(float(v) for v in env.point))
        tgt = getattr(src, "target", None)
        self.h_target = sc.add_icosphere("/target", radius=0.003, color=TARGET_RGB,
                                         position=tuple(tgt) if tgt is not None else (0, 0, 0),
                                         visible=tgt is not None)
        if getattr(src, "can_move_target", False) and tgt is not None:
            gizmo = sc.add_transform_controls("/target_control", scale=0.03,
                                              disable_rotations=True, position=tuple(tgt))

            @gizmo.on_update
            def _(_evt: Any) -> None:
                x, y, z = (float(v) for v in gizmo.position)
                src.command(f"target {x:.6f} {y:.6f} {z:.6f}")

        gui.add_markdown(f"**hapgate view** · {self.title}")
        self.h_status = gui.add_markdown("waiting for the device …")
        self.h_events = gui.add_markdown("no safety event")
        if src.live:
            if src.can_pause:
                pause = gui.add_button("Pause / resume", hint="scene runs: simulated time stops")

                @pause.on_click
                def _(_evt: Any) -> None:
                    st = src.state()
                    src.command("resume" if st.get("paused") else "pause")
            off = gui.add_button("Forces off", color="red",
                                 hint="the firmware's disable: zero torque; never enables")

            @off.on_click
            def _(_evt: Any) -> None:
                src.command("forces_off")
            burst = gui.add_button("Capture burst", hint="DAC frames, currents and ADC words "
                                   "at full rate (also triggered by a fault)")

            @burst.on_click
            def _(_evt: Any) -> None:
                src.command("burst")
        else:
            t = src.t
            self.h_slider = gui.add_slider("time [s]", min=float(t[0]), max=float(t[-1]),
                                           step=float(np.median(np.diff(t))) if t.size > 1
                                           else 1e-3, initial_value=float(t[0]))
            play = gui.add_button("Play / stop")

            @self.h_slider.on_update
            def _(_evt: Any) -> None:
                if not self._setting_slider:
                    src.playing = False
                    src.seek(float(self.h_slider.value))

            @play.on_click
            def _(_evt: Any) -> None:
                if src.index >= src.t.size - 1:
                    src.seek(float(src.t[0]))
                src.playing = not src.playing
        z = np.zeros(2)
        folder = gui.add_folder("Scopes")
        with folder:
            self.h_q = gui.add_uplot((z, z, z, z), (
                {"label": "t [s]"}, {"label": "α", "stroke": "#d62728"},
                {"label": "β", "stroke": "#2ca02c"}, {"label": "γ", "stroke": "#1f77b4"}),
                title="joint angles [rad]", aspect=2.0, scales=LINEAR)
            self.h_p = gui.add_uplot((z, z, z, z), (
                {"label": "t [s]"}, {"label": "x", "stroke": "#d62728"},
                {"label": "y", "stroke": "#2ca02c"}, {"label": "z", "stroke": "#1f77b4"}),
                title="endpoint [mm]", aspect=2.0, scales=LINEAR)
            self.h_fd = gui.add_uplot((z, z, z), (
                {"label": "depth [mm]"}, {"label": "force [N]", "stroke": "#d62728",
                                          "width": 0, "points": {"show": True, "size": 3}},
                {"label": "wall law k·d", "stroke": "#333"}),
                title="force against depth", aspect=2.0, scales=LINEAR)
            self.h_tau = gui.add_uplot((z, z, z, z), (
                {"label": "t [s]"}, {"label": "τα", "stroke": "#d62728"},
                {"label": "τβ", "stroke": "#2ca02c"}, {"label": "τγ", "stroke": "#1f77b4"}),
                title="motor torques [N·m]", aspect=2.0, scales=LINEAR)
        bfold = gui.add_folder("Burst capture (full rate)", expand_by_default=src.live)
        with bfold:
            self.h_dac = self._six(gui, "DAC", "DAC codes, six channels")
            self.h_cur = self._six(gui, "i", "phase currents [A]")
            self.h_liss = gui.add_image(lissajous(np.zeros((0, 6), np.int8)),
                                        label="encoder Lissajous A/B, axes α β γ")
        gui.add_markdown("Built: " + ", ".join(self.built) if self.built else "")
        if self.skipped:
            gui.add_markdown("Skipped: " + ", ".join(self.skipped))

    @staticmethod
    def _six(gui: Any, prefix: str, title: str) -> Any:
        """A burst scope of the six channels a0 b0 a1 b1 a2 b2 against time in ms."""
        colours = ("#d62728", "#ff9896", "#2ca02c", "#98df8a", "#1f77b4", "#aec7e8")
        return gui.add_uplot(tuple(np.zeros(2) for _ in range(7)), (
            {"label": "t [ms]"}, *({"label": f"{prefix} {c}", "stroke": col}
                                   for c, col in zip("a0 b0 a1 b1 a2 b2".split(), colours))),
            title=title, aspect=2.0, scales=LINEAR)

    # -------------------------------------------------------------------- redraw
    def _loop(self) -> None:
        last_t = time.monotonic()
        while not self._stop.wait(1.0 / REDRAW_HZ):
            now = time.monotonic()
            src = self.source
            if not src.live and src.playing:
                with src.lock:
                    t_next = src.t[src.index] + (now - last_t)
                src.seek(t_next)
                if src.index >= src.t.size - 1:
                    src.playing = False
            last_t = now
            try:
                self.redraw()
            except Exception:   # noqa: BLE001 - a page that closes mid-update must not stop us
                continue

    def redraw(self) -> None:
        src = self.source
        st = src.state()
        if st.get("t_s") is None:
            return
        frames = int(st.get("frames", 0))
        if src.live and frames > self._shown + 1 and self._shown:
            src.dropped_view += frames - self._shown - 1       # not shown: dropped, counted
        self._shown = frames
        q = st["q"]
        if all(v is not None for v in q):
            bars, _shafts, p = linkage(q)
            self.h_link.points = bars
            self.h_hand.position = tuple(float(v) for v in p)
            f = np.array([v or 0.0 for v in st["f_hand"]])
            self.h_force.points = np.array([[p, p + f * M_PER_N + 1e-5]])
        h = src.history()
        if h and h["t"].size > 1:
            t = h["t"]
            keep = t >= t[-1] - TRAIL_S
            pts = h["p"][keep]
            if pts.shape[0] > 1:
                self.h_trail.points = np.stack([pts[:-1], pts[1:]], axis=1)
            self.h_q.data = (t, *h["q"].T)
            self.h_p.data = (t, *(h["p"].T * 1e3))
            self.h_tau.data = (t, *h["tau"].T)
            self._force_depth(h)
        if not src.live and not self._setting_slider:
            self._setting_slider = True
            try:
                self.h_slider.value = float(st["t_s"])
            finally:
                self._setting_slider = False
        tgt = st.get("target")
        if tgt is not None:
            self.h_target.position = tuple(tgt)
            self.h_target.visible = True
        b = src.burst()
        if b is not None and getattr(src, "bursts", 0) != self._last_burst:
            self._last_burst = src.bursts
            tb = (b["t"] - b["t"][0]) * 1e3
            self.h_dac.data = (tb, *b["dac"].T)
            self.h_cur.data = (tb, *b["i_ab"].T)
            self.h_liss.image = lissajous(b["adc"])
        self.h_status.content = self._status_text(st)
        evs = st.get("events") or []
        self.h_events.content = "\n".join(
            f"- **{e['kind']}** axis {e['axis']} at {e['t_s']:.6f} s: zero torque after "
            f"**{e['reaction_us']:.1f} µs**" for e in evs if e.get("reaction_us") is not None
        ) or "no safety event"

    def _force_depth(self, h: dict[str, np.ndarray]) -> None:
        env = getattr(getattr(self.source, "scene", None), "env", None)
        if env is None or env.kind != "wall":
            return
        n = np.asarray(env.normal, float)
        n = n / np.linalg.norm(n)
        depth = (np.asarray(env.point, float) - h["p"]) @ n
        fn = h["f"] @ -n              # the force on the hand pushes it out along n: the device's
        order = np.argsort(depth)     # force along −n resists the hand
        d = depth[order]
        self.h_fd.data = (d * 1e3, np.abs(fn[order]), env.k * np.maximum(d, 0.0))

    def _status_text(self, st: dict[str, Any]) -> str:
        def vec(v: list[Any], scale: float = 1.0, fmt: str = "{:+.3f}") -> str:
            return "(" + ", ".join("–" if x is None else fmt.format(x * scale) for x in v) + ")"

        rtf = st.get("rtf")
        lines = [
            f"t **{st['t_s']:.4f} s** · real-time factor "
            f"{'–' if rtf is None else f'{rtf:.2f}'}"
            + (" · **paused**" if st.get("paused") else "")
            + (" · **forces off**" if st.get("forces_off") else ""),
            f"p {vec(st['p'], 1e3)} mm · F {vec(st['f_hand'], 1.0, '{:+.2f}')} N",
            f"q {vec(st['q'])} rad · τ {vec(st['tau'], 1.0, '{:+.4f}')} N·m",
            f"firmware error **{st.get('fw_error')}**"
            + (f" (FPGA alarm **{', '.join(st['fpga_fault'])}**)" if st.get("fpga_fault") else "")
            + ("" if st.get("enabled") is None else
               f" · forces {'on' if st.get('driving') else 'off'}"),
        ]
        link = st.get("link")
        if link:
            hz = st.get("pc_loop_hz")
            age = st.get("pc_force_age_ms")
            lines.append(f"link good {link['good']} bad {link['bad']} replayed "
                         f"{link['replayed']} timeouts {link['timeouts']}"
                         + ("" if hz is None else f" · PC {hz:.0f} frames/s")
                         + ("" if age is None else f" · PC force age {age:.1f} ms"))
        if st.get("source") == "live":
            lines.append(f"telemetry {st.get('frames')} frames · dropped: device "
                         f"{st.get('dropped_device')}, page {st.get('dropped_view')} · bursts "
                         f"{st.get('bursts')}" + (" · **run finished**" if st.get("done") else ""))
        else:
            lines.append(f"replay sample {st['index'] + 1} of {st['last_index'] + 1}"
                         + (" · **end of run**" if st.get("done") else ""))
        return "  \n".join(lines)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        self.server.stop()
