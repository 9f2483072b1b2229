"""What the native harnesses of the virtual device (tb/native/device/) share, at both
fidelities (rtl: hapgate.device.runner, model: hapgate.device.model): the record layouts, the
decisions a scene implies (clock, axes, start pose), the harness's configuration files, the
scripted PC and the raw records of one run. Kept apart so that runner -> model -> harness has no
cycle."""

from __future__ import annotations

import math
import subprocess
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..base.paths import ROOT, TB
from ..golden import encsig, interp, kinematics, pclink
from ..golden.interp import InterpConfig
from ..runners import cosim
from ..runners.records import FRAME_DT as FRAME_DT  # re-exported: runner, model, the tests
from ..runners.records import LOAD_DT as LOAD_DT
from ..runners.records import TICK_DT as TICK_DT
from .scene import PcCfg, index_at

HERE = TB / "native" / "device"
FW = ROOT / "dsp-fw"
MIN_CLK_HZ = 6_000_000       # lowest clock of the grid-aligned bus (README): D >= 6 clocks per us
OBS_MIN_CLK_HZ = 12_000_000  # run.velocity = "observer": its extra clock of latency, with margin
FULL_CLK_HZ = 48_000_000     # the shipped default
SAMPLE_HZ = 1_000_000
K_MAX_TEST = 50_000.0        # N/m: HG_SCENE_K_MAX_TEST of a firmware.test_limits build
T_HOLD_S = 9.1e-3            # power-up: a fixture holds the handle in q0 from reset to scene time 0
HOLD_SAMPLES = 64            # a held axis: the golden interpolator reads it after this many samples
LOSS_SAMPLES = 16            # interpolator: the 16th bad sample raises signal loss
ENV_KINDS = {"none": 0, "wall": 1, "spring": 2, "viscous": 3, "pc": 4}
# the [[fault]] kinds the harnesses simulate, by name (harness_common.h kFaultKinds: a test),
# the co-simulation's too; then the injections into the gateware's flip-flops, which only the
# device harness on the saboteur netlist simulates (hapgate.device.seu: not scene kinds)
HARNESS_FAULTS = (*cosim.FAULT_KINDS, "seu", "stuck")
ERR_NAMES = ("NONE", "NONFINITE", "AXIS_FAULT", "ENCODER", "STALE", "OVERRUN", "WATCHDOG",
             "FPGA_ID", "CONFIG", "FPGA_FAULT")
HAND_KINDS = {"none": 0, "spring": 1, "fixed": 2}
COUNTS_PER_REV = 1 << 20
ENERGY_MIN_J = 1e-9          # energy_drift_frac only for a scene that starts moving (coast.toml)
# the wall's steady state: the hand's target at rest for 5 ms, the endpoint slower than 20 mm/s
# and at least 0.2 mm into the wall (the force error there includes k * speed * the servo's
# sample-and-hold delay: 0.04 N at 20 mm/s into 20 N/cm at 1 kHz)
STEADY_AFTER_S, STEADY_SPEED, STEADY_DEPTH = 5e-3, 2e-2, 2e-4
CODE_FS = 32767              # firmware torque code at full scale



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


def q_index(q0: np.ndarray, scene: Any = None) -> np.ndarray:
    """The index of each encoder at start pose q0 (scene.index_at: plant.index_q_deg, else
    just below q0)."""
    return index_at(q0, getattr(getattr(scene, "plant", None), "index_q_deg", None))


def _plant_bringup(scene: Any) -> tuple[tuple[float, ...], tuple[bool, ...], tuple[int, ...]]:
    pl = scene.plant
    return (tuple(getattr(pl, "comm_offset_elec_deg", (0.0,) * 3)),
            tuple(getattr(pl, "phases_swapped", (False,) * 3)),
            tuple(getattr(pl, "encoder_dir", (1,) * 3)))


def calib_line(scene: Any) -> str:
    """The firmware's calibration (scene.calib(), hg_axis_calib_t words per axis), for the run
    configuration: `calib = flags dir swapped pole_pairs index_to_zero offset` x 3."""
    if not hasattr(scene, "calib"):
        return ""
    return "calib = " + " ".join(str(w) for a in scene.calib() for w in a.words())


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
        f"q_index = {_vec(q_index(q0, scene))}", f"q0 = {_vec(q0)}",
        f"comm_offset_deg = {_vec(_plant_bringup(scene)[0])}",
        f"phases_swapped = {_vec([1.0 if b else 0.0 for b in _plant_bringup(scene)[1]])}",
        f"encoder_dir = {_vec(_plant_bringup(scene)[2])}",
        f"free = {_vec([1.0 if i in built else 0.0 for i in range(3)])}",
        f"seed = {int(scene.run.seed)}",
        f"t0_s = {-T_HOLD_S!r}",
    ]
    gk = list(getattr(pl, "gravity_k", ()) or ())
    if gk:
        lines += ["gravity_on = 1", f"gravity_k = {_vec(gk)}",
                  f"gravity_q = {_vec(getattr(pl, 'gravity_q', (0.0, 0.0)))}"]
    if any(pl.link_k_nm_per_rad):
        lines += [f"link_k_nm_per_rad = {_vec(pl.link_k_nm_per_rad)}",
                  f"link_b_nms_per_rad = {_vec(pl.link_b_nms_per_rad)}"]
    if hand.kind == "spring" or getattr(hand, "guided", ()):
        lines += [f"hand_k = {hand.k!r}", f"hand_b = {hand.b!r}"]
    if hand.kind == "spring":
        path = np.asarray(hand.path if hand.path else [[0.0, *kinematics.fk(q0)]], dtype=float)
        lines.append(f"hand_path = {_vec(path)}")
    return "\n".join(lines) + "\n"


def _observer(scene: Any) -> bool:
    return scene.run.gateware().velocity == "observer"


def _coarse(scene: Any) -> bool:
    return scene.run.gateware().angle == "quadrature"


def hold_values(scene: Any, q0: np.ndarray) -> dict[str, list[int]]:
    """What the interpolator of a held (not built) axis reports: the joint at rest in the start
    pose since reset, unhomed (nothing arms the index latch before the firmware does): the
    golden model's position on that constant, noise-free signal, its index latch and count 0
    (README, "Axes that are not built"; the held bank shows an axis homed only when
    hold_index_count says an index was latched). So a held axis powers up as a built one held
    in the same pose does, and the firmware restarts it the same way."""
    out = {"hold_pos_homed": [0, 0, 0], "hold_index_pos": [0, 0, 0], "hold_index_count": [0, 0, 0]}
    built = set(int(a) for a in scene.run.axes)
    qi = q_index(q0, scene)
    enc_dir = _plant_bringup(scene)[2]
    for i in range(3):
        if i in built:
            continue
        e = _enc(scene, i)
        lines = np.full(HOLD_SAMPLES, (q0[i] - qi[i]) / (2 * np.pi) * encsig.LINES)
        spec = replace(e.spec(seed=0), noise_lsb=0.0)
        a, b = encsig.adc_codes(lines, spec)
        if enc_dir[i] < 0:               # A and B swapped at the connector (the plant's too)
            a, b = b, a
        o = interp.run(a, b, encsig.index_bit(lines), InterpConfig(coarse=_coarse(scene)))
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
             f"q0 = {_vec(q0)}", f"q_index = {_vec(q_index(q0, scene))}",
             f"qd0 = {_vec(np.deg2rad(getattr(scene.run, 'qd0_deg_s', None) or (0, 0, 0)))}",
             f"t_hold_s = {T_HOLD_S!r}",
             f"comm_err = {' '.join(str(int(v)) for v in scene.firmware.comm_offset_error_counts)}",
             f"record = {record_mask(scene)}"]
    timeout_ms = getattr(scene.firmware, "pc_force_timeout_ms", None)
    if timeout_ms is not None:
        ticks = int(round(timeout_ms * scene.run.servo_hz / 1000))
        lines.append(f"pc_force_timeout_ticks = {ticks}")
    guided = getattr(scene.hand, "guided", ())
    if guided:
        lines.append(f"guided = {_vec(np.asarray(guided, dtype=float))}")
    if calib_line(scene):
        lines.append(calib_line(scene))
    for k, v in hold_values(scene, q0).items():
        lines.append(f"{k} = {' '.join(str(x) for x in v)}")
    for f in scene.faults:
        if f.kind == "link_garbage":
            continue                 # on the scripted PC's line (link_script), not a harness fault
        if f.kind not in HARNESS_FAULTS:
            raise DeviceError(f"fault kind {f.kind!r} is not simulated by the virtual device yet")
        ax = -1 if getattr(f, "axis", None) is None else int(f.axis)
        lines.append(f"fault = {f.at_s!r} {f.kind} {max(ax, 0)}")
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
