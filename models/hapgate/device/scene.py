"""Scenes: what the virtual device simulates, as one typed, validated, frozen object.

A scene is a TOML file (`scenes/*.toml`, format reference: `scenes/README.md`) read with the
standard library's `tomllib` and validated once, here: unknown keys, wrong types (a bool is not an
int; an int is accepted for a float, a float is not accepted for an int), NaN/inf and impossible
values raise `SceneError` whose message names the file, the line where the TOML parser gives one,
and the dotted key (``scenes/x.toml: hand.path[2][0]: time must increase``). The defaults live in
the dataclasses below and nowhere else; the runner takes the validated `Scene`, never a raw dict.

    scene = load("scenes/wall.toml")
    stiffer = scene.override({"env.k": 3000.0, "run.record": ["q", "dac"]})   # re-validated
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..base import cache
from ..golden import calib, configs, encsig, kinematics


class SceneError(ValueError):
    """A malformed scene (the message names the file and the dotted key, or the line)."""


# ------------------------------------------------------------------------------- vocabulary

FIDELITIES = ("rtl", "model", "soc")
SOC_CLK_HZ = 48_000_000              # the soc fidelity's one clock: the SoC's (rtl/soc/README.md)
SOC_FAULTS = ("dropout", "hang", "link_garbage")   # what the soc fidelity simulates
GUIDED_MAX_M = 0.05                # hand.guided: largest displacement from the step's start
RECORDABLE = ("q", "p", "f_hand", "tau", "dac", "adc", "pos", "current")
ENV_KINDS = ("none", "wall", "spring", "viscous", "pc")
HAND_KINDS = ("none", "spring", "fixed")
FAULT_KINDS = ("dropout", "hang", "watchdog", "link_garbage")
BRINGUP_KEYS = ("comm_offset_elec_deg", "phases_swapped", "encoder_dir", "index_q_deg")
FW_ERRORS = ("NONE", "NONFINITE", "AXIS_FAULT", "ENCODER", "STALE", "OVERRUN", "WATCHDOG",
             "FPGA_ID", "CONFIG", "FPGA_FAULT")       # dsp-fw/include/hg_servo.h, HG_ERR_*
# Keys of [env] that apply to each kind (the others are refused).
ENV_KEYS = {"none": (), "wall": ("point", "normal", "k", "b"), "spring": ("point", "k", "b", "ki"),
            "viscous": ("b",), "pc": ()}
DEFAULT_Q0_DEG = (4.0, 46.0, 43.0)   # endpoint (-5.0, 71.2, -1.9) mm (KINEMATICS.md geometry)
TICK_HZ = 1_000_000                  # the FPGA's servo-tick time base (1 us)
SAMPLE_HZ = encsig.SAMPLE_HZ         # ADC strobe, 1 MSPS
P_MAX_M = 0.2                        # |point| limit, dsp-fw/include/hg_scene.h HG_SCENE_P_MAX
K_MAX = 3500.0                       # N/m,      HG_SCENE_K_MAX
K_MAX_TEST = 50_000.0                # N/m,      HG_SCENE_K_MAX_TEST (firmware.test_limits only)
B_MAX = 100.0                        # N s/m,    HG_SCENE_B_MAX
KI_MAX = 1.0e5                       # N/(m s),  HG_SCENE_KI_MAX
QD_MAX_DEG_S = math.degrees(100.0)   # dsp-fw qd_max = 100 rad/s: the fastest physical joint
GRAVITY_K_LEN = 12                   # dsp-fw/include/hg_gravity.h: k[12], k[n-1] = k_ny
GRIP_GAP_M = 1e-4                    # a rigid grip's path must start at the start pose (0.1 mm)
F_MAX_N = 10.0                       # N, |PC force| limit: dsp-fw hg_servo_default_cfg f_max
GARBAGE_BYTES = 256                  # link_garbage: bytes in the burst unless `bytes` is given


# ------------------------------------------------------------------------------- the schema


@dataclass(frozen=True)
class RunCfg:
    duration_s: float = 0.5          # simulated time, s (0, 600]
    fidelity: str = "rtl"            # "rtl": Verilated gateware; "model": the golden models;
    #                                   "soc": the Verilated SoC, the firmware on its soft CPU
    axes: tuple[int, ...] = (0, 1, 2)   # simulated axes (sorted); the others are not built
    servo_hz: int = 1000             # firmware servo rate, Hz, 100..10000, divides 1 MHz
    clk_hz: int = 0                  # FPGA clock, Hz; 0 = lowest bit-identical clock
    trace: bool = False              # VCD waveform of the gateware (<out>/harness/trace.vcd)
    record: tuple[str, ...] = ("q", "p", "f_hand", "tau", "dac")   # outputs computed and saved
    seed: int = 1                    # seeds every random source (encoder noise, link garbage)
    q0_deg: tuple[float, float, float] | None = None   # initial joint angles, deg (resolved
    #                                   on load: IK of the hand path[0], else DEFAULT_Q0_DEG)
    qd0_deg_s: tuple[float, float, float] = (0.0, 0.0, 0.0)   # initial joint speeds, deg/s
    name: str | None = None          # output folder name (resolved on load: the file's stem)
    position: str = "interpolated"   # "quadrature": the interpolator's fine angle zeroed (COARSE)
    velocity: str = "fir"            # "observer": VEL reports the tracking observer (VEL_OBS)
    config: str = "paper"            # the gateware's named configuration (golden.configs)

    def gateware(self) -> configs.Config:
        """The gateware's configuration: run.config, with position = "quadrature" and
        velocity = "observer" applied to it (a sweep point), on the configuration's clock (the
        run's clock is chosen when building)."""
        c = configs.get(self.config)
        if self.position == "quadrature":
            c = c.replace(angle="quadrature")
        if self.velocity == "observer":
            c = c.replace(velocity="observer")
        return c


# what the virtual device builds of a configuration: the paper's, but for these keys (and the
# clock, which the run chooses)
DEVICE_KEYS = {"angle": ("arcsine", "quadrature"), "velocity": ("fir", "observer"),
               "harden": ("none", "all")}


def device_refusal(c: configs.Config) -> str:
    """Why the virtual device cannot build configuration `c` ("" if it can)."""
    paper = configs.get("paper")
    other = [k for k in configs.KEYS if k != "clk_hz" and k not in DEVICE_KEYS
             and getattr(c, k) != getattr(paper, k)]
    other += [f"{k} = {getattr(c, k)!r}" for k, ok in DEVICE_KEYS.items()
              if getattr(c, k) not in ok]
    if not other:
        return ""
    return (f"configuration {c.name!r} sets {', '.join(other)}: the virtual device builds the "
            f"paper's configuration with angle {' or '.join(DEVICE_KEYS['angle'])} and velocity "
            f"{' or '.join(DEVICE_KEYS['velocity'])}, hardened or not "
            f"(models/hapgate/configs.toml)")


@dataclass(frozen=True)
class EnvCfg:
    """The firmware's scene (SET_SCENE), rendered at the servo rate (dsp-fw/include/hg_scene.h)."""
    kind: str = "none"               # none | wall | spring | viscous | pc
    point: tuple[float, float, float] = (0.0, 0.073, 0.0)   # m: wall point / spring anchor
    normal: tuple[float, float, float] = (0.0, -1.0, 0.0)   # into free space (unit after load)
    k: float = 2000.0                # N/m, 0..3500
    b: float = 0.0                   # N s/m, 0..100 (wall/spring damping, or viscosity)
    ki: float = 0.0                  # N/(m s), spring integral gain, 0..1e5


@dataclass(frozen=True)
class HandCfg:
    """The operator's hand: a spring-damper from the endpoint to a scripted target path."""
    kind: str = "none"               # none (free linkage) | spring | fixed (rigid grip)
    k: float = 500.0                 # N/m, (0, 1e5]
    b: float = 2.0                   # N s/m, [0, 1e3]
    path: tuple[tuple[float, float, float, float], ...] = ()   # (t s, x m, y m, z m)
    #                                   empty: the target is the start pose's endpoint
    guided: tuple[tuple[float, float, float, float], ...] = ()  # (t s, dx m, dy m, dz m)
    #                                   bring-up's guided move: while a GUIDED step runs, a spring
    #                                   (k, b) pulls the endpoint along these displacements from
    #                                   where the step started; while another step runs, no hand

    def target(self, t: np.ndarray, start: np.ndarray) -> np.ndarray:
        """Target endpoint (m, shape t.shape + (3,)) at times t: a C1 smooth (cubic ease)
        interpolation between path points, held before the first and after the last;
        `start` (the start pose's endpoint) when the path is empty."""
        t = np.asarray(t, dtype=np.float64)
        if not self.path:
            return np.broadcast_to(np.asarray(start, dtype=np.float64), t.shape + (3,)).copy()
        pts = np.asarray(self.path, dtype=np.float64)
        tp, xyz = pts[:, 0], pts[:, 1:]
        if len(tp) == 1:
            return np.broadcast_to(xyz[0], t.shape + (3,)).copy()
        i = np.clip(np.searchsorted(tp, t, side="right") - 1, 0, len(tp) - 2)
        u = np.clip((t - tp[i]) / (tp[i + 1] - tp[i]), 0.0, 1.0)
        s = u * u * (3.0 - 2.0 * u)           # zero velocity at every path point
        return xyz[i] + s[..., None] * (xyz[i + 1] - xyz[i])


@dataclass(frozen=True)
class EncoderCfg:
    """One axis's encoder front end: the parameters of `hapgate.golden.encsig.SignalSpec`,
    same names and units (the seed comes from [run] seed and the axis)."""
    amplitude: float = 110.0         # ADC codes (LSB), 1..127
    offset_a: float = 0.0            # LSB, |.| <= 64
    offset_b: float = 0.0
    gain_a: float = 1.0              # relative, 0.5..1.5
    gain_b: float = 1.0
    phase_deg: float = 0.0           # quadrature error, deg, |.| <= 30
    h2: float = 0.0                  # 2nd / 3rd harmonic, fraction of the fundamental, 0..0.2
    h3: float = 0.0
    noise_lsb: float = 0.0           # Gaussian sigma, LSB, 0..16

    def spec(self, seed: int) -> encsig.SignalSpec:
        return encsig.SignalSpec(seed=seed, **asdict(self))


@dataclass(frozen=True)
class FaultCfg:
    at_s: float                      # s, 0 <= at_s < duration_s
    kind: str                        # dropout | hang | watchdog | link_garbage
    axis: int | None = None          # dropout only: the axis whose encoder signal is lost
    bytes: int | None = None         # link_garbage only: length of the burst (default 256)


@dataclass(frozen=True)
class PcCfg:
    """The scripted PC of a scene with env kind "pc" run without a live PC program: it enables
    the forces over the link at scene time 0 and sends SET_FORCE(force_n) every period_ms,
    until the first link_garbage fault (the line is lost there: garbage, then silence)."""
    force_n: tuple[float, float, float] = (0.0, 0.0, 0.0)   # N, on the hand, |f| <= 10
    period_ms: float = 10.0          # ms between the PC's SET_FORCE frames, 1..1000
    baud: int = 1_000_000            # the UART's rate, 9600..12 000 000


@dataclass(frozen=True)
class FirmwareCfg:
    comm_offset_error_counts: tuple[int, int, int] = (0, 0, 0)   # 1/1024 electrical cycle
    pc_force_timeout_ms: float | None = None   # None: the firmware's default
    test_limits: bool = False        # simulation-only firmware build: k up to K_MAX_TEST
    calibration: str | None = None   # "none" | "truth" | a calibration.toml path (relative to
    #                                   the scene's folder); resolved on load: "none" when the
    #                                   scene sets a bring-up key of [plant] (BRINGUP_KEYS),
    #                                   else "truth"


# The link mode's bounds: a stiffness whose rotor mode, sqrt(k / j_rotor), stays below
# 1 / (16 us), the model fidelity's mechanics step (semi-implicit Euler is stable below
# 2 / step), with the default rotor (a stiffer link is rigid for the ~10 kHz loops here);
# a damper that the explicit step keeps stable (b dt / j_rotor < 2 at 16 us)
LINK_K_MAX = 1.6e-5 / 16e-6 ** 2     # 62 500 N m/rad (a ~10 kHz rotor mode)
LINK_B_MAX = 1.0                     # N m s/rad


@dataclass(frozen=True)
class PlantCfg:
    """The plant's parameters (their meaning, units and sources: the plant's block doc)."""
    kt_nm_per_a: float = 0.06
    r_ohm: float = 1.2
    j_rotor_kg_m2: float = 1.6e-5
    pole_pairs: int = 2
    i_max_a: float = 8.0
    current_bw_hz: float = 2000.0
    m_link_kg: float = 0.02
    m_handle_kg: float = 0.01
    b_visc_nms: tuple[float, float, float] = (2e-4, 2e-4, 2e-4)
    tau_coulomb_nm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    # link compliance, one structural mode per joint (tb/native/device/README.md, "Link
    # compliance"): rotor-to-linkage spring and damper; 0: rigid (the paper's direct drive)
    link_k_nm_per_rad: tuple[float, float, float] = (0.0, 0.0, 0.0)
    link_b_nms_per_rad: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gravity_k: tuple[float, ...] = ()      # empty: no gravity; else k1..k12 (hg_gravity.h order)
    gravity_q: tuple[float, float] = (0.0, 0.0)   # (Q_ab, Q_ac) of eq (2) (hg_gravity_t)
    dt_s: float = 1e-6                     # integrator step: 1e-6 / n, n = 1..16
    # what bring-up must find (issue 26), per axis; the defaults are today's device
    comm_offset_elec_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)   # index -> winding
    phases_swapped: tuple[bool, bool, bool] = (False, False, False)   # amplifier a, b swapped
    encoder_dir: tuple[int, int, int] = (1, 1, 1)   # -1: encoder A and B swapped
    index_q_deg: tuple[float, float, float] | None = None   # joint angle of the index, deg;
    #                                   None: 0.25 deg below the start pose (DEFAULT_INDEX_DEG)

    @property
    def substeps(self) -> int:
        """Integrator steps per ADC sample."""
        return round(1.0 / (SAMPLE_HZ * self.dt_s))


@dataclass(frozen=True)
class ExpectCfg:
    """Optional pass/fail checks against the run's metrics (None = not checked)."""
    max_force_error_n: float | None = None
    max_position_error_counts: float | None = None
    zero_torque_within_us: float | None = None
    min_torque_ratio: float | None = None
    max_torque_ratio: float | None = None
    max_energy_drift_frac: float | None = None
    max_slips: int | None = None
    fw_error: str | None = None
    min_link_bad_frames: int | None = None      # link_garbage: the firmware counted >= N bad
    pc_force_zero_within_ms: float | None = None   # the PC's last force is zero this long after
    #                                             its last good frame (and stays zero)

    def items(self) -> list[tuple[str, object]]:
        """(key, limit) of every check that is set, in declaration order."""
        return [(f.name, getattr(self, f.name)) for f in fields(self)
                if getattr(self, f.name) is not None]


@dataclass(frozen=True)
class Scene:
    run: RunCfg = RunCfg()
    env: EnvCfg = EnvCfg()
    hand: HandCfg = HandCfg()
    encoders: tuple[EncoderCfg, EncoderCfg, EncoderCfg] = (EncoderCfg(),) * 3
    faults: tuple[FaultCfg, ...] = ()
    firmware: FirmwareCfg = FirmwareCfg()
    plant: PlantCfg = PlantCfg()
    expect: ExpectCfg = ExpectCfg()
    pc: PcCfg | None = None          # [pc]: the scripted PC (env kind "pc" only)
    source: str = field(default="<scene>", compare=False)   # file it came from
    raw: str = field(default="{}", compare=False, repr=False)   # the TOML table, as JSON

    @property
    def name(self) -> str:
        return self.run.name or "scene"

    @property
    def q0_rad(self) -> np.ndarray:
        return np.deg2rad(np.asarray(self.run.q0_deg or DEFAULT_Q0_DEG, dtype=np.float64))

    @property
    def calibration(self) -> str:
        """firmware.calibration, the default resolved: "none" when the scene sets a bring-up
        key of [plant] (BRINGUP_KEYS), else "truth"."""
        if self.firmware.calibration is not None:
            return self.firmware.calibration
        given = json.loads(self.raw).get("plant", {})
        return "none" if any(k in given for k in BRINGUP_KEYS) else "truth"

    def calib(self) -> tuple[calib.AxisCalib, ...]:
        """The calibration the firmware starts with (three axes): calib.NONE, the plant's own
        (calib.truth) or the file's (relative to the scene's folder; checked on load)."""
        return _calib(self.calibration, self.plant, self.run, self.source)

    def signal_spec(self, axis: int) -> encsig.SignalSpec:
        """The encoder signal model of one axis, seeded from [run] seed and the axis."""
        return self.encoders[axis].spec(seed=3 * self.run.seed + axis)

    def records(self, name: str) -> bool:
        return name in self.run.record

    def override(self, changes: Mapping[str, object]) -> Scene:
        """A new scene with dotted keys replaced (``{"env.k": 3000.0, "encoder.1.h2": 0.01}``),
        validated like a file; a key naming a missing table creates it, a value None removes
        the key (TOML has no null: only code can ask for that)."""
        d = json.loads(self.raw)
        for dotted, value in changes.items():
            *head, last = dotted.split(".")
            node = d
            for part in head:
                node = node.setdefault(part, {})
                if not isinstance(node, dict):
                    raise SceneError(f"{self.source}: {dotted}: not a table")
            if value is None:
                node.pop(last, None)
            else:
                node[last] = json.loads(json.dumps(value))   # tuples -> arrays, like TOML
        return from_dict(d, self.source)

    def digest(self) -> str:
        """A stable content hash (sha256 hex) of the validated scene, without its file and
        name: equal for equal scenes in any process (for caches keyed by parameters)."""
        d = self.summary()
        d.pop("source")
        d["run"].pop("name")  # type: ignore[union-attr]
        return cache.digest(data=d, length=None, algorithm="sha256")

    def summary(self) -> dict[str, object]:
        """The validated scene as plain JSON-able data (for summary.json)."""
        out = asdict(self)
        out.pop("raw")
        return out


# ------------------------------------------------------------------------------- loading


def load(path: str | Path) -> Scene:
    """Read and validate a scene file. Raises SceneError naming the file (and line or key)."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SceneError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        text = data.decode("utf-8-sig")   # a leading BOM is fine
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise SceneError(f"{path}:{line}: not UTF-8 (byte 0x{data[exc.start]:02x} at offset "
                         f"{exc.start})") from None
    return loads(text, str(path))


def loads(text: str, source: str = "<scene>") -> Scene:
    try:
        import tomllib  # here, not at the top: `hapgate` itself still starts on Python 3.10
    except ImportError:  # pragma: no cover - the pinned venv is 3.11+
        raise SceneError(f"{source}: reading scenes needs Python >= 3.11 (tomllib)") from None
    try:
        d = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = re.search(r"\(at line (\d+), column (\d+)\)", msg)
        if m:
            base = msg[:m.start()].strip()
            raise SceneError(f"{source}:{m.group(1)}:{m.group(2)}: invalid TOML: {base}"
                             ) from None
        raise SceneError(f"{source}: invalid TOML: {msg}") from None
    return from_dict(d, source)


def from_dict(d: Mapping[str, Any], source: str = "<scene>") -> Scene:
    """Validate a TOML-shaped mapping (what `tomllib` returns) into a Scene."""
    v = _Validator(source)
    top = v.table(d, "", ("run", "env", "hand", "encoder", "fault", "firmware", "plant",
                          "expect", "pc"))
    run = v.run(v.sub(top, "run"), Path(source).stem)
    firmware = v.firmware(v.sub(top, "firmware"), run)
    env = v.env(v.sub(top, "env"), K_MAX_TEST if firmware.test_limits else K_MAX)
    hand = v.hand(v.sub(top, "hand"))
    encoders = v.encoders(v.sub(top, "encoder"))
    faults = v.faults(top.get("fault", []), run)
    plant = v.plant(v.sub(top, "plant"))
    expect = v.expect(v.sub(top, "expect"))
    pc = v.pc(v.sub(top, "pc")) if "pc" in top else None
    v.consistent(run, faults, expect, env, pc, plant, firmware)
    run = replace(run, q0_deg=v.q0(run, hand))
    raw = json.dumps(d, default=str)
    out = Scene(run, env, hand, encoders, faults, firmware, plant, expect, pc=pc,
                source=source, raw=raw)
    v.calibration(out)
    return out


DEFAULT_INDEX_DEG = 0.25         # without plant.index_q_deg each index lies this far below q0


def _calib(mode: str, plant: PlantCfg, run: RunCfg, source: str
           ) -> tuple[calib.AxisCalib, ...]:
    if mode == "none":
        return calib.NONE
    if mode == "truth":   # the harness's index (harness.q_index), to the bit
        qi = index_at(np.deg2rad(np.asarray(run.q0_deg or DEFAULT_Q0_DEG, dtype=np.float64)),
                      plant.index_q_deg)
        return calib.truth(qi, plant.comm_offset_elec_deg, plant.phases_swapped,
                           plant.encoder_dir, plant.pole_pairs)
    path = Path(mode)
    if not path.is_absolute() and source not in ("<scene>", ""):
        path = Path(source).parent / path
    return calib.load(path)


def index_at(q0_rad: np.ndarray, index_q_deg: Sequence[float] | None) -> np.ndarray:
    """The joint angle of each encoder's index [rad]: index_q_deg (plant.index_q_deg), else
    DEFAULT_INDEX_DEG below the start pose q0_rad (the windings' zero lies there too, unless
    comm_offset_elec_deg says otherwise)."""
    if index_q_deg is not None:
        return np.deg2rad(np.asarray(index_q_deg, dtype=np.float64))
    return np.asarray(q0_rad, dtype=np.float64) - np.deg2rad(DEFAULT_INDEX_DEG)


def index_rad(scene: Scene) -> np.ndarray:
    """The scene's index of each encoder [rad] (index_at)."""
    return index_at(scene.q0_rad, scene.plant.index_q_deg)


# ------------------------------------------------------------------------------- validation

_Num = Callable[[float], bool]


class _Validator:
    def __init__(self, source: str) -> None:
        self.src = source

    def fail(self, key: str, msg: str) -> SceneError:
        return SceneError(f"{self.src}: {key}: {msg}")

    # ---- generic shapes
    def table(self, d: object, key: str, allowed: tuple[str, ...]) -> dict[str, Any]:
        if not isinstance(d, dict):
            raise self.fail(key or "<top>", f"must be a table, got {_tname(d)}")
        for k in d:
            if k not in allowed:
                where = f"{key}.{k}" if key else k
                raise self.fail(where, "unknown key (known: " + ", ".join(allowed) + ")")
        return d

    def sub(self, top: dict[str, Any], name: str) -> dict[str, Any]:
        d = top.get(name, {})
        if not isinstance(d, dict):
            raise self.fail(name, f"must be a table, got {_tname(d)}")
        return d

    def num(self, value: object, key: str, ok: _Num, rule: str) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, f"must be a number, got {_tname(value)}")
        x = float(value)
        if not math.isfinite(x):
            raise self.fail(key, f"must be finite, got {value}")
        if not ok(x):
            raise self.fail(key, f"{value} out of range: {rule}")
        return x

    def int_(self, value: object, key: str, ok: Callable[[int], bool], rule: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(key, f"must be an integer, got {_tname(value)}")
        if not ok(value):
            raise self.fail(key, f"{value} out of range: {rule}")
        return value

    def str_(self, value: object, key: str, choices: tuple[str, ...]) -> str:
        if not isinstance(value, str):
            raise self.fail(key, f"must be a string, got {_tname(value)}")
        if value not in choices:
            raise self.fail(key, f"{value!r} is not one of " + ", ".join(choices))
        return value

    def bool_(self, value: object, key: str) -> bool:
        if not isinstance(value, bool):
            raise self.fail(key, f"must be true or false, got {_tname(value)}")
        return value

    def list_(self, value: object, key: str, n: int | None = None) -> list[Any]:
        if not isinstance(value, list):
            raise self.fail(key, f"must be an array, got {_tname(value)}")
        if n is not None and len(value) != n:
            raise self.fail(key, f"must have {n} elements, got {len(value)}")
        return value

    def vec(self, value: object, key: str, n: int, ok: _Num, rule: str) -> tuple[float, ...]:
        return tuple(self.num(x, f"{key}[{i}]", ok, rule)
                     for i, x in enumerate(self.list_(value, key, n)))

    def fields_of(self, d: dict[str, Any], key: str,
                  parse: Mapping[str, Callable[[object, str], object]]) -> dict[str, object]:
        self.table(d, key, tuple(parse))
        return {k: parse[k](d[k], f"{key}.{k}") for k in parse if k in d}

    # ---- sections
    def run(self, d: dict[str, Any], stem: str) -> RunCfg:
        def axes(x: object, k: str) -> tuple[int, ...]:
            lst = self.list_(x, k)
            if not lst:
                raise self.fail(k, "must list at least one axis")
            out = [self.int_(a, f"{k}[{i}]", lambda a: 0 <= a <= 2, "an axis is 0, 1 or 2")
                   for i, a in enumerate(lst)]
            if len(set(out)) != len(out):
                raise self.fail(k, f"axes must be unique, got {out}")
            return tuple(sorted(out))

        def servo(x: object, k: str) -> int:
            hz = self.int_(x, k, lambda h: 100 <= h <= 10_000, "100..10000 Hz")
            if TICK_HZ % hz:
                raise self.fail(k, f"{hz} Hz does not divide the FPGA's 1 MHz tick")
            return hz

        def clk(x: object, k: str) -> int:
            hz = self.int_(x, k, lambda h: h == 0 or 1_000_000 <= h <= 100_000_000,
                           "0 (auto) or 1000000..100000000 Hz")
            if hz % SAMPLE_HZ:
                raise self.fail(k, f"{hz} Hz is not a whole multiple of the 1 MHz ADC strobe")
            return hz

        def record(x: object, k: str) -> tuple[str, ...]:
            out = tuple(self.str_(r, f"{k}[{i}]", RECORDABLE)
                        for i, r in enumerate(self.list_(x, k)))
            if len(set(out)) != len(out):
                raise self.fail(k, "names must be unique")
            return out

        def name(x: object, k: str) -> str:
            if not isinstance(x, str):
                raise self.fail(k, f"must be a string, got {_tname(x)}")
            if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}", x):
                raise self.fail(k, f"{x!r}: use 1..64 of A-Z a-z 0-9 _ . - (not starting "
                                   "with . or -): it names the output folder")
            return x

        def gateware(x: object, k: str) -> str:
            name_ = self.str_(x, k, tuple(configs.names()))
            why = device_refusal(configs.get(name_))
            if why:
                raise self.fail(k, why)
            return name_

        kw = self.fields_of(d, "run", {
            "duration_s": lambda x, k: self.num(x, k, lambda s: 0 < s <= 600, "0 < s <= 600"),
            "fidelity": lambda x, k: self.str_(x, k, FIDELITIES),
            "axes": axes, "servo_hz": servo, "clk_hz": clk,
            "trace": self.bool_, "record": record,
            "seed": lambda x, k: self.int_(x, k, lambda s: 0 <= s < 2**32, "0 <= seed < 2^32"),
            "q0_deg": lambda x, k: self.vec(x, k, 3, lambda a: abs(a) <= 180, "|deg| <= 180"),
            "qd0_deg_s": lambda x, k: self.vec(x, k, 3, lambda w: abs(w) <= QD_MAX_DEG_S,
                                               f"|deg/s| <= {QD_MAX_DEG_S:.0f} (the firmware's "
                                               "qd_max, 100 rad/s)"),
            "name": name,
            "position": lambda x, k: self.str_(x, k, ("interpolated", "quadrature")),
            "velocity": lambda x, k: self.str_(x, k, ("fir", "observer")),
            "config": gateware})
        for a, w in enumerate(kw.get("qd0_deg_s", ())):   # type: ignore[arg-type]
            if w != 0 and a not in kw.get("axes", RunCfg.axes):   # type: ignore[operator]
                raise self.fail(f"run.qd0_deg_s[{a}]", f"axis {a} is not simulated (its joint "
                                                       "is held): the speed must be 0")
        kw.setdefault("name", stem if re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}", stem)
                      else "scene")
        return RunCfg(**kw)  # type: ignore[arg-type]

    def env(self, d: dict[str, Any], k_max: float = K_MAX) -> EnvCfg:
        kind = self.str_(d.get("kind", EnvCfg.kind), "env.kind", ENV_KINDS)
        for k in d:
            if k != "kind" and k in ("point", "normal", "k", "b", "ki") \
                    and k not in ENV_KEYS[kind]:
                raise self.fail(f"env.{k}", f"does not apply to env kind {kind!r} (it takes: "
                                + (", ".join(ENV_KEYS[kind]) or "no parameters") + ")")
        kw = self.fields_of(d, "env", {
            "kind": lambda x, k: x,
            "point": lambda x, k: self._point(x, k),
            "normal": lambda x, k: self.vec(x, k, 3, lambda _: True, ""),
            "k": lambda x, k: self.num(x, k, lambda v: 0 <= v <= k_max,
                                       f"0..{k_max:g} N/m (HG_SCENE_K_MAX"
                                       + ("_TEST)" if k_max > K_MAX else ")")),
            "b": lambda x, k: self.num(x, k, lambda v: 0 <= v <= B_MAX,
                                       f"0..{B_MAX:g} N s/m (HG_SCENE_B_MAX)"),
            "ki": lambda x, k: self.num(x, k, lambda v: 0 <= v <= KI_MAX,
                                        f"0..{KI_MAX:g} N/(m s) (HG_SCENE_KI_MAX)")})
        if "normal" in kw:
            n = np.asarray(kw["normal"])
            norm = float(np.linalg.norm(n))
            if not 0.5 <= norm <= 2.0:
                raise self.fail("env.normal", f"norm {norm:.3g} out of range: 0.5..2 "
                                              "(it is normalised on load)")
            kw["normal"] = tuple(float(c) for c in n / norm)
        return EnvCfg(**kw)  # type: ignore[arg-type]

    def _point(self, x: object, k: str) -> tuple[float, ...]:
        p = self.vec(x, k, 3, lambda _: True, "")
        if math.hypot(*p) > P_MAX_M:
            raise self.fail(k, f"|p| = {math.hypot(*p):.3g} m out of range: <= {P_MAX_M} m")
        return p

    def hand(self, d: dict[str, Any]) -> HandCfg:
        kind = self.str_(d.get("kind", HandCfg.kind), "hand.kind", HAND_KINDS)
        if kind == "none":
            for k in ("path",) if "guided" in d else ("k", "b", "path"):
                if k in d:
                    raise self.fail(f"hand.{k}", "does not apply to hand kind 'none' "
                                                 "(a free linkage)")
        if kind == "fixed":
            for k in ("k", "b"):
                if k in d:
                    raise self.fail(f"hand.{k}", "does not apply to hand kind 'fixed' "
                                                 "(a rigid grip)")

        def path(x: object, k: str) -> tuple[tuple[float, ...], ...]:
            rows = self.list_(x, k)
            out: list[tuple[float, ...]] = []
            for i, row in enumerate(rows):
                r = self.list_(row, f"{k}[{i}]", 4)
                t = self.num(r[0], f"{k}[{i}][0]", lambda t: t >= 0, "time >= 0 s")
                if out and t <= out[-1][0]:
                    raise self.fail(f"{k}[{i}][0]", f"time must increase ({t:g} s after "
                                                    f"{out[-1][0]:g} s)")
                xyz = tuple(self.num(c, f"{k}[{i}][{j + 1}]", lambda _: True, "")
                            for j, c in enumerate(r[1:]))
                if math.hypot(*xyz) > P_MAX_M:
                    raise self.fail(f"{k}[{i}]", f"|p| = {math.hypot(*xyz):.3g} m out of "
                                                 f"range: <= {P_MAX_M} m")
                out.append((t, *xyz))
            return tuple(out)

        def guided(x: object, k: str) -> tuple[tuple[float, ...], ...]:
            rows = path(x, k)
            if not rows:
                raise self.fail(k, "expected at least one point [t, dx, dy, dz]")
            for i, r in enumerate(rows):
                if math.hypot(*r[1:]) > GUIDED_MAX_M:
                    raise self.fail(f"{k}[{i}]", f"|d| = {math.hypot(*r[1:]):.3g} m out of "
                                                 f"range: <= {GUIDED_MAX_M} m")
            return rows

        kw = self.fields_of(d, "hand", {
            "guided": guided,
            "kind": lambda x, k: x,
            "k": lambda x, k: self.num(x, k, lambda v: 0 < v <= 1e5, "0 < k <= 1e5 N/m"),
            "b": lambda x, k: self.num(x, k, lambda v: 0 <= v <= 1e3, "0..1e3 N s/m"),
            "path": path})
        return HandCfg(**kw)  # type: ignore[arg-type]

    def _encoder_fields(self, d: dict[str, Any], key: str, extra: tuple[str, ...] = ()
                        ) -> dict[str, object]:
        def rng(lo: float, hi: float, unit: str) -> Callable[[object, str], float]:
            return lambda x, k: self.num(x, k, lambda v: lo <= v <= hi, f"{lo:g}..{hi:g}{unit}")

        parse: dict[str, Callable[[object, str], object]] = {
            "amplitude": rng(1, 127, " LSB"), "offset_a": rng(-64, 64, " LSB"),
            "offset_b": rng(-64, 64, " LSB"), "gain_a": rng(0.5, 1.5, ""),
            "gain_b": rng(0.5, 1.5, ""), "phase_deg": rng(-30, 30, " deg"),
            "h2": rng(0, 0.2, " of the amplitude"), "h3": rng(0, 0.2, " of the amplitude"),
            "noise_lsb": rng(0, 16, " LSB")}
        for e in extra:
            parse[e] = lambda x, k: x
        out = self.fields_of(d, key, parse)
        for e in extra:
            out.pop(e, None)
        return out

    def encoders(self, d: dict[str, Any]) -> tuple[EncoderCfg, EncoderCfg, EncoderCfg]:
        base = self._encoder_fields(d, "encoder", ("0", "1", "2"))
        out = []
        for ax in range(3):
            per = d.get(str(ax), {})
            if not isinstance(per, dict):
                raise self.fail(f"encoder.{ax}", f"must be a table, got {_tname(per)}")
            out.append(EncoderCfg(**{**base, **self._encoder_fields(per, f"encoder.{ax}")}))
        return out[0], out[1], out[2]

    def faults(self, x: object, run: RunCfg) -> tuple[FaultCfg, ...]:
        if not isinstance(x, list):
            raise self.fail("fault", "must be an array of tables ([[fault]])")
        out = []
        for i, d in enumerate(x):
            key = f"fault[{i}]"
            self.table(d, key, ("at_s", "kind", "axis", "bytes"))
            if "at_s" not in d or "kind" not in d:
                raise self.fail(key, "needs at_s and kind")
            at = self.num(d["at_s"], f"{key}.at_s", lambda t: 0 <= t < run.duration_s,
                          f"0 <= at_s < run.duration_s = {run.duration_s:g} s")
            kind = self.str_(d["kind"], f"{key}.kind", FAULT_KINDS)
            axis = None
            if kind == "dropout":
                if "axis" not in d:
                    raise self.fail(f"{key}.axis", "required for a dropout")
                axis = self.int_(d["axis"], f"{key}.axis", lambda a: a in run.axes,
                                 f"must be a simulated axis (run.axes = {list(run.axes)})")
            elif "axis" in d:
                raise self.fail(f"{key}.axis", f"applies to dropout only, not {kind!r}")
            nbytes = None
            if kind == "link_garbage":
                nbytes = self.int_(d.get("bytes", GARBAGE_BYTES), f"{key}.bytes",
                                   lambda b: 1 <= b <= 65536, "1..65536")
            elif "bytes" in d:
                raise self.fail(f"{key}.bytes", f"applies to link_garbage only, not {kind!r}")
            out.append(FaultCfg(at, kind, axis, nbytes))
        return tuple(sorted(out, key=lambda f: f.at_s))

    def firmware(self, d: dict[str, Any], run: RunCfg) -> FirmwareCfg:
        def comm(x: object, k: str) -> tuple[int, ...]:
            return tuple(self.int_(c, f"{k}[{i}]", lambda c: abs(c) <= 512,
                                   "|counts| <= 512 (half an electrical cycle)")
                         for i, c in enumerate(self.list_(x, k, 3)))

        def timeout(x: object, k: str) -> float:
            ms = self.num(x, k, lambda m: 0 < m <= 10_000, "0 < ms <= 10000")
            ticks = ms * run.servo_hz / 1000.0
            if ticks < 1 or abs(ticks - round(ticks)) > 1e-9:
                raise self.fail(k, f"{ms:g} ms is not a whole number (>= 1) of servo ticks "
                                   f"at {run.servo_hz} Hz")
            return ms

        def calibration(x: object, k: str) -> str:
            if not isinstance(x, str):
                raise self.fail(k, f"must be a string, got {_tname(x)}")
            if x in ("none", "truth"):
                return x
            if not x.endswith(".toml"):
                raise self.fail(k, f"{x!r}: \"none\", \"truth\" or a path to a "
                                   "calibration.toml")
            return x

        kw = self.fields_of(d, "firmware", {
            "comm_offset_error_counts": comm, "pc_force_timeout_ms": timeout,
            "test_limits": lambda x, k: self.bool_(x, k), "calibration": calibration})
        return FirmwareCfg(**kw)  # type: ignore[arg-type]

    def calibration(self, scene: Scene) -> None:
        """Check the calibration the scene resolves to (a file: that it loads). An index may lie
        anywhere: a stored calibration restarts in the start pose without one (the firmware's
        RESTART), and without a calibration bring-up's HOME searches for it."""
        try:
            scene.calib()
        except calib.CalibError as exc:
            raise self.fail("firmware.calibration", str(exc)) from None

    def plant(self, d: dict[str, Any]) -> PlantCfg:
        def pos(hi: float, unit: str) -> Callable[[object, str], float]:
            return lambda x, k: self.num(x, k, lambda v: 0 < v <= hi, f"0 < value <= {hi:g}{unit}")

        def nonneg(hi: float, unit: str) -> Callable[[object, str], float]:
            return lambda x, k: self.num(x, k, lambda v: 0 <= v <= hi, f"0..{hi:g}{unit}")

        def vec3(hi: float, unit: str) -> Callable[[object, str], tuple[float, ...]]:
            return lambda x, k: self.vec(x, k, 3, lambda v: 0 <= v <= hi, f"0..{hi:g}{unit}")

        def gravity(x: object, k: str) -> tuple[float, ...]:
            lst = self.list_(x, k)
            if len(lst) not in (0, GRAVITY_K_LEN):
                raise self.fail(k, f"must be empty (no gravity) or list k1..k{GRAVITY_K_LEN} "
                                   f"(dsp-fw/include/hg_gravity.h), got {len(lst)} values")
            return tuple(self.num(c, f"{k}[{i}]", lambda v: abs(v) <= 10, "|k| <= 10 N m")
                         for i, c in enumerate(lst))

        def dt(x: object, k: str) -> float:
            s = self.num(x, k, lambda v: 0 < v <= 1e-6, "0 < dt <= 1e-6 s")
            n = round(1e-6 / s)
            if not 1 <= n <= 16 or abs(n * s - 1e-6) > 1e-15:
                raise self.fail(k, f"{s:g} s must be 1e-6 s / n for a whole n in 1..16")
            return 1e-6 / n

        def swapped(x: object, k: str) -> tuple[bool, ...]:
            return tuple(self.bool_(c, f"{k}[{i}]") for i, c in enumerate(self.list_(x, k, 3)))

        def enc_dir(x: object, k: str) -> tuple[int, ...]:
            return tuple(self.int_(c, f"{k}[{i}]", lambda v: v in (1, -1), "+1 or -1")
                         for i, c in enumerate(self.list_(x, k, 3)))

        kw = self.fields_of(d, "plant", {
            "comm_offset_elec_deg": lambda x, k: self.vec(x, k, 3, lambda v: abs(v) <= 360,
                                                          "-360..360 deg electrical"),
            "phases_swapped": swapped, "encoder_dir": enc_dir,
            "index_q_deg": lambda x, k: self.vec(x, k, 3, lambda v: abs(v) <= 180,
                                                 "|deg| <= 180"),
            "kt_nm_per_a": pos(1.0, " N m/A"), "r_ohm": pos(100.0, " ohm"),
            "j_rotor_kg_m2": pos(1e-2, " kg m^2"),
            "pole_pairs": lambda x, k: self.int_(x, k, lambda p: 1 <= p <= 8, "1..8"),
            "i_max_a": pos(50.0, " A"), "current_bw_hz": pos(1e5, " Hz"),
            "m_link_kg": nonneg(1.0, " kg"), "m_handle_kg": nonneg(1.0, " kg"),
            "b_visc_nms": vec3(1.0, " N m s"), "tau_coulomb_nm": vec3(1.0, " N m"),
            "gravity_k": gravity,
            "gravity_q": lambda x, k: self.vec(x, k, 2, lambda v: abs(v) <= 10, "|Q| <= 10"),
            "dt_s": dt, "link_k_nm_per_rad": vec3(LINK_K_MAX, " N m/rad"),
            "link_b_nms_per_rad": vec3(LINK_B_MAX, " N m s/rad")})
        for i, (k, b) in enumerate(zip(kw.get("link_k_nm_per_rad", (0.0,) * 3),  # type: ignore
                                       kw.get("link_b_nms_per_rad", (0.0,) * 3))):  # type: ignore
            if b and not k:
                raise self.fail(f"plant.link_b_nms_per_rad[{i}]",
                                "a link damper needs its spring (link_k_nm_per_rad > 0)")
        return PlantCfg(**kw)  # type: ignore[arg-type]

    def expect(self, d: dict[str, Any]) -> ExpectCfg:
        nonneg = lambda x, k: self.num(x, k, lambda v: v >= 0, ">= 0")  # noqa: E731
        ratio = lambda x, k: self.num(x, k, lambda v: 0 <= v <= 10, "0..10")  # noqa: E731
        kw = self.fields_of(d, "expect", {
            "max_force_error_n": nonneg, "max_position_error_counts": nonneg,
            "zero_torque_within_us": nonneg, "min_torque_ratio": ratio,
            "max_torque_ratio": ratio, "max_energy_drift_frac": nonneg,
            "max_slips": lambda x, k: self.int_(x, k, lambda v: v >= 0, ">= 0"),
            "fw_error": lambda x, k: self.str_(x, k, FW_ERRORS),
            "min_link_bad_frames": lambda x, k: self.int_(x, k, lambda v: v >= 0, ">= 0"),
            "pc_force_zero_within_ms": nonneg})
        if "min_torque_ratio" in kw and "max_torque_ratio" in kw \
                and kw["min_torque_ratio"] > kw["max_torque_ratio"]:  # type: ignore[operator]
            raise self.fail("expect.min_torque_ratio", "exceeds expect.max_torque_ratio")
        return ExpectCfg(**kw)  # type: ignore[arg-type]

    def pc(self, d: dict[str, Any]) -> PcCfg:
        def force(x: object, k: str) -> tuple[float, ...]:
            f = self.vec(x, k, 3, lambda _: True, "")
            if math.hypot(*f) > F_MAX_N:
                raise self.fail(k, f"|f| = {math.hypot(*f):.3g} N out of range: <= {F_MAX_N:g} N "
                                   "(the firmware's f_max)")
            return f

        kw = self.fields_of(d, "pc", {
            "force_n": force,
            "period_ms": lambda x, k: self.num(x, k, lambda v: 1 <= v <= 1000, "1..1000 ms"),
            "baud": lambda x, k: self.int_(x, k, lambda b: 9600 <= b <= 12_000_000,
                                           "9600..12000000")})
        return PcCfg(**kw)  # type: ignore[arg-type]

    def consistent(self, run: RunCfg, faults: tuple[FaultCfg, ...], expect: ExpectCfg,
                   env: EnvCfg | None = None, pc: PcCfg | None = None,
                   plant: PlantCfg | None = None, firmware: FirmwareCfg | None = None) -> None:
        """Rules across sections."""
        if run.fidelity == "soc":
            self.soc(run, faults, firmware)
        kind = env.kind if env is not None else "none"
        if pc is not None and kind != "pc":
            raise self.fail("pc", f"a scripted PC needs env kind \"pc\", not {kind!r}")
        for i, f in enumerate(faults):
            if f.kind == "link_garbage" and kind != "pc":
                raise self.fail(f"fault[{i}].kind", "link_garbage needs the PC link: env kind "
                                                    f"\"pc\", not {kind!r}")
        if run.trace and run.fidelity != "rtl":
            raise self.fail("run.trace", "a waveform needs the gateware (fidelity = \"rtl\")")
        if plant is not None and run.fidelity == "model" and -1 in plant.encoder_dir:
            raise self.fail("plant.encoder_dir", "a reversed encoder needs the gateware "
                                                 "(fidelity = \"rtl\"): the model's quadrant "
                                                 "count follows the forward angle")
        if expect.zero_torque_within_us is not None and not faults:
            raise self.fail("expect.zero_torque_within_us", "the scene injects no [[fault]] "
                                                            "to react to")

    def soc(self, run: RunCfg, faults: tuple[FaultCfg, ...],
            firmware: FirmwareCfg | None) -> None:
        """What the soc fidelity cannot do: it builds the board's SoC as it is (three axes, its
        clock, the paper's gateware, the shipped firmware image) and simulates the faults of
        the world around it and the CPU's own (hang: it stops taking interrupts)."""
        if tuple(run.axes) != (0, 1, 2):
            raise self.fail("run.axes", "the soc fidelity builds the whole FPGA: axes [0, 1, 2]")
        if run.clk_hz not in (0, SOC_CLK_HZ):
            raise self.fail("run.clk_hz", f"the soc fidelity runs at the SoC's clock, "
                                          f"{SOC_CLK_HZ} Hz (or 0)")
        if run.config != "paper" or run.position != "interpolated" or run.velocity != "fir":
            key = ("run.config" if run.config != "paper" else
                   "run.position" if run.position != "interpolated" else "run.velocity")
            raise self.fail(key, "the soc fidelity builds the board's gateware (the paper's "
                                 "configuration, interpolated position, FIR velocity)")
        if firmware is not None and firmware.test_limits:
            raise self.fail("firmware.test_limits", "the soc fidelity runs the shipped firmware "
                                                    "image")
        for i, f in enumerate(faults):
            if f.kind not in SOC_FAULTS:
                raise self.fail(f"fault[{i}].kind",
                                f"{f.kind!r} is not simulated at the soc fidelity (it "
                                f"simulates {', '.join(SOC_FAULTS)})")

    def q0(self, run: RunCfg, hand: HandCfg) -> tuple[float, float, float]:
        """The initial joint angles: given, else IK of the hand path's first point, else the
        default pose. The start pose must be reachable and clear of the singular sets."""
        if hand.kind == "fixed":          # a rigid grip goes where its path goes
            qs, ok = kinematics.ik(np.asarray([r[1:] for r in hand.path]).reshape(-1, 3))
            for i in np.flatnonzero(~ok):
                raise self.fail(f"hand.path[{i}]", "outside the workspace (no inverse "
                                                   "kinematics): a rigid grip cannot go there")
            for i in np.flatnonzero(kinematics.guard(qs) < 1.0):
                raise self.fail(f"hand.path[{i}]", "too near a singular set for a rigid grip")
        if run.q0_deg is not None:
            q = tuple(run.q0_deg)
            key = "run.q0_deg"
            if hand.kind == "fixed" and hand.path:
                gap = float(np.linalg.norm(kinematics.fk(np.deg2rad(q)) - hand.path[0][1:]))
                if gap > GRIP_GAP_M:
                    raise self.fail("hand.path[0]", f"the rigid grip starts {1e3 * gap:.3g} mm "
                                                    "from the endpoint of run.q0_deg (it "
                                                    "would jump)")
        elif hand.path:
            qr, ok = kinematics.ik(np.asarray(hand.path[0][1:]))
            if not bool(ok):
                raise self.fail("hand.path[0]", "the start point is outside the workspace "
                                                "(no inverse kinematics)")
            q = tuple(float(a) for a in np.rad2deg(qr))
            key = "hand.path[0]"
        else:
            return DEFAULT_Q0_DEG
        if float(kinematics.guard(np.deg2rad(q))) < 1.0:
            raise self.fail(key, "the start pose is too near a singular set (the firmware's "
                                 "guard fades torque there)")
        return q[0], q[1], q[2]


def _tname(x: object) -> str:
    return {bool: "a boolean", int: "an integer", float: "a float", str: "a string",
            list: "an array", dict: "a table"}.get(type(x), type(x).__name__)


def keys() -> list[tuple[str, str, object]]:
    """(dotted key, type, default) of every scene key: the format reference's checklist."""
    out: list[tuple[str, str, object]] = []
    for sec, cls in (("run", RunCfg), ("env", EnvCfg), ("hand", HandCfg),
                     ("encoder", EncoderCfg), ("firmware", FirmwareCfg), ("plant", PlantCfg),
                     ("expect", ExpectCfg), ("pc", PcCfg)):
        for f in fields(cls):
            out.append((f"{sec}.{f.name}", str(f.type), f.default))
    for f in fields(FaultCfg):
        out.append((f"fault[].{f.name}", str(f.type), f.default))
    return out
