"""`make bench` part "view": the virtual device's real-time factor without the live view, with
the view on and nobody watching, and with a headless Chromium on the page (docs/view.md).

The factor is the harness's own (simulated time over its wall and CPU time), so the page's
server and the browser count only as far as they take the CPU from the simulation.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

from ..base.paths import ROOT
from ..base.report import table
from ..device import runner
from ..device import scene as scene_mod
from ..device.telemetry import Feed
from ..device.view import Page

CHROMEDRIVER = Path("/usr/bin/chromedriver")


def _browser(url: str) -> Any:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    for a in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
              "--window-size=1400,900", "--enable-unsafe-swiftshader"):
        opts.add_argument(a)
    d = webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=opts)
    d.get(url)
    return d


def _one(scene: Any, mode: str) -> list[str]:
    feed = page = browser = None
    if mode != "off":
        feed = Feed(scene)
        page = Page(feed, title=f"bench {mode}")
        if mode == "browser":
            browser = _browser(page.url)
    try:
        r = runner.run(scene, view=feed)
    finally:
        if browser is not None:
            browser.quit()
        if page is not None:
            page.close()
    st = feed.state() if feed is not None else {}
    return [mode, f"{r.sim_s:.3f}", f"{r.wall_s:.2f}", f"{r.rtf:.3f}",
            f"{r.sim_s / r.cpu_s:.3f}" if r.cpu_s > 0 else "-",
            str(st.get("frames", "-")), str(st.get("dropped_device", "-")),
            str(st.get("dropped_view", "-"))]


def run(quick: bool) -> bool:
    dur = 0.4 if quick else 1.0
    scene = scene_mod.load(ROOT / "scenes" / "wall.toml").override(
        {"run.duration_s": dur, "expect": {},
         "fault": [{"at_s": dur / 2, "kind": "dropout", "axis": 1}]})
    modes = ["off", "on"]
    if CHROMEDRIVER.exists() and shutil.which("chromium"):
        modes.append("browser")
    runner.simulate(scene.override({"run.duration_s": 0.01, "fault": []}))   # the build first
    rows = [_one(scene, m) for m in modes]
    print(f"scenes/wall.toml, 3 axes, {dur} s simulated; the live view off, on (no browser), "
          "and with a headless Chromium on the page")
    print(table(["view", "simulated s", "wall s", "real-time x", "real-time x (CPU)",
                 "telemetry frames", "dropped (device)", "not shown (page)"], rows))
    if "browser" not in modes:
        print("(no chromium/chromedriver: the browser row is missing; tb/debian-deps.sh)")
    return True
