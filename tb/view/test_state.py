"""`GET /state` of a live view before and after the first telemetry frame (docs/view.md): the
same keys either way, the frame's values null until a frame came. No browser and no device: the
page serves a `Feed` whose telemetry pipe the test writes one harness line into.
"""

from __future__ import annotations

import json
import os
import time
import urllib.request
from pathlib import Path

from hapgate.device.telemetry import Feed
from hapgate.device.view import Page

# a telemetry line as tb/native/device/view_link.cpp writes it (a device serve: with link=)
LINE = ("T t={t:.9f} q=0.1,0.2,0.3 p=0.01,0.07,-0.002 f=0,1.5,0 tau=0.01,0.02,0.03 "
        "i=0,0,0,0,0,0 dac=1,-2,3,-4,5,-6 ffw=0,1.5,0 taufw=0.01,0.02,0.03 err=0 eax=0 en=1 "
        "drv=1 st=3 paused=0 off=0 drop=0 pcage=0.0015 link={good},0,0,0\n")
# what a live answer has whether or not a frame came (not values of the frame)
NOT_FROM_THE_FRAME = {"events": [], "frames": 0, "target": None, "dropped_view": 0,
                      "bursts": 0, "done": False, "source": "live"}


def get_state(url: str) -> dict:
    with urllib.request.urlopen(url + "state", timeout=30) as r:
        return json.loads(r.read())


def test_state_before_the_first_frame_has_every_key_null(tmp_path: Path) -> None:
    feed = Feed()
    _cfg, (tel_w, _ctl_r) = feed.open()
    writer = os.dup(tel_w)                  # the harness's end of the telemetry pipe
    feed.started(tmp_path)                  # (closes the child ends, as after a harness start)
    page = Page(feed, title="state test")
    try:
        before = get_state(page.url)
        os.write(writer, LINE.format(t=0.1, good=8).encode())
        time.sleep(0.05)                    # (the real-time factor: wall time between frames)
        os.write(writer, LINE.format(t=0.12, good=10).encode())
        t0 = time.monotonic()
        while (after := get_state(page.url))["frames"] < 2:    # rtf needs two frames
            assert time.monotonic() - t0 < 30, "the frame never reached /state"
            time.sleep(0.01)
    finally:
        os.close(writer)
        page.close()
        feed.finished()
    assert after["t_s"] == 0.12 and after["link"] == {"good": 10, "bad": 0, "replayed": 0,
                                                      "timeouts": 0}
    assert list(before) == list(after)      # the same keys, in the same order
    assert {k: v for k, v in before.items() if k not in NOT_FROM_THE_FRAME} == \
        dict.fromkeys(set(after) - set(NOT_FROM_THE_FRAME))
    assert {k: before[k] for k in NOT_FROM_THE_FRAME} == NOT_FROM_THE_FRAME
    assert all(after[k] is not None for k in after if k not in NOT_FROM_THE_FRAME)
