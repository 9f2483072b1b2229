"""The live view in a real browser (docs/view.md): headless Chromium from Debian driven by
selenium, against `hapgate scene run --view`, `hapgate view RUN_DIR` and `hapgate device serve
--view`. Every check is in device time; wall-clock bounds are only hang guards.

Needs Debian's chromium and chromium-driver (tb/debian-deps.sh, run by `make deps`).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from hapgate.base.paths import REPORTS, ROOT, ensure
from hapgate.device.telemetry import PERIOD_S
from hapgate.device.view import LINK_RGB

HG = [sys.executable, "-m", "hapgate.commands.cli"]
CHROMEDRIVER = Path("/usr/bin/chromedriver")
BUILD_S = 900          # hang guard: the first start may build the device (minutes)
WALL = (ROOT / "scenes" / "wall.toml").read_text()
SHORT = WALL.replace("axes = [0, 1, 2]", "axes = [1]").replace(
    'record = ["q", "p", "f_hand", "tau", "dac"]', 'record = ["q", "p", "f_hand", "tau"]')
LONG = SHORT.replace("duration_s = 0.5", "duration_s = 30.0").replace("at_s = 0.3", "at_s = 29.0")


# ------------------------------------------------------------------------------ helpers
class Proc:
    """A hapgate command whose stdout is read in a thread; url: its 'view:' line."""

    def __init__(self, argv: list[str], cwd: Path = ROOT) -> None:
        self.p = subprocess.Popen(HG + argv, cwd=cwd, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True,
                                  env=os.environ | {"PYTHONUNBUFFERED": "1"})
        self.lines: list[str] = []
        self.err: list[str] = []
        threading.Thread(target=self._read, args=(self.p.stdout, self.lines), daemon=True).start()
        threading.Thread(target=self._read, args=(self.p.stderr, self.err), daemon=True).start()

    @staticmethod
    def _read(f, into: list[str]) -> None:
        for line in f:
            into.append(line.rstrip("\n"))

    def wait_line(self, prefix: str, timeout: float = BUILD_S) -> str:
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout:
            for line in self.lines:
                if line.startswith(prefix):
                    return line[len(prefix):].strip()
            if self.p.poll() is not None and not any(x.startswith(prefix) for x in self.lines):
                time.sleep(0.2)
                if not any(x.startswith(prefix) for x in self.lines):
                    raise AssertionError(f"exited {self.p.returncode} before '{prefix}': "
                                         + "\n".join(self.lines + self.err))
            time.sleep(0.05)
        raise AssertionError(f"no '{prefix}' line in {timeout} s: " + "\n".join(self.err))

    def stop(self) -> int:
        if self.p.poll() is None:
            self.p.send_signal(signal.SIGINT)
            try:
                self.p.wait(timeout=60)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait()
        return self.p.returncode


def state(url: str) -> dict:
    with urllib.request.urlopen(url + "state", timeout=30) as r:
        return json.loads(r.read())


def wait_state(url: str, cond, timeout: float = BUILD_S, every: float = 0.02) -> dict:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        s = state(url)
        if cond(s):
            return s
        time.sleep(every)
    raise AssertionError(f"/state never met the condition in {timeout} s; last: {s}")


@pytest.fixture(scope="module")
def chrome() -> Iterator:
    assert CHROMEDRIVER.exists() and shutil.which("chromium"), \
        "Debian's chromium and chromium-driver are missing: run tb/debian-deps.sh as root"
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    for a in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
              "--window-size=1200,800", "--enable-unsafe-swiftshader", "--use-angle=swiftshader"):
        opts.add_argument(a)
    opts.binary_location = shutil.which("chromium")
    # get() returns at once: open_page waits for the text it needs, on a loaded machine too
    opts.page_load_strategy = "none"
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    # the driver from Debian, named explicitly: selenium-manager never runs (no downloads)
    d = webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=opts)
    d.set_page_load_timeout(120)
    d.command_executor.client_config.timeout = 120    # no driver call waits for ever
    yield d
    d.quit()


@pytest.fixture
def browser(chrome) -> Iterator:
    """The browser for one test; afterwards a blank page, so that no 3-D page goes on
    rendering (software WebGL takes a core) while the next tests run."""
    yield chrome
    blank(chrome)


def blank(browser, timeout: float = 120) -> None:
    """A blank page, loaded (get() returns at once: page_load_strategy none)."""
    browser.get("about:blank")
    t0 = time.monotonic()
    while browser.execute_script("return document.URL") != "about:blank":
        assert time.monotonic() - t0 < timeout, "about:blank never loaded"
        time.sleep(0.05)


def open_page(browser, url: str, text: str, timeout: float = 120) -> str:
    """Load the page, wait until its body shows `text`; the body's text. (The log of the
    page before, whose server may be gone, is drained first.)"""
    blank(browser)
    browser.get_log("browser")
    browser.get(url)
    t0 = time.monotonic()
    body = ""
    while time.monotonic() - t0 < timeout:
        body = browser.execute_script("return document.body ? document.body.innerText : ''")
        if text in body:
            return body
        time.sleep(0.2)
    raise AssertionError(f"the page never showed {text!r}: {body[:500]}")


def console_errors(browser) -> list[str]:
    return [e["message"] for e in browser.get_log("browser") if e["level"] == "SEVERE"]


def linkage_pixels(png: Path) -> int:
    from PIL import Image

    img = np.asarray(Image.open(png).convert("RGB")).astype(int)
    return int((np.abs(img - np.array(LINK_RGB)).max(axis=2) <= 40).sum())


def click(browser, label: str) -> None:
    browser.find_element("xpath", f"//button[contains(., '{label}')]").click()


def shown_p_mm(body: str) -> np.ndarray:
    m = re.search(r"p \(([-+\d.]+), ([-+\d.]+), ([-+\d.]+)\) mm", body)
    assert m, body[:400]
    return np.array([float(v) for v in m.groups()])


# ------------------------------------------------------------------------------ a short run
@pytest.fixture(scope="module")
def short_run(tmp_path_factory) -> Iterator[dict]:
    """scenes/wall.toml on axis 1 (a dropout at 0.3 s) with --view; /state sampled while it
    runs; the command keeps serving the finished run."""
    d = tmp_path_factory.mktemp("view")
    (d / "wall1.toml").write_text(SHORT)
    proc = Proc(["scene", "run", str(d / "wall1.toml"), "--out", str(d / "out"), "--view"])
    try:
        url = proc.wait_line("view: ")
        samples = []
        t0 = time.monotonic()
        while time.monotonic() - t0 < BUILD_S:
            s = state(url)
            if s.get("t_s") is not None:
                samples.append(s)
            if s.get("done"):
                break
            time.sleep(0.01)
        proc.wait_line("wrote ")
        yield {"url": url, "samples": samples, "out": d / "out", "proc": proc}
    finally:
        proc.stop()


def test_live_page_loads_and_draws_the_linkage(short_run, browser) -> None:
    body = open_page(browser, short_run["url"], "run finished")
    time.sleep(2.0)          # let WebGL draw
    png = ensure(REPORTS) / "view-live.png"
    browser.save_screenshot(str(png))
    assert console_errors(browser) == []
    assert linkage_pixels(png) > 500, "no linkage-coloured pixels in the 3-D canvas"
    final = state(short_run["url"])
    np.testing.assert_allclose(shown_p_mm(body), np.array(final["p"]) * 1e3, atol=1.5e-3)


def test_state_follows_the_device_records(short_run) -> None:
    samples = short_run["samples"]
    assert len(samples) >= 5, "too few /state samples while the run went on"
    with np.load(short_run["out"] / "run.npz") as z:
        t, p, q, f, tau = z["t"], z["p"], z["q"], z["f_hand"], z["tau"]
    for s in samples:
        for k in ("t_s", "q", "p", "f_hand", "tau", "rtf", "fw_error", "events"):
            assert k in s
        i = int(np.argmin(np.abs(t - s["t_s"])))
        assert abs(t[i] - s["t_s"]) <= PERIOD_S          # within one telemetry period
        assert abs(t[i] - s["t_s"]) < 1e-6                # in fact: the same frame
        np.testing.assert_allclose(s["p"], p[i], atol=1e-9)
        np.testing.assert_allclose(s["q"], q[i], atol=1e-9)
        np.testing.assert_allclose(s["f_hand"], f[i], atol=1e-7)
        np.testing.assert_allclose(s["tau"], tau[i], atol=1e-9)
    ts = [s["t_s"] for s in samples]
    assert ts == sorted(ts)
    last = state(short_run["url"])
    assert t[-1] - last["t_s"] <= PERIOD_S + 1e-9       # the feed reached the end of the run


def test_fault_is_an_event_with_its_reaction_time(short_run, browser) -> None:
    s = state(short_run["url"])
    summary = json.loads((short_run["out"] / "summary.json").read_text())
    (ev,) = s["events"]
    (ref,) = summary["events"]
    assert ev["kind"] == "dropout" and ev["axis"] == 1
    assert ev["t_s"] == pytest.approx(ref["cause_s"], abs=1e-9)
    assert ev["reaction_us"] == pytest.approx(ref["reaction_us"], abs=0.01)
    assert 0 < ev["reaction_us"] < 100
    assert ev["seen_t_s"] - ev["t_s"] <= 0.1           # published within 100 ms of device time
    assert s["fw_error"] == summary["metrics"]["fw_error"] == "AXIS_FAULT"
    # every /state sampled after 0.1 s past the cause already carried it
    late = [x for x in short_run["samples"] if x["t_s"] >= ev["t_s"] + 0.1]
    assert late and all(x["events"] for x in late)
    body = open_page(browser, short_run["url"], "zero torque after")
    assert f"{ev['reaction_us']:.1f} µs" in body


def test_replay_reaches_the_last_sample(short_run, browser) -> None:
    proc = Proc(["view", str(short_run["out"])])
    try:
        url = proc.wait_line("view: ", timeout=120)
        s = wait_state(url, lambda s: s.get("done"), timeout=120)
        with np.load(short_run["out"] / "run.npz") as z:
            t, p = z["t"], z["p"]
        assert s["t_s"] == pytest.approx(float(t[-1]), abs=1e-12)
        assert s["index"] == s["last_index"] == t.size - 1
        np.testing.assert_allclose(s["p"], p[-1], atol=1e-12)
        assert [e["kind"] for e in s["events"]] == ["dropout"]
        open_page(browser, url, "end of run")
        time.sleep(2.0)
        png = ensure(REPORTS) / "view-replay.png"
        browser.save_screenshot(str(png))
        assert console_errors(browser) == []
        assert linkage_pixels(png) > 500
    finally:
        proc.stop()


# ------------------------------------------------------------------------------ controls
def test_pause_stops_time_and_forces_off_zeroes_the_torque(tmp_path, browser) -> None:
    (tmp_path / "long.toml").write_text(LONG)
    proc = Proc(["scene", "run", str(tmp_path / "long.toml"), "--out", str(tmp_path / "out"),
                 "--view"])
    try:
        url = proc.wait_line("view: ")
        open_page(browser, url, "Pause / resume")
        wait_state(url, lambda s: (s.get("t_s") or 0) > 0.25)   # the hand is on the wall
        s0 = state(url)
        assert s0["driving"] and max(abs(v) for v in s0["tau"]) > 1e-3
        click(browser, "Pause / resume")
        s1 = wait_state(url, lambda s: s.get("paused"), timeout=60)
        time.sleep(1.0)
        s2 = state(url)
        assert s2["paused"] and s2["t_s"] == s1["t_s"]          # simulated time stands
        click(browser, "Pause / resume")
        s3 = wait_state(url, lambda s: not s["paused"] and s["t_s"] > s1["t_s"], timeout=60)
        click(browser, "Forces off")
        s4 = wait_state(url, lambda s: s["forces_off"] and not s["enabled"], timeout=60)
        # 20 ms of device time later the amplifiers' 80 us lag has long settled
        s5 = wait_state(url, lambda s: s["t_s"] >= s4["t_s"] + 0.02, timeout=120)
        assert s5["forces_off"] and not s5["driving"]
        assert max(abs(v) for v in s5["tau"]) < 1e-9
        assert s5["t_s"] > s3["t_s"]
    finally:
        proc.stop()


def test_device_serve_view(browser) -> None:
    proc = Proc(["device", "serve", "--axes", "1", "--pace", "realtime", "--view"])
    try:
        port = proc.wait_line("port: ")
        url = proc.wait_line("view: ", timeout=120)
        assert proc.lines[0].startswith("port: /dev/pts/") and port.startswith("/dev/pts/")
        assert proc.lines[1] == f"view: {url}" and url.startswith("http://127.0.0.1:")
        s = wait_state(url, lambda s: (s.get("t_s") or 0) > 0.05, timeout=120)
        assert s["link"] is not None and s["link"]["bad"] == 0
        assert s["fw_error"] == "NONE" and not s["enabled"]     # forces off until a PC enables
        open_page(browser, url, "link good")
        assert console_errors(browser) == []
    finally:
        proc.stop()


# ------------------------------------------------------------------------------ bad inputs
def test_bad_inputs_exit_2_naming_the_path_or_port(tmp_path) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    r = subprocess.run(HG + ["view", str(empty)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and str(empty / "run.npz") in r.stderr
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "run.npz").write_bytes(b"PK\x03\x04 not really a zip")
    r = subprocess.run(HG + ["view", str(bad)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and str(bad / "run.npz") in r.stderr
    good = tmp_path / "good"
    good.mkdir()
    np.savez(good / "run.npz", t=np.linspace(0, 0.1, 11), p=np.zeros((11, 3)))
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        r = subprocess.run(HG + ["view", str(good), "--view-port", str(port)],
                           capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and f"--view-port {port}" in r.stderr, r.stderr
