"""The virtual device, closed loop: run a scene through the Verilated gateware, the unchanged
firmware and the plant (tb/native/device/), and measure it.

`run(scene)` decides what to build (the clock, the axes, tracing), builds it once per parameter
set (cached under build/native/device_harness-<hash>/), runs the native harness with a progress
bar, reads its records and computes the metrics `[expect]` checks (`metrics()`), returning a
`RunResult`. Nothing here is per sample in Python: the loop is C++; the metrics are numpy.

Why any clock gives the same result, and which clock is the lowest: tb/native/device/README.md.
"""

from __future__ import annotations

import functools
import math
import os
import subprocess
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..base.paths import BUILD, GEN, ROOT, ensure
from ..golden import configs, kinematics
from ..golden.top import SOURCES, TopConfig
from ..runners import cosim, funcov, native
from . import model, soc
from .harness import (
    ENERGY_MIN_J,
    ERR_NAMES,
    FRAME_DT,
    FW,
    HERE,
    K_MAX_TEST,
    LOAD_DT,
    LOSS_SAMPLES,
    STEADY_AFTER_S,
    STEADY_DEPTH,
    STEADY_SPEED,
    TICK_DT,
    DeviceError,
    Raw,
    _coarse,
    _observer,
    _progress_reader,
    axis_mask,
    choose_clock,
    link_script,
    plant_config,
    record_mask,
    run_config,
    scripted_pc,
    start_pose,
)
from .harness import FULL_CLK_HZ as FULL_CLK_HZ
from .harness import MIN_CLK_HZ as MIN_CLK_HZ
from .result import RunResult
from .scene import load as load_scene

HARNESS = [HERE / "device_harness.cpp", HERE / "harness_common.cpp", HERE / "plant.cpp",
           HERE / "uart_link.cpp", HERE / "view_link.cpp"]

# ---------------------------------------------------------------------------------- decisions
def _top(clk_hz: int, mask: int, coarse: bool = False,
         vel_obs: bool = False) -> tuple[TopConfig, list[Path], dict[str, Any]]:
    """The top's configuration, sources and parameters of a virtual-device build: the FPGA's
    top; with axes left out (mask < 7) its interpolator bank replaced by the held-axis bank
    (tb/native/device/held/enc_interp3.v, docs/design/SIMULATION.md)."""
    point = configs.get("paper").replace(
        clk_hz=clk_hz, angle="quadrature" if coarse else "arcsine",
        velocity="observer" if vel_obs else "fir")
    return point.top(), sim_sources(mask), point.rtl_params()


def sim_sources(mask: int) -> list[Path]:
    """The virtual device's gateware sources: the top's, with axes left out (mask < 7) the
    held-axis bank in place of rtl/interp/enc_interp3.v."""
    srcs = [ROOT / "rtl" / s for s in SOURCES]
    if mask == 7:
        return srcs
    bank = ROOT / "rtl" / "interp" / "enc_interp3.v"
    return [s for s in srcs if s != bank] + [_built_bank(bank), HERE / "held" / "enc_interp3.v"]


def _built_bank(bank: Path) -> Path:
    """rtl/interp/enc_interp3.v as module enc_interp3_built (the held-axis bank instantiates it
    with the built axes), written into build/gen/."""
    text = bank.read_text()
    head = "module enc_interp3 #("
    if text.count(head) != 1:
        raise RuntimeError(f"{bank}: expected one '{head}'")
    out = ensure(GEN / "sim") / "enc_interp3_built.v"
    new = text.replace(head, "module enc_interp3_built #(")
    if not out.exists() or out.read_text() != new:
        out.write_text(new)
    return out


def sim_defines(mask: int, gate: bool) -> list[str]:
    """The defines of a virtual-device build (rtl/include/hg_sim.vh)."""
    return ((["-DHG_SIM_GATE"] if gate else [])
            + ([f"-DHG_AXIS_MASK={mask}"] if mask != 7 else []))


def build_gate_equiv(clk_hz: int, mask: int, gate: bool) -> Path:
    """The stage clocks' equivalence harness (tb/native/device/gate_equiv.cpp) on the device's
    top, with the stage clocks (gate) or with every register on clk (cached)."""
    _, srcs, params = _top(clk_hz, mask)
    return native.verilate_harness(
        "gate_equiv", "hapgate_top", srcs, params, [HERE / "gate_equiv.cpp"],
        cflags=(f"-std=c++17 -DCLK_HZ={clk_hz} -DAXIS_MASK={mask} -DHG_SIM_GATE={int(gate)} "
                f"-I{FW / 'include'}"),
        inputs=[HERE / "stage_clocks.h", *sorted((FW / "include").glob("*.h"))],
        vflags=sim_defines(mask, gate))


def pgo_enabled() -> bool:
    """Profile-guided optimisation of the rtl fidelity's build (README "Simulation speed"): on
    unless HG_PGO=0 (the test suite turns it off: it doubles a build's compile time and changes
    no result, which tb/device/test_closed_loop.py checks)."""
    return os.environ.get("HG_PGO", "1") != "0"


TRAIN_S = 0.03   # s of scene time in a PGO training run (after the 9.1 ms power-up)


def _train(clk_hz: int, mask: int, test_limits: bool, coarse: bool, vel_obs: bool,
           exe: Path) -> None:
    """The PGO training run of a device build: TRAIN_S of scenes/wall.toml (power-up, the hand
    pushing into the wall) on the build's own clock and axes."""
    s = load_scene(ROOT / "scenes" / "wall.toml").override({
        "run.duration_s": TRAIN_S, "run.clk_hz": clk_hz, "fault": [], "expect": {},
        "run.axes": [a for a in range(3) if mask >> a & 1],
        "run.position": "quadrature" if coarse else "interpolated",
        "run.velocity": "observer" if vel_obs else "fir", "firmware.test_limits": test_limits})
    q0 = start_pose(s)
    with tempfile.TemporaryDirectory(prefix="train-", dir=ensure(BUILD / "native" / "runs")) as t:
        (Path(t) / "plant.cfg").write_text(plant_config(s, q0))
        (Path(t) / "run.cfg").write_text(run_config(s, q0))
        subprocess.run([str(exe), str(Path(t) / "plant.cfg"), str(Path(t) / "run.cfg"), t],
                       check=True, capture_output=True, timeout=300)


def build(clk_hz: int, mask: int = 7, trace: bool = False, test_limits: bool = False,
          coarse: bool = False, vel_obs: bool = False, gate: bool = True,
          pgo: bool | None = None, saboteur: Any = None) -> Path:
    """Verilate the top (the held-axis bank for the axes not in mask) with the harness, plant
    and firmware (cached).
    test_limits: the firmware built with HG_SCENE_K_MAX_TEST (scene key firmware.test_limits);
    coarse: plain quadrature, the interpolator's fine angle zeroed (run.position);
    vel_obs: the tracking velocity observer built and reported as VEL (run.velocity);
    gate: the interpolators' stages on simulation-only stage clocks (HG_SIM_GATE,
    tb/native/device/README.md "Stage clocks"; False: every stage on clk, the same results);
    pgo: compiled with a profile of a short training run (pgo_enabled() when None; never with
    a trace), the same results;
    saboteur: a hapgate.flows.saboteur.Design of this clock: its netlist in the top's place,
    with the injection ports driven from the run configuration's seu/stuck faults
    (tb/native/device/fault_inject.h; three axes, no stage clocks, no trace)."""
    if pgo is None:
        pgo = pgo_enabled()
    cfg, srcs, params = _top(clk_hz, mask, coarse, vel_obs)
    fi = ""
    if saboteur is not None:
        if mask != 7 or gate or trace or coarse or vel_obs:
            raise DeviceError("the saboteur build: three axes, gate=False, no trace, the paper's "
                              "angle and velocity")
        srcs, params = [saboteur.netlist], {}
        fi = f"-DHG_FI=1 -DHG_FI_SITES={saboteur.port_bits} "
    fw_srcs = sorted((FW / "src").glob("*.c")) + sorted((FW / "include").glob("*.h"))
    vflags = sim_defines(mask, gate) + (["--trace"] if trace else [])   # VCD (FST needs liblz4)
    if saboteur is not None:    # a netlist large enough to be split: the wheel's PCH breaks that
        vflags += ["--output-split", "0"]
    defs = (f"HG_SCENE_K_MAX_TEST={K_MAX_TEST:.1f}",) if test_limits else ()
    return native.verilate_harness(
        "device_harness" if saboteur is None else "device_harness_fi", "hapgate_top", srcs,
        params, HARNESS,
        cflags=(f"-std=c++17 -DCLK_HZ={clk_hz} -DAXIS_MASK={mask} -DHG_TRACE={int(trace)} "
                f"-DHG_SIM_GATE={int(gate)} {fi}"
                f"-DHG_LOAD_CLOCKS={cfg.comm.load_clocks + 1} -DHG_DAC_BITS={cfg.comm.dac_bits} "
                f"-DHG_DAC_OFFSET_BINARY={int(cfg.comm.offset_binary)} "
                f"-I{HERE} -I{FW / 'include'}" + "".join(f" -D{d}" for d in defs)),
        ldflags="fw/libhgfw.a -lm",
        inputs=[HERE / "plant.h", HERE / "uart_link.h", HERE / "view_link.h",
                HERE / "harness_common.h", HERE / "stage_clocks.h", HERE / "bus_hal.h",
                HERE / "dac_word.h", HERE.parent / "vl_internals.h", *fw_srcs,
                *([HERE / "fault_inject.h"] if saboteur is not None else [])],
        prepare=functools.partial(cosim._fw_lib, defines=defs), vflags=vflags,
        train=functools.partial(_train, clk_hz, mask, test_limits, coarse, vel_obs)
        if pgo and not trace else None)


# ---------------------------------------------------------------------------------- the run
def parts(scene: Any, mask: int | None = None) -> tuple[list[str], list[str]]:
    """What a run of the scene builds and what it skips (the table's first lines)."""
    m = axis_mask(scene) if mask is None else int(mask)
    built = [f"interpolator axis {i}" for i in range(3) if m >> i & 1]
    built += ["commutator + DAC scheduler", "bus + register file", "firmware (dsp-fw)",
              f"plant ({', '.join(str(a) for a in scene.run.axes)} free)"]
    skipped = [f"axis {i} (interpolator, signals; joint held)" for i in range(3)
               if not m >> i & 1]
    skipped += [] if scene.run.trace else ["waveform trace"]
    skipped += [] if record_mask(scene) & 1 else ["plant records"]
    return built, skipped


def simulate(scene: Any, clk_hz: int | None = None, mask: int | None = None,
             progress: Any = None, out_dir: Path | None = None, gate: bool = True,
             pgo: bool | None = None, view: Any = None, saboteur: Any = None,
             extra: str = "", timeout_s: float | None = None) -> Raw:
    """Build what the scene needs (or the given clock/mask) and run it once; at model fidelity
    the golden models' harness (hapgate.device.model). gate=False: the rtl build without the
    interpolators' simulation-only stage clocks; pgo: with or without profile-guided
    optimisation (None: pgo_enabled()); build(): the same results either way, slower.
    view: a hapgate.device.telemetry.Feed to stream the live view to (rtl fidelity only).
    saboteur, extra: the saboteur build (build()) and run-configuration lines added to the
    scene's (its seu/stuck fault: hapgate.device.seu); timeout_s: the harness is stopped after
    that many wall seconds (a DeviceError)."""
    if scene.run.fidelity == "model":
        if view is not None:
            raise DeviceError("the live view needs run.fidelity = 'rtl'")
        return model.simulate(scene, clk_hz, mask, progress, out_dir)
    at_soc = scene.run.fidelity == "soc"
    trace = bool(scene.run.trace)
    if at_soc:
        if view is not None or saboteur is not None:
            raise DeviceError("the live view and the saboteur build need run.fidelity = 'rtl'")
        clk, m = soc.CLK_HZ, 7
        exe = soc.build(link_script(scene).baud if scripted_pc(scene) else soc.BAUD)
    else:
        clk = choose_clock(scene) if clk_hz is None else int(clk_hz)
        m = axis_mask(scene) if mask is None else int(mask)
        exe = build(clk, m, trace, bool(getattr(scene.firmware, "test_limits", False)),
                    _coarse(scene), _observer(scene), gate=gate, pgo=pgo, saboteur=saboteur)
    q0 = start_pose(scene)
    built, skipped = soc.parts(scene) if at_soc else parts(scene, m)
    with tempfile.TemporaryDirectory(prefix="scene-", dir=ensure(BUILD / "native" / "runs")) as t:
        tmp = Path(t) if out_dir is None else ensure(out_dir)
        (tmp / "plant.cfg").write_text(plant_config(scene, q0))
        view_cfg, fds = view.open() if view is not None else ("", ())
        soc_cfg = soc.prepare(scene, q0, tmp, scripted_pc(scene)) if at_soc else ""
        (tmp / "run.cfg").write_text(run_config(scene, q0) + view_cfg + extra + soc_cfg)
        argv = [str(exe), str(tmp / "plant.cfg"), str(tmp / "run.cfg"), str(tmp)]
        if scripted_pc(scene):
            script = link_script(scene)
            (tmp / "link.script").write_text(script.text)
            (tmp / "link.cfg").write_text(f"script = {tmp / 'link.script'}\n"
                                          f"baud = {script.baud}\n")
            argv.append(str(tmp / "link.cfg"))
            built.append("scripted PC on the link")
        t0 = time.perf_counter()
        proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, pass_fds=fds, cwd=tmp if at_soc else None)
        if view is not None:
            view.started(tmp)
        timer = threading.Timer(timeout_s, proc.kill) if timeout_s else None
        if timer is not None:
            timer.start()
        try:
            errs = _progress_reader(proc, float(scene.run.duration_s), progress)
            stdout = proc.stdout.read() if proc.stdout else ""
            rc = proc.wait()
        finally:
            if timer is not None:
                timer.cancel()
            if proc.poll() is None:     # interrupted (Ctrl-C): the harness goes too
                proc.kill()
                proc.wait()
            if view is not None:
                view.finished()
        wall = time.perf_counter() - t0
        if rc != 0:
            raise DeviceError(f"device harness failed ({rc}): {errs.strip()}")
        summary = dict(kv.split("=", 1) for kv in stdout.split())
        if int(summary["frame_bytes"]) != FRAME_DT.itemsize or \
                int(summary["tick_bytes"]) != TICK_DT.itemsize:
            raise DeviceError("record layout of the harness and the runner differ")
        frames = np.fromfile(tmp / "frames.bin", dtype=FRAME_DT)
        ticks = np.fromfile(tmp / "ticks.bin", dtype=TICK_DT)
        loads = np.fromfile(tmp / "loads.bin", dtype=LOAD_DT)
        adc = np.fromfile(tmp / "adc.bin", dtype=np.int8).reshape(-1, 6)
        trace_path = None
        if trace and (tmp / "trace.vcd").exists():
            if out_dir is None:
                raise DeviceError("trace = true needs an output directory")
            trace_path = tmp / "trace.vcd"
    return Raw(summary, frames, ticks, loads, float(summary.get("wall_s", wall)), clk, m,
               built, skipped, trace_path, adc)


# ---------------------------------------------------------------------------------- metrics
def _j_inv_t(q: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Endpoint force the motor torques produce: F = J^-T tau, per row."""
    jac = kinematics.jacobian(q)                       # (n, 3, 3)
    return np.linalg.solve(np.swapaxes(jac, -1, -2), tau[..., None])[..., 0]


def events(scene: Any, raw: Raw) -> list[dict[str, Any]]:
    """Safety events: the cause (the FPGA's own detection where it has one), the first DAC load
    from which every affected channel stays at zero, and the reaction time between them."""
    out: list[dict[str, Any]] = []
    s = raw.summary
    scene0_us = int(s["scene0_us"])
    clk = raw.clk_hz
    loads = raw.loads
    t_load = (loads["edge"] / clk) - scene0_us * 1e-6
    for f in scene.faults:
        if f.kind == "dropout":
            cause = f.at_s + (LOSS_SAMPLES - 1) * 1e-6 + 1e-6      # the 16th bad sample
            motors = [int(f.axis)]
        elif f.kind in ("watchdog", "hang"):
            cause = int(s["last_key_edge"]) / clk - scene0_us * 1e-6 + int(s["wdog_us"]) * 1e-6
            motors = [0, 1, 2]
        else:
            continue
        ch_mask = np.isin(loads["ch"] // 2, motors)
        sel = ch_mask & (t_load >= cause)
        codes, times = loads["code"][sel], t_load[sel]
        nz = np.flatnonzero(codes != 0)
        if times.size == 0:
            zero_t = math.nan
        elif nz.size == 0:
            zero_t = float(times[0])
        elif nz[-1] + 1 < times.size:
            zero_t = float(times[nz[-1] + 1])
        else:
            zero_t = math.nan                                   # never reached zero
        # the load that reaches zero completes the channel's torque: its whole frame
        react = (zero_t - cause) * 1e6 if math.isfinite(zero_t) else math.inf
        out.append({"kind": f.kind, "axis": getattr(f, "axis", None), "cause_s": cause,
                    "zero_torque_s": zero_t, "reaction_us": react})
    return out


def metrics(scene: Any, raw: Raw) -> tuple[dict[str, Any], dict[str, list[float]],
                                            list[dict[str, Any]]]:
    fr, tk = raw.frames, raw.ticks
    m: dict[str, Any] = {}
    per: dict[str, list[float]] = {}
    evs = events(scene, raw)
    first_fault = min([f.at_s for f in scene.faults], default=math.inf)
    built = [int(a) for a in scene.run.axes]
    # position: the firmware's snapshot against the true angle of that sample (counts)
    ok = (tk["t"] >= 0) & (tk["t"] < first_fault)
    if ok.any():
        e = tk["pos_err"][ok][:, built].astype(float)
        m["position_error_counts"] = float(np.abs(e).max())
        m["slips"] = int((np.abs(e) >= 256).any(axis=0).sum())
        per["pos_err_rms_counts"] = [float(v) for v in np.sqrt((e * e).mean(axis=0))]
        per["pos_err_max_counts"] = [float(v) for v in np.abs(e).max(axis=0)]
    err = int(raw.summary["fw_err"])
    m["fw_error"] = ERR_NAMES[err] if err < len(ERR_NAMES) else str(err)
    m["fw_error_axis"] = int(raw.summary["fw_err_axis"])
    if evs:
        m["zero_torque_us"] = float(max(e["reaction_us"] for e in evs))
    if "link_good" in raw.summary:
        m["link_good_frames"] = int(raw.summary["link_good"])
        m["link_bad_frames"] = int(raw.summary["link_bad"])
        m["link_timeouts"] = int(raw.summary["link_timeouts"])
        last = link_script(scene).last_force_us * 1e-6
        f_norm = np.linalg.norm(tk["f_fw"], axis=1) if tk.size else np.zeros(0)
        after = np.flatnonzero((tk["t"] > last) & (f_norm == 0)) if tk.size else np.zeros(0, int)
        if math.isfinite(last) and np.linalg.norm(scene.pc.force_n if scene.pc else 0) > 0:
            # the PC's last force: rendered until it expires, zero from then on
            m["pc_force_zero_ms"] = (float(tk["t"][after[0]] - last) * 1e3
                                     if after.size and (f_norm[after[0]:] == 0).all()
                                     else math.inf)
    if fr.size and record_mask(scene) & 1:
        q, tau, p = fr["q"], fr["tau"], fr["p"]
        f_dev = _j_inv_t(q, tau)
        # the wall law at the true endpoint (the firmware renders it from its own estimate)
        if scene.env.kind == "wall":
            n = np.asarray(scene.env.normal, float)
            n = n / np.linalg.norm(n)
            depth = (np.asarray(scene.env.point, float) - p) @ n
            v = np.gradient(p, fr["t"], axis=0) if fr.size > 2 else np.zeros_like(p)
            law = np.maximum(0.0, scene.env.k * depth - scene.env.b * (v @ n))
            f_law = np.where(depth[:, None] > 0, law[:, None] * n, 0.0)
            path = getattr(scene.hand, "path", None) or ()
            t_rest = (float(path[-1][0]) if len(path) else 0.0) + STEADY_AFTER_S
            steady = (np.linalg.norm(v, axis=1) < STEADY_SPEED) & (fr["t"] > t_rest) & \
                (fr["t"] < first_fault) & (depth > STEADY_DEPTH)
            if steady.any():
                m["force_error_n"] = float(np.linalg.norm(f_dev - f_law, axis=1)[steady].max())
                m["force_samples"] = int(steady.sum())
                m["force_speed_max"] = float(np.linalg.norm(v, axis=1)[steady].max())
        # delivered against commanded torque, per motor (1 kHz-class servo: settled frames)
        if tk.size:
            idx = np.searchsorted(tk["t"], fr["t"], side="right") - 1
            have = idx >= 0
            since = np.where(have, fr["t"] - tk["t"][np.maximum(idx, 0)], -1.0)
            cmd = np.where(have[:, None], tk["tau_fw"][np.maximum(idx, 0)], 0.0)
            drive = np.where(have, tk["drive"][np.maximum(idx, 0)] != 0, False)
            settled = drive & (since > 4.5e-4) & (fr["t"] < first_fault)
            ratios = []
            for j in range(3):
                sel = settled & (np.abs(cmd[:, j]) > 0.01)
                if sel.sum() >= 8:
                    ratios.append(float((tau[sel, j] * cmd[sel, j]).sum() /
                                        (cmd[sel, j] ** 2).sum()))
                else:
                    ratios.append(math.nan)
            per["torque_ratio"] = ratios
            fin = [r for r in ratios if math.isfinite(r)]
            if fin:
                m["torque_ratio"] = float(min(fin))
        # mechanical energy of the linkage (kinetic + the hand's spring): meaningful as a
        # conservation check when nothing injects or removes energy (coast.toml)
        e = fr["energy"]
        if e.size and e[0] > ENERGY_MIN_J:     # a scene that starts at rest has nothing to keep
            m["energy_drift_frac"] = float(np.abs(e / e[0] - 1).max())
    return m, per, evs


def run(scene: Any, progress: Any = None, out_dir: Path | None = None, view: Any = None) -> Any:
    """Run a validated scene; returns a hapgate.device.result.RunResult. view: a live view's
    hapgate.device.telemetry.Feed (simulate())."""
    work = None
    if scene.run.trace:        # the waveform goes beside the scene's other outputs
        work = ensure((out_dir or BUILD / "scenes" / scene.name) / "harness")
    raw = simulate(scene, progress=progress, out_dir=work, view=view)
    if raw.trace is not None:
        raw.built.append(f"waveform trace {raw.trace}")
    m, per, evs = metrics(scene, raw)
    if funcov.active():   # coverage runs: the faults applied, the zero-torque paths measured
        funcov.sample_device([(f.kind, int(f.axis) if f.kind == "dropout" else "all")
                              for f in scene.faults])
        if str(scene.run.fidelity) == "rtl":
            funcov.sample_top(["loss" if e.get("kind") == "dropout" else "watchdog"
                               for e in evs if math.isfinite(e["reaction_us"])])
    arrays = arrays_of(scene, raw)
    sim_s = float(raw.summary["sim_s"])
    return RunResult(scene=scene, sim_s=sim_s, wall_s=raw.wall_s,
                     rtf=sim_s / raw.wall_s if raw.wall_s > 0 else math.inf,
                     fidelity=str(scene.run.fidelity), clk_hz=raw.clk_hz,
                     axes=tuple(scene.run.axes),
                     built=raw.built, skipped=raw.skipped, arrays=arrays, events=evs,
                     metrics=m, per_axis=per, cpu_s=float(raw.summary.get("cpu_s", "nan")))


def arrays_of(scene: Any, raw: Raw) -> dict[str, np.ndarray]:
    rec = set(scene.run.record)
    fr = raw.frames
    a: dict[str, np.ndarray] = {"t": fr["t"].copy()}
    for k in ("q", "p", "f_hand", "tau"):
        if k in rec:
            a[k] = fr[k].copy()
    if "current" in rec:
        a["current"] = fr["i_ab"].copy()
    if "dac" in rec:
        a["dac"] = fr["dac"].astype(np.int16)
        a["dac_t"] = fr["t"].copy()
    if "adc" in rec and raw.adc is not None:
        a["adc"] = raw.adc.copy()                       # A0 B0 A1 B1 A2 B2 per 1 us sample
        a["adc_t"] = np.arange(raw.adc.shape[0]) * 1e-6
    tk = raw.ticks
    if "pos" in rec:
        a["pos"] = tk["pos"].copy()                     # snapshot positions per servo tick
        a["pos_t"] = tk["t"].copy()
    a["tick_t"] = tk["t"].copy()
    a["tick_pos_err_counts"] = tk["pos_err"].copy()
    a["tick_f_cmd"] = tk["f_fw"].copy()
    a["tick_tau_cmd"] = tk["tau_fw"].copy()
    return a
