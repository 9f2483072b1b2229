"""`make bench`, the virtual device: real-time factor beside the force and position error, per
fidelity, clock and set of axes, and where the time goes (gateware, firmware, plant).

Rows: the wall scene (scenes/wall.toml: three axes, a hand pushing into a 20 N/cm wall, 1 kHz
servo; the dropout fault dropped so the whole run renders the wall) at the lowest bit-identical
clock (the users' build: stage clocks and profile-guided optimisation; without the profile;
without the stage clocks), at 10 kHz servo,
with one axis built, and at the shipped 48 MHz with everything built.
The real-time factor is simulated time over the harness's wall time (build excluded), and over
its CPU time (the one-core figure, meaningful on a busy machine), of the run with the median CPU
time of RTL_REPEATS; the cost split comes from the harness's own timers (HG_PROFILE=1)."""

from __future__ import annotations

import os
from typing import Any

from ..base.paths import ROOT
from ..base.report import table, write_csv
from ..device import model, runner
from ..device import scene as sc

RTL_REPEATS = 3   # runs per rtl row: the run of median CPU time is reported (a shared machine's
                  # speed drifts by +-20 % within minutes; the records are the same every run)


def _row(label: str, s: Any, clk: int | None = None, mask: int | None = None,
         gate: bool = True, pgo: bool = True) -> list[object]:
    os.environ["HG_PROFILE"] = "1"
    try:
        raws = [runner.simulate(s, clk_hz=clk, mask=mask, gate=gate, pgo=pgo)
                for _ in range(RTL_REPEATS)]
    finally:
        os.environ.pop("HG_PROFILE", None)
    raws.sort(key=lambda r: float(r.summary.get("cpu_s", "nan")))
    raw = raws[len(raws) // 2]
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
        _row("wall, 3 axes, no profile-guided build", base, pgo=False),
        _row("wall, 3 axes, no stage clocks", base, gate=False),
        _row("wall, 3 axes, 10 kHz servo", base.override({"run.servo_hz": 10000})),
        _row("wall, axis 1 only", base.override({"run.axes": [1]})),
    ]
    if not quick:
        rows.append(_row("wall, 3 axes, full 48 MHz build", base, runner.FULL_CLK_HZ, 7))
    headers = ["scene", "fidelity", "clock", "axes built", "servo Hz", "simulated s", "wall s",
               "real-time factor", "CPU s", "real-time factor (CPU)", "force err mN",
               "pos err counts", "gateware", "firmware", "plant"]
    print(table(headers, rows))
    print(f"csv: {write_csv('bench_device.csv', headers, rows)}")
    print("(force error: max |J^-T tau - wall law| in the wall's steady state; position error: "
          "max |firmware snapshot - true angle|, counts of 2^20/rev; each rtl row: the run of "
          f"median CPU time of {RTL_REPEATS})")
    return run_model(quick)


# ---------------------------------------------------------------------------------- model fidelity
MODEL_HEADERS = ["scene", "fidelity", "clock", "mechanics step", "axes built", "servo Hz",
                 "simulated s",
                 "wall s", "CPU s", "real-time x (CPU)", "real-time x (wall)", "force err mN",
                 "pos err counts", "DAC diff vs rtl, LSB"]


MODEL_REPEATS = 5   # runs per model row: the CPU and wall figures are the minimum (shared machine)


def _model_row(label: str, s: Any, mech_us: int = 0, rtl: Any = None,
               clk: int | None = None) -> list[object]:
    runs = [model.simulate(s, clk_hz=clk, mech_us=mech_us or model.MECH_US)
            for _ in range(MODEL_REPEATS)]
    raw = runs[0]
    m, _, _ = runner.metrics(s, raw)
    sim = float(raw.summary["sim_s"])
    wall = min(float(r.summary["wall_s"]) for r in runs)
    cpu = min(float(r.summary["cpu_s"]) for r in runs)
    diff = "-"
    if rtl is not None and rtl.frames.size == raw.frames.size:
        diff = str(int(abs(rtl.frames["dac"].astype(int) - raw.frames["dac"].astype(int)).max()))
    return [label, "model", f"{raw.clk_hz / 1e6:g} MHz", f"{mech_us or model.MECH_US} us",
            "".join(str(a) for a in range(3) if raw.mask >> a & 1), int(s.run.servo_hz),
            f"{sim:.3f}", f"{wall:.3f}", f"{cpu:.3f}", f"{sim / cpu:.1f}" if cpu > 0 else "inf",
            f"{sim / wall:.1f}", f"{m.get('force_error_n', float('nan')) * 1e3:.1f}",
            f"{m.get('position_error_counts', float('nan')):.0f}", diff]


def model_rows(quick: bool = False) -> list[list[object]]:
    """The model-fidelity rows (the lead's `run` may print them beside the rtl rows): the wall
    scene with three axes (at the lowest clock and at the shipped 48 MHz: the same records)
    and with one, and the 1 us plant against the gateware on the same scene (its DAC codes
    bit-identical: 0). Each row is the minimum CPU and wall time of MODEL_REPEATS runs."""
    base = sc.load(ROOT / "scenes" / "wall.toml").override(
        {"run.duration_s": 0.25 if quick else 0.5, "fault": [], "expect": {},
         "run.fidelity": "model"})
    short = base.override({"run.duration_s": 0.05})
    rtl_short = runner.simulate(short.override({"run.fidelity": "rtl"}))
    return [
        _model_row("wall, 3 axes", base),
        _model_row("wall, 3 axes, 48 MHz", base, clk=runner.FULL_CLK_HZ),
        _model_row("wall, axis 1 only", base.override({"run.axes": [1]})),
        _model_row("wall, 3 axes, 0.05 s", short, rtl=rtl_short),
        _model_row("wall, 3 axes, 0.05 s, 1 us plant", short, 1, rtl=rtl_short),
    ]


def run_model(quick: bool = False) -> bool:
    print("== virtual device, model fidelity: real-time factor (CPU and wall) beside error "
          "(scenes/wall.toml) ==", flush=True)
    rows = model_rows(quick)
    print(table(MODEL_HEADERS, rows))
    print(f"csv: {write_csv('bench_device_model.csv', MODEL_HEADERS, rows)}")
    print(f"(CPU s: the harness process's CPU time of the run, power-up included, the minimum of "
          f"{MODEL_REPEATS} runs; the machine is shared, so the wall figure depends on its load. "
          "DAC diff: max per-frame code difference against the rtl run of the same scene)")
    return True
