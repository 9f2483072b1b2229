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
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..base.paths import BUILD, ROOT, TB, ensure
from ..golden import encsig, interp, kinematics, pclink
from ..golden.interp import InterpConfig
from ..golden.top import TopConfig, blocks
from ..runners import cosim, native

HERE = TB / "native" / "device"
HARNESS = [HERE / "device_harness.cpp", HERE / "harness_common.cpp", HERE / "plant.cpp",
           HERE / "uart_link.cpp"]
FW = ROOT / "dsp-fw"
MIN_CLK_HZ = 6_000_000       # lowest clock of the grid-aligned bus (README): D >= 6 clocks per us
OBS_MIN_CLK_HZ = 12_000_000  # run.velocity = "observer": its extra clock of latency, with margin
FULL_CLK_HZ = 48_000_000     # the shipped default
SAMPLE_HZ = 1_000_000
K_MAX_TEST = 50_000.0        # N/m: HG_SCENE_K_MAX_TEST of a firmware.test_limits build
T_SWEEP0_S, T_SWEEP_S, T_SETTLE_S = 100e-6, 6e-3, 3e-3   # homing before scene time 0
SWEEP_DEG = 0.5              # homing sweep, ending at q0; the index lies half-way
LOSS_SAMPLES = 16            # interpolator: the 16th bad sample raises signal loss
ENV_KINDS = {"none": 0, "wall": 1, "spring": 2, "viscous": 3, "pc": 4}
FAULT_KINDS = {"dropout": 1, "hang": 2, "watchdog": 3}
ERR_NAMES = ("NONE", "NONFINITE", "AXIS_FAULT", "ENCODER", "STALE", "OVERRUN", "WATCHDOG",
             "FPGA_ID", "CONFIG")
HAND_KINDS = {"none": 0, "spring": 1, "fixed": 2}
COUNTS_PER_REV = 1 << 20
ENERGY_MIN_J = 1e-9          # energy_drift_frac only for a scene that starts moving (coast.toml)
# the wall's steady state: the hand's target at rest for 5 ms, the endpoint slower than 20 mm/s
# and at least 0.2 mm into the wall (the force error there includes k * speed * the servo's
# sample-and-hold delay: 0.04 N at 20 mm/s into 20 N/cm at 1 kHz)
STEADY_AFTER_S, STEADY_SPEED, STEADY_DEPTH = 5e-3, 2e-2, 2e-4
CODE_FS = 32767              # firmware torque code at full scale

FRAME_DT = np.dtype([("t", "<f8"), ("q", "<f8", 3), ("p", "<f8", 3), ("f_hand", "<f8", 3),
                     ("tau", "<f8", 3), ("i_ab", "<f8", 6), ("energy", "<f8"),
                     ("dac", "<i2", 6), ("pad", "<i2"),
                     ("pad2", "<u4")], align=True)
TICK_DT = np.dtype([("t", "<f8"), ("q_fw", "<f8", 3), ("q_true", "<f8", 3), ("p_fw", "<f8", 3),
                    ("f_fw", "<f8", 3), ("tau_fw", "<f8", 3), ("pos_err", "<i4", 3),
                    ("pos", "<i4", 3), ("status", "<u4"), ("err", "u1"), ("err_axis", "u1"),
                    ("drive", "u1"),
                    ("pad", "u1")], align=True)
LOAD_DT = np.dtype([("edge", "<i8"), ("ch", "<i4"), ("code", "<i4")])


class DeviceError(RuntimeError):
    """The harness failed (build, configuration, or a run that did not complete)."""


# ---------------------------------------------------------------------------------- decisions
def choose_clock(scene: Any) -> int:
    """The scene's clock, or (clk_hz = 0) the lowest at which the recorded outputs are
    bit-identical to the 48 MHz build: MIN_CLK_HZ, whole MHz, and a whole number of clocks per
    servo tick (README, "Why any clock gives the same result")."""
    clk = int(scene.run.clk_hz) or (OBS_MIN_CLK_HZ if _observer(scene) else MIN_CLK_HZ)
    if clk % SAMPLE_HZ or clk < MIN_CLK_HZ:
        raise DeviceError(f"clk_hz {clk}: the virtual device needs a whole number of MHz "
                          f">= {MIN_CLK_HZ // 1_000_000} MHz")
    while clk % int(scene.run.servo_hz):
        clk += SAMPLE_HZ
    return clk


def axis_mask(scene: Any) -> int:
    return sum(1 << int(a) for a in scene.run.axes)


def _top(clk_hz: int, mask: int, coarse: bool = False,
         vel_obs: bool = False) -> tuple[TopConfig, list[Path], dict[str, Any]]:
    """The top's configuration, sources and parameters of a virtual-device build."""
    cfg = TopConfig(clk_hz=clk_hz, interp=InterpConfig(coarse=coarse, vel_obs=vel_obs),
                    vel_obs_sel=vel_obs)
    srcs = [ROOT / "rtl" / s for s in blocks()[0].sources]
    return cfg, srcs, cfg.rtl_params() | {"AXIS_MASK": mask}


def build_gate_equiv(clk_hz: int, mask: int, gate: bool) -> Path:
    """The stage clocks' equivalence harness (tb/native/device/gate_equiv.cpp) on the device's
    top, with the stage clocks (gate) or with every register on clk (cached)."""
    _, srcs, params = _top(clk_hz, mask)
    return native.verilate_harness(
        "gate_equiv", blocks()[0].top, srcs, params, [HERE / "gate_equiv.cpp"],
        cflags=f"-std=c++17 -DCLK_HZ={clk_hz} -DHG_SIM_GATE={int(gate)} -I{FW / 'include'}",
        inputs=[HERE / "stage_clocks.h", *sorted((FW / "include").glob("*.h"))],
        vflags=["-DHG_SIM"] + (["-DHG_SIM_GATE"] if gate else []))


def pgo_enabled() -> bool:
    """Profile-guided optimisation of the rtl fidelity's build (README "Simulation speed"): on
    unless HG_PGO=0 (the test suite turns it off: it doubles a build's compile time and changes
    no result, which tb/device/test_closed_loop.py checks)."""
    return os.environ.get("HG_PGO", "1") != "0"


TRAIN_S = 0.03   # s of scene time in a PGO training run (after the 9.1 ms homing)


def _train(clk_hz: int, mask: int, test_limits: bool, coarse: bool, vel_obs: bool,
           exe: Path) -> None:
    """The PGO training run of a device build: TRAIN_S of scenes/wall.toml (homing, the hand
    pushing into the wall) on the build's own clock and axes."""
    from . import scene as sc
    s = sc.load(ROOT / "scenes" / "wall.toml").override({
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
          pgo: bool | None = None) -> Path:
    """Verilate the top (HG_SIM, AXIS_MASK) with the harness, plant and firmware (cached).
    test_limits: the firmware built with HG_SCENE_K_MAX_TEST (scene key firmware.test_limits);
    coarse: plain quadrature, the interpolator's fine angle zeroed (run.position);
    vel_obs: the tracking velocity observer built and reported as VEL (run.velocity);
    gate: the interpolators' stages on simulation-only stage clocks (HG_SIM_GATE,
    tb/native/device/README.md "Stage clocks"; False: every stage on clk, the same results);
    pgo: compiled with a profile of a short training run (pgo_enabled() when None; never with
    a trace), the same results."""
    if pgo is None:
        pgo = pgo_enabled()
    cfg, srcs, params = _top(clk_hz, mask, coarse, vel_obs)
    block = blocks()[0]
    fw_srcs = sorted((FW / "src").glob("*.c")) + sorted((FW / "include").glob("*.h"))
    vflags = (["-DHG_SIM"] + (["-DHG_SIM_GATE"] if gate else [])
              + (["--trace"] if trace else []))   # VCD: FST needs liblz4 headers
    defs = (f"HG_SCENE_K_MAX_TEST={K_MAX_TEST:.1f}",) if test_limits else ()
    return native.verilate_harness(
        "device_harness", block.top, srcs, params, HARNESS,
        cflags=(f"-std=c++17 -DCLK_HZ={clk_hz} -DAXIS_MASK={mask} -DHG_TRACE={int(trace)} "
                f"-DHG_SIM_GATE={int(gate)} "
                f"-DHG_LOAD_CLOCKS={cfg.comm.load_clocks + 1} "
                f"-I{HERE} -I{FW / 'include'}" + "".join(f" -D{d}" for d in defs)),
        ldflags="fw/libhgfw.a -lm",
        inputs=[HERE / "plant.h", HERE / "uart_link.h", HERE / "harness_common.h",
                HERE / "stage_clocks.h", *fw_srcs],
        prepare=functools.partial(cosim._fw_lib, defines=defs), vflags=vflags,
        train=functools.partial(_train, clk_hz, mask, test_limits, coarse, vel_obs)
        if pgo and not trace else None)


# ---------------------------------------------------------------------------------- configs
def _vec(x: Any) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(x))


def start_pose(scene: Any) -> np.ndarray:
    """Initial joint angles [rad]: q0_deg, else the IK of the hand path's first point, else the
    working pose (4, 46, 43) degrees."""
    if getattr(scene.run, "q0_deg", None) is not None:
        return np.deg2rad(np.asarray(scene.run.q0_deg, dtype=float))
    path = getattr(scene.hand, "path", None) or ()
    if len(path):
        q, ok = kinematics.ik(np.asarray(path[0][1:4], dtype=float))
        if not bool(np.all(ok)):
            raise DeviceError("hand.path[0]: outside the workspace (no inverse kinematics)")
        return np.asarray(q, dtype=float)
    return np.deg2rad([4.0, 46.0, 43.0])


def q_index(q0: np.ndarray) -> np.ndarray:
    """The index (and the windings' zero) of each encoder: half-way along the homing sweep."""
    return q0 - np.deg2rad(SWEEP_DEG) / 2


def _enc(scene: Any, i: int) -> Any:
    return scene.encoders[i]


def plant_config(scene: Any, q0: np.ndarray) -> str:
    pl, hand = scene.plant, scene.hand
    built = set(int(a) for a in scene.run.axes)
    enc = [_enc(scene, i) for i in range(3)]
    noise = [enc[i].noise_lsb if i in built else 0.0 for i in range(3)]
    lines = [
        f"dt_s = {pl.dt_s!r}", f"kt_nm_per_a = {pl.kt_nm_per_a!r}", f"r_ohm = {pl.r_ohm!r}",
        f"j_rotor_kg_m2 = {pl.j_rotor_kg_m2!r}", f"pole_pairs = {pl.pole_pairs}",
        f"i_max_a = {pl.i_max_a!r}", f"current_bw_hz = {pl.current_bw_hz!r}",
        f"m_link_kg = {pl.m_link_kg!r}", f"m_handle_kg = {pl.m_handle_kg!r}",
        f"b_visc_nms = {_vec(pl.b_visc_nms)}", f"tau_coulomb_nm = {_vec(pl.tau_coulomb_nm)}",
        f"hand_kind = {HAND_KINDS[hand.kind]}",
        f"enc_amplitude = {_vec([e.amplitude for e in enc])}",
        f"enc_offset_a = {_vec([e.offset_a for e in enc])}",
        f"enc_offset_b = {_vec([e.offset_b for e in enc])}",
        f"enc_gain_a = {_vec([e.gain_a for e in enc])}",
        f"enc_gain_b = {_vec([e.gain_b for e in enc])}",
        f"enc_phase_deg = {_vec([e.phase_deg for e in enc])}",
        f"enc_h2 = {_vec([e.h2 for e in enc])}", f"enc_h3 = {_vec([e.h3 for e in enc])}",
        f"enc_noise_lsb = {_vec(noise)}",
        f"q_index = {_vec(q_index(q0))}", f"q0 = {_vec(q0 - np.deg2rad(SWEEP_DEG))}",
        f"free = {_vec([1.0 if i in built else 0.0 for i in range(3)])}",
        f"seed = {int(scene.run.seed)}",
        f"t0_s = {-(T_SWEEP0_S + T_SWEEP_S + T_SETTLE_S)!r}",
    ]
    gk = list(getattr(pl, "gravity_k", ()) or ())
    if gk:
        lines += ["gravity_on = 1", f"gravity_k = {_vec(gk)}",
                  f"gravity_q = {_vec(getattr(pl, 'gravity_q', (0.0, 0.0)))}"]
    if hand.kind == "spring":
        lines += [f"hand_k = {hand.k!r}", f"hand_b = {hand.b!r}"]
        path = np.asarray(hand.path if hand.path else [[0.0, *kinematics.fk(q0)]], dtype=float)
        lines.append(f"hand_path = {_vec(path)}")
    return "\n".join(lines) + "\n"


def _observer(scene: Any) -> bool:
    return getattr(scene.run, "velocity", "fir") == "observer"


def _coarse(scene: Any) -> bool:
    return getattr(scene.run, "position", "interpolated") == "quadrature"


def hold_values(scene: Any, q0: np.ndarray) -> dict[str, list[int]]:
    """What the interpolator of a held (not built) axis reports after the homing sweep: the
    golden model run on the same sweep, noise-free (README, "Axes that are not built")."""
    out = {"hold_pos_homed": [0, 0, 0], "hold_index_pos": [0, 0, 0], "hold_index_count": [0, 0, 0]}
    built = set(int(a) for a in scene.run.axes)
    n = int(round((T_SWEEP0_S + T_SWEEP_S + T_SETTLE_S) * SAMPLE_HZ))
    g = np.arange(1, n + 1) * 1e-6                      # sample k is the grid point k + 1
    u = np.clip((g - T_SWEEP0_S) / T_SWEEP_S, 0.0, 1.0)
    s = 0.5 * (1 - np.cos(np.pi * u))
    qi = q_index(q0)
    for i in range(3):
        if i in built:
            continue
        e = _enc(scene, i)
        q = q0[i] - np.deg2rad(SWEEP_DEG) * (1 - s)
        lines = (q - qi[i]) / (2 * np.pi) * encsig.LINES
        spec = replace(e.spec(seed=0), noise_lsb=0.0)
        a, b = encsig.adc_codes(lines, spec)
        o = interp.run(a, b, encsig.index_bit(lines), InterpConfig(coarse=_coarse(scene)),
                       arm_at=[0])
        if not bool(o.homed[-1]):
            raise DeviceError(f"axis {i}: the homing sweep did not home the held axis")
        out["hold_pos_homed"][i] = int(o.pos_homed[-1])
        out["hold_index_pos"][i] = int(o.index_pos[-1])
        out["hold_index_count"][i] = int(o.index_count[-1])
    return out


def run_config(scene: Any, q0: np.ndarray) -> str:
    env = scene.env
    lines = [f"duration_s = {scene.run.duration_s!r}", f"servo_hz = {int(scene.run.servo_hz)}",
             f"env_kind = {ENV_KINDS[env.kind]}",
             f"env_point = {_vec(getattr(env, 'point', (0, 0, 0)) or (0, 0, 0))}",
             f"env_normal = {_vec(getattr(env, 'normal', (0, 0, 0)) or (0, 0, 0))}",
             f"env_k = {float(getattr(env, 'k', 0.0) or 0.0)!r}",
             f"env_b = {float(getattr(env, 'b', 0.0) or 0.0)!r}",
             f"env_ki = {float(getattr(env, 'ki', 0.0) or 0.0)!r}",
             f"q0 = {_vec(q0)}", f"q_index = {_vec(q_index(q0))}",
             f"qd0 = {_vec(np.deg2rad(getattr(scene.run, 'qd0_deg_s', None) or (0, 0, 0)))}",
             f"sweep_rad = {math.radians(SWEEP_DEG)!r}", f"t_sweep_s = {T_SWEEP_S!r}",
             f"t_settle_s = {T_SETTLE_S!r}",
             f"comm_err = {' '.join(str(int(v)) for v in scene.firmware.comm_offset_error_counts)}",
             f"record = {record_mask(scene)}"]
    timeout_ms = getattr(scene.firmware, "pc_force_timeout_ms", None)
    if timeout_ms is not None:
        ticks = int(round(timeout_ms * scene.run.servo_hz / 1000))
        lines.append(f"pc_force_timeout_ticks = {ticks}")
    for k, v in hold_values(scene, q0).items():
        lines.append(f"{k} = {' '.join(str(x) for x in v)}")
    for f in scene.faults:
        if f.kind == "link_garbage":
            continue                 # on the scripted PC's line (link_script), not a harness fault
        if f.kind not in FAULT_KINDS:
            raise DeviceError(f"fault kind {f.kind!r} is not simulated by the virtual device yet")
        ax = -1 if getattr(f, "axis", None) is None else int(f.axis)
        lines.append(f"fault = {f.at_s!r} {FAULT_KINDS[f.kind]} {max(ax, 0)}")
    return "\n".join(lines) + "\n"


def scripted_pc(scene: Any) -> bool:
    """Does the scene run with the scripted PC on its link ([pc], or a link_garbage fault)?"""
    return scene.env.kind == "pc" and (getattr(scene, "pc", None) is not None or
                                       any(f.kind == "link_garbage" for f in scene.faults))


@dataclass(frozen=True)
class LinkScript:
    text: str                    # the harness's script file: "T_US HEX" per burst
    baud: int
    last_force_us: float         # scene time the last good SET_FORCE has crossed the line (us)


def link_script(scene: Any) -> LinkScript:
    """The scripted PC (scene.PcCfg): ENABLE at scene time 0, then SET_FORCE(force_n) every
    period_ms until the first link_garbage fault; each link_garbage fault a burst of seeded
    random bytes (numpy PCG64, seed = run.seed and the fault's index) at its time."""
    from .scene import PcCfg
    pc = getattr(scene, "pc", None) or PcCfg()
    byte_us = 10.0 * 1e6 / pc.baud
    garbage = [(i, f) for i, f in enumerate(scene.faults) if f.kind == "link_garbage"]
    stop_us = garbage[0][1].at_s * 1e6 if garbage else scene.run.duration_s * 1e6
    bursts: list[tuple[int, bytes]] = []
    seq = 0

    def frame(msg: int, data: bytes) -> bytes:
        nonlocal seq
        seq = (seq + 1) & 0xFF
        return pclink.encode(msg, seq, data)

    bursts.append((0, frame(pclink.ENABLE, b"\x01")))
    line_free = len(bursts[0][1]) * byte_us
    last_force = math.nan
    period = pc.period_ms * 1e3
    for k in range(int(math.ceil(stop_us / period))):
        t = int(round(k * period))
        if t >= stop_us:
            break
        fr = frame(pclink.SET_FORCE, pclink.set_force(*pc.force_n))
        line_free = max(line_free, float(t)) + len(fr) * byte_us
        last_force = line_free
        bursts.append((t, fr))
    for i, f in garbage:
        rng = np.random.default_rng([int(scene.run.seed), 0x6C67, i])
        bursts.append((int(round(f.at_s * 1e6)), rng.integers(0, 256, f.bytes, dtype=np.uint8)
                       .tobytes()))
    bursts.sort(key=lambda b: b[0])
    text = "".join(f"{t} {b.hex()}\n" for t, b in bursts)
    return LinkScript(text, pc.baud, last_force)


PLANT_RECORDS = ("q", "p", "f_hand", "tau", "current")


def record_mask(scene: Any) -> int:
    rec = set(scene.run.record)
    m = 1 if rec & set(PLANT_RECORDS) else 0
    if "dac" in rec or scene.faults:
        m |= 2      # the DAC loads time the safety reactions
    if "adc" in rec:
        m |= 4
    return m


# ---------------------------------------------------------------------------------- the run
@dataclass
class Raw:
    """What one harness run produced, before the metrics."""
    summary: dict[str, str]
    frames: np.ndarray
    ticks: np.ndarray
    loads: np.ndarray
    wall_s: float
    clk_hz: int
    mask: int
    built: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    trace: Path | None = None
    adc: np.ndarray | None = None


def _progress_reader(proc: subprocess.Popen, duration: float, progress: Any) -> str:
    err_lines: list[str] = []
    assert proc.stderr is not None
    for line in proc.stderr:
        if line.startswith("progress "):
            if progress is not None:
                progress(min(float(line.split()[1]), duration), duration)
        else:
            err_lines.append(line)
    return "".join(err_lines)


def simulate(scene: Any, clk_hz: int | None = None, mask: int | None = None,
             progress: Any = None, out_dir: Path | None = None, gate: bool = True,
             pgo: bool | None = None) -> Raw:
    """Build what the scene needs (or the given clock/mask) and run it once; at model fidelity
    the golden models' harness (hapgate.device.model). gate=False: the rtl build without the
    interpolators' simulation-only stage clocks; pgo: with or without profile-guided
    optimisation (None: pgo_enabled()); build(): the same results either way, slower."""
    if scene.run.fidelity == "model":
        from . import model
        return model.simulate(scene, clk_hz, mask, progress, out_dir)
    clk = choose_clock(scene) if clk_hz is None else int(clk_hz)
    m = axis_mask(scene) if mask is None else int(mask)
    trace = bool(scene.run.trace)
    exe = build(clk, m, trace, bool(getattr(scene.firmware, "test_limits", False)),
                _coarse(scene), _observer(scene), gate=gate, pgo=pgo)
    q0 = start_pose(scene)
    built = [f"interpolator axis {i}" for i in range(3) if m >> i & 1]
    built += ["commutator + DAC scheduler", "bus + register file", "firmware (dsp-fw)",
              f"plant ({', '.join(str(a) for a in scene.run.axes)} free)"]
    skipped = [f"axis {i} (interpolator, signals; joint held)" for i in range(3)
               if not m >> i & 1]
    skipped += [] if trace else ["waveform trace"]
    skipped += [] if record_mask(scene) & 1 else ["plant records"]
    with tempfile.TemporaryDirectory(prefix="scene-", dir=ensure(BUILD / "native" / "runs")) as t:
        tmp = Path(t) if out_dir is None else ensure(out_dir)
        (tmp / "plant.cfg").write_text(plant_config(scene, q0))
        (tmp / "run.cfg").write_text(run_config(scene, q0))
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
                                text=True)
        errs = _progress_reader(proc, float(scene.run.duration_s), progress)
        stdout = proc.stdout.read() if proc.stdout else ""
        rc = proc.wait()
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


def run(scene: Any, progress: Any = None, out_dir: Path | None = None) -> Any:
    """Run a validated scene; returns a hapgate.device.result.RunResult."""
    from .result import RunResult
    work = None
    if scene.run.trace:        # the waveform goes beside the scene's other outputs
        work = ensure((out_dir or BUILD / "scenes" / scene.name) / "harness")
    raw = simulate(scene, progress=progress, out_dir=work)
    if raw.trace is not None:
        raw.built.append(f"waveform trace {raw.trace}")
    m, per, evs = metrics(scene, raw)
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
