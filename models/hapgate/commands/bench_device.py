"""`make bench`, the virtual device: real-time factor beside the force and position error, per
fidelity, clock and set of axes, and where the time goes (gateware, firmware, plant).

Rows: the wall scene (scenes/wall.toml: three axes, a hand pushing into a 20 N/cm wall, 1 kHz
servo; the dropout fault dropped so the whole run renders the wall) at the lowest bit-identical
clock, at 10 kHz servo, with one axis built, and at the shipped 48 MHz with everything built.
The real-time factor is simulated time over the harness's wall time (build excluded), and over
its CPU time (the one-core figure, meaningful on a busy machine); the cost split comes from the
harness's own timers (HG_PROFILE=1)."""

from __future__ import annotations

import os
from typing import Any

from ..base.paths import ROOT
from ..base.report import table, write_csv
from ..device import runner
from ..device import scene as sc


def _row(label: str, s: Any, clk: int | None = None, mask: int | None = None) -> list[object]:
    os.environ["HG_PROFILE"] = "1"
    try:
        raw = runner.simulate(s, clk_hz=clk, mask=mask)
    finally:
        os.environ.pop("HG_PROFILE", None)
    m, per, _ = runner.metrics(s, raw)
    sim = float(raw.summary["sim_s"])
    wall = float(raw.summary["wall_s"])
    cpu = float(raw.summary.get("cpu_s", "nan"))
    plant = float(raw.summary.get("profile_plant_s", "nan"))
    fw = float(raw.summary.get("profile_firmware_s", "nan"))
    gate = float(raw.summary.get("profile_gateware_s", "nan"))
    return [label, "rtl", f"{raw.clk_hz / 1e6:g} MHz", "".join(str(a) for a in range(3)
                                                           if raw.mask >> a & 1),
            int(s.run.servo_hz), f"{sim:.3f}", f"{wall:.2f}", f"{sim / wall:.2f}",
            f"{cpu:.2f}", f"{sim / cpu:.2f}",
            f"{m.get('force_error_n', float('nan')) * 1e3:.1f}",
            f"{m.get('position_error_counts', float('nan')):.0f}",
            f"{gate / wall:.0%}", f"{fw / wall:.1%}", f"{plant / wall:.0%}"]


def run(quick: bool = False) -> bool:
    print("== virtual device: real-time factor beside error (scenes/wall.toml) ==", flush=True)
    base = sc.load(ROOT / "scenes" / "wall.toml").override(
        {"run.duration_s": 0.25 if quick else 0.5, "fault": [], "expect": {}})
    rows = [
        _row("wall, 3 axes", base),
        _row("wall, 3 axes, 10 kHz servo", base.override({"run.servo_hz": 10000})),
        _row("wall, axis 1 only", base.override({"run.axes": [1]})),
    ]
    if not quick:
        rows.append(_row("wall, 3 axes, full 48 MHz build", base, runner.FULL_CLK_HZ, 7))
    headers = ["scene", "fidelity", "clock", "axes built", "servo Hz", "simulated s", "wall s",
               "real-time factor", "CPU s", "real-time factor (CPU)", "force err mN", "pos err counts", "gateware", "firmware",
               "plant"]
    print(table(headers, rows))
    print(f"csv: {write_csv('bench_device.csv', headers, rows)}")
    print("(force error: max |J^-T tau - wall law| in the wall's steady state; position error: "
          "max |firmware snapshot - true angle|, counts of 2^20/rev)")
    return True
