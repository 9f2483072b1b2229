"""Firmware co-simulation: the DSP firmware (dsp-fw/src, C99, unchanged) against the Verilated FPGA
top over the modelled EMIF bus (tb/native/cosim/).

`build()` compiles the firmware with its own warning flags into a static library and Verilates
rtl/top/hapgate_top.v with the C++ harness and the co-sim HAL (one cached build per parameter
set and source hash, under build/native/cosim-<hash>/). `load()` reads a co-simulation scene
(scenes/cosim/NAME.toml) and `run_config()` writes its run configuration, the one format the
device, model and co-simulation harnesses parse (hg_dev::parse_run). `run()` runs one scene and
returns its
summary and per-frame / per-ISR records as numpy arrays. `check()` re-checks a run independently
of the harness: the torques reconstructed from the DAC codes with `hapgate.golden.commutation`'s
motor
model, the endpoint force through `hapgate.golden.kinematics`, and the safety reaction times from
the
raw DAC loads. `demo_section()` / `bench_section()` are the `make demo` / `make bench` entries.
"""

from __future__ import annotations

import math
import subprocess
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..base import cbuild, report
from ..base.paths import ROOT, TB, ensure
from ..golden import commutation, configs, encsig, interp, kinematics
from ..golden.top import SOURCES, TopConfig
from . import native
from .records import LOAD_DT, TICK_DT

HERE = TB / "native" / "cosim"
DEVICE = TB / "native" / "device"     # the shared bus master, DAC word and plant
HARNESS = [HERE / "cosim_harness.cpp", HERE / "hal_cosim.cpp", DEVICE / "plant.cpp",
           DEVICE / "harness_common.cpp"]
FW = ROOT / "dsp-fw"
FW_WARN = ("-Wall -Wextra -Werror -Wconversion -Wdouble-promotion -Wshadow -Wstrict-prototypes "
           "-Wmissing-prototypes -Wcast-qual -Wvla").split()   # dsp-fw/Makefile's WARN
SCENES = ROOT / "scenes" / "cosim"
SCENARIOS = ("wall", "wdog", "hang", "dropout", "miscal", "bus")   # SCENES/NAME.toml
ERR_NONE, ERR_AXIS_FAULT, ERR_WATCHDOG = 0, 2, 6   # dsp-fw/README.md, "latched error codes"
STAT_FAULT0, STAT_WDOG = 1 << 0, 1 << 12           # rtl/regs/REGISTERS.md, STATUS
KT, AMP_GAIN, DAC_FS_V, CODE_FS = 0.06, 0.8, 10.0, 32767   # dsp-fw/README.md motor defaults
ENV_WALL = 1                                       # hg_proto.h HG_SCENE_WALL (run key env_kind)


@dataclass(frozen=True)
class BusTiming:
    """EMIF-like access in FPGA clocks (rtl/bus/README.md: strobe >= 5, recovery >= 3)."""
    setup: int = 1
    strobe: int = 5
    hold: int = 2
    use_ready: bool = False


class CosimSceneError(ValueError):
    """A malformed co-simulation scene (the message names the file and the dotted key)."""


# Every key of a co-simulation scene with its default (tb/native/cosim/README.md "Scenes").
DEFAULTS: dict[str, dict[str, object]] = {
    "run": {"kind": "servo", "servo_hz": 1000, "duration_s": 0.235},
    "hand": {"free_deg": [4.0, 46.0, 43.0], "deep_deg": [3.0, 42.0, 40.0], "in_s": 0.1,
             "hold_s": 0.02, "seed": 1},
    "wall": {"at": 0.45, "k": 2000.0},
    "bus": {"setup": 1, "strobe": 5, "hold": 2, "use_ready": False, "pairs": 200_000},
    "firmware": {"comm_err": [0, 0, 0]},
}
FAULT_KEYS = {"at_s": 0.0, "kind": "", "axis": 0}
T_HOMED_S = 3e-3   # the harness's time from the homing sweep's end to the push start (Trajectory)
KINDS = ("servo", "bus")
# the fault kinds every harness simulates: hg_dev::kFaultKinds less the device harness's
# flip-flop injections (tb/device/test_record_layout.py compares them, as
# hapgate.device.harness.HARNESS_FAULTS)
FAULT_KINDS = ("dropout", "hang", "watchdog")


@dataclass(frozen=True)
class CosimScene:
    name: str
    values: dict[str, dict[str, object]]      # every table's every key (defaults filled in)
    faults: tuple[dict[str, object], ...]     # at most one: at_s (from the push start), kind, axis
    bus: BusTiming

    def get(self, table: str, key: str) -> object:
        return self.values[table][key]


def _typed(path: Path, dotted: str, value: object, default: object) -> object:
    """`value` of the default's type (an int is taken for a float; lists by element)."""
    def ok(v: object, d: object) -> bool:
        if isinstance(d, bool) or isinstance(v, bool):
            return isinstance(v, bool) and isinstance(d, bool)
        if isinstance(d, float):
            return isinstance(v, (int, float)) and math.isfinite(v)
        return isinstance(v, type(d))
    if isinstance(default, list):
        if not (isinstance(value, list) and len(value) == len(default)
                and all(ok(v, d) for v, d in zip(value, default))):
            raise CosimSceneError(f"{path}: {dotted}: expected a list of {len(default)} "
                                  f"{type(default[0]).__name__}")
        return [float(v) if isinstance(d, float) else v for v, d in zip(value, default)]
    if not ok(value, default):
        raise CosimSceneError(f"{path}: {dotted}: expected {type(default).__name__}")
    return float(value) if isinstance(default, float) else value


def load(scene: str | Path) -> CosimScene:
    """A co-simulation scene by name (SCENES/NAME.toml) or path; unknown tables and keys, wrong
    types and impossible values are refused (CosimSceneError naming the file and the key)."""
    path = Path(scene) if isinstance(scene, Path) or str(scene).endswith(".toml") \
        else SCENES / f"{scene}.toml"
    import tomllib  # here, not at the top: `hapgate` itself still starts on Python 3.10

    try:
        doc = tomllib.loads(path.read_text())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as e:
        raise CosimSceneError(f"{path}: {e}") from None
    values = {t: dict(d) for t, d in DEFAULTS.items()}
    faults = []
    for table, body in doc.items():
        if table == "fault":
            if not isinstance(body, list):
                raise CosimSceneError(f"{path}: fault: expected [[fault]] tables")
            for i, f in enumerate(body):
                got = dict(FAULT_KEYS)
                for k, v in f.items():
                    if k not in FAULT_KEYS:
                        raise CosimSceneError(f"{path}: fault[{i}].{k}: unknown key")
                    got[k] = _typed(path, f"fault[{i}].{k}", v, FAULT_KEYS[k])
                if got["kind"] not in FAULT_KINDS:
                    raise CosimSceneError(f"{path}: fault[{i}].kind: one of "
                                          f"{', '.join(FAULT_KINDS)}")
                if got["axis"] not in (0, 1, 2):
                    raise CosimSceneError(f"{path}: fault[{i}].axis: 0, 1 or 2")
                faults.append(got)
            continue
        if table not in DEFAULTS or not isinstance(body, dict):
            raise CosimSceneError(f"{path}: {table}: unknown table")
        for k, v in body.items():
            if k not in DEFAULTS[table]:
                raise CosimSceneError(f"{path}: {table}.{k}: unknown key")
            values[table][k] = _typed(path, f"{table}.{k}", v, DEFAULTS[table][k])
    if len(faults) > 1:
        raise CosimSceneError(f"{path}: fault: at most one fault per co-simulation scene")
    if faults and not 0 <= faults[0]["at_s"] < values["run"]["duration_s"]:
        raise CosimSceneError(f"{path}: fault[0].at_s: inside the run (0 .. run.duration_s)")
    if values["run"]["kind"] not in KINDS:
        raise CosimSceneError(f"{path}: run.kind: one of {', '.join(KINDS)}")
    for t, k in (("run", "servo_hz"), ("run", "duration_s"), ("bus", "pairs"), ("wall", "k")):
        if not values[t][k] > 0:
            raise CosimSceneError(f"{path}: {t}.{k}: must be > 0")
    if values["run"]["servo_hz"] * T_HOMED_S <= 1:
        raise CosimSceneError(f"{path}: run.servo_hz: the firmware enables at the tick before "
                              f"the push start, which must come after the homing sweep "
                              f"({T_HOMED_S * 1e3:g} ms before it): more than "
                              f"{1 / T_HOMED_S:.0f} Hz")
    b = values["bus"]
    return CosimScene(path.stem, values, tuple(faults),
                      BusTiming(b["setup"], b["strobe"], b["hold"], b["use_ready"]))


def _rad(deg: list[float]) -> list[float]:
    return [x * math.pi / 180.0 for x in deg]


def wall_plane(sc: CosimScene) -> tuple[np.ndarray, np.ndarray, float]:
    """The scene's wall: its point (wall.at of the way from the free to the deep endpoint), its
    unit normal (from deep to free: into free space), m, and its stiffness, N/m (b = 0)."""
    pf = kinematics.fk(np.array(_rad(sc.get("hand", "free_deg"))))
    pd = kinematics.fk(np.array(_rad(sc.get("hand", "deep_deg"))))
    at = float(sc.get("wall", "at"))   # type: ignore[arg-type]
    return pf + at * (pd - pf), (pf - pd) / np.linalg.norm(pf - pd), float(sc.get("wall", "k"))


def run_config(sc: CosimScene) -> str:
    """The scene as the harness's run configuration (hg_dev::parse_run, cosim_* keys). Scene time
    0 is the start of the push; the poses in rad as the harness's deg() computes them. The
    firmware's wall is the env_* keys (`wall_plane`, as the device harness's run configuration
    gives its environment); cosim_wall_at and cosim_wall_k are the scene's wall again, from which
    the harness builds its check's reference with the plant's kinematics."""
    v = sc.values
    def rad(d: list[float]) -> str:
        return " ".join(repr(x) for x in _rad(d))
    def vec(x: np.ndarray) -> str:
        return " ".join(repr(float(c)) for c in x)
    b = sc.bus
    p0, n, k = wall_plane(sc)
    lines = [f"servo_hz = {v['run']['servo_hz']}", f"duration_s = {v['run']['duration_s']!r}",
             "progress_s = 0",
             f"cosim_kind = {KINDS.index(v['run']['kind'])}",
             f"cosim_bus = {b.setup} {b.strobe} {b.hold} {int(b.use_ready)}",
             f"cosim_bus_pairs = {v['bus']['pairs']}",
             f"q0 = {rad(v['hand']['free_deg'])}", f"cosim_q_deep = {rad(v['hand']['deep_deg'])}",
             f"cosim_push = {v['hand']['in_s']!r} {v['hand']['hold_s']!r}",
             f"cosim_seed = {v['hand']['seed']}",
             f"cosim_wall_at = {v['wall']['at']!r}", f"cosim_wall_k = {v['wall']['k']!r}",
             f"env_kind = {ENV_WALL}", f"env_point = {vec(p0)}", f"env_normal = {vec(n)}",
             f"env_k = {k!r}", "env_b = 0.0",
             "comm_err = " + " ".join(str(c) for c in v["firmware"]["comm_err"])]
    lines += [f"fault = {f['at_s']!r} {f['kind']} {f['axis']}" for f in sc.faults]
    return "\n".join(lines) + "\n"


def _fw_lib(bdir: Path, defines: tuple[str, ...] = ()) -> Path:
    """dsp-fw/src/*.c compiled as C99 with the firmware's own -Werror flags (and `defines`,
    e.g. "HG_SCENE_K_MAX_TEST=50000" for a simulation-only test limit)."""
    objs = []
    for src in sorted((FW / "src").glob("*.c")):
        obj = bdir / "fw" / (src.stem + ".o")
        ensure(obj.parent)
        cmd = ["gcc", "-std=c99", *FW_WARN, "-O2", *(f"-D{d}" for d in defines),
               "-I", str(FW / "include"), "-c", str(src),
               "-o", str(obj)]
        cbuild.run(cmd, bdir / "build.log", f"firmware ({src.name})")
        objs.append(obj)
    lib = bdir / "fw" / "libhgfw.a"
    cbuild.run(["ar", "rcs", str(lib), *map(str, objs)], bdir / "build.log", "firmware library")
    return lib


def build(cfg: TopConfig | None = None) -> Path:
    """Verilate the top with the harness and link the firmware; return the executable (cached).
    `cfg`: the paper's configuration when None."""
    cfg = cfg or configs.get("paper").top()
    srcs = [ROOT / "rtl" / s for s in SOURCES]
    fw_srcs = sorted((FW / "src").glob("*.c")) + sorted((FW / "include").glob("*.h"))
    return native.verilate_harness(
        "cosim_harness", "hapgate_top", [HERE / "public.vlt", *srcs], cfg.rtl_params(), HARNESS,
        cflags=(f"-std=c++17 -DCLK_HZ={cfg.clk_hz} -DHG_LOAD_CLOCKS={cfg.comm.load_clocks + 1} "
                f"-DHG_WR_CYCLES={cfg.comm.wr_cycles} -DHG_DAC_BITS={cfg.comm.dac_bits} "
                f"-DHG_DAC_OFFSET_BINARY={int(cfg.comm.offset_binary)} "
                f"-I{HERE} -I{DEVICE} -I{FW / 'include'}"),
        ldflags="fw/libhgfw.a -lm",          # relative to the build directory (make runs there)
        inputs=[HERE / "cosim.h", DEVICE / "testb.h", DEVICE / "bus_hal.h", DEVICE / "dac_word.h",
                DEVICE / "plant.h", DEVICE / "harness_common.h", *fw_srcs],
        prepare=_fw_lib)


@dataclass
class CosimRun:
    scenario: str
    rate_hz: int
    ok: bool                      # the harness's own verdict (exit code 0 and result=PASS)
    summary: dict[str, str]       # key=value lines of its stdout
    frames: np.ndarray            # structured, one row per DAC frame (frames.csv)
    ticks: np.ndarray             # TICK_DT, one per ISR call (ticks.bin, the scenario engine's)
    isr: np.ndarray               # structured, the same rows: irq/start/end edges, codes (isr.csv)
    loads: np.ndarray             # LOAD_DT, every DAC load (loads.bin)
    wall_s: float                 # wall-clock time of the harness process
    scene: CosimScene             # what was run (the overrides applied)
    fails: list[str] = field(default_factory=list)
    warns: list[str] = field(default_factory=list)
    fault: str = ""               # the scene's fault kind ("": a normal run)

    def num(self, key: str) -> float:
        return float(self.summary[key])

    def vec(self, key: str) -> np.ndarray:
        return np.array([float(x) for x in self.summary[key].split(",")])

    @property
    def simulated_s(self) -> float:
        """Simulated time from reset: the homing sweep and the scene (sim_s: the scene's)."""
        return self.num("clocks") / self.num("clk_hz")


def run(scene: str | Path = "wall", rate_hz: int | None = None, bus: BusTiming | None = None,
        cfg: TopConfig | None = None, seed: int | None = None,
        keep: Path | None = None) -> CosimRun:
    """One scene (a name in SCENES or a path, `load()`); `rate_hz`, `bus` and `seed` (the joints'
    power-up positions, uniform over the whole revolution) override the scene's. `keep`: write
    the outputs into this directory instead of a temporary one."""
    sc = load(scene)
    if rate_hz is not None:
        sc.values["run"]["servo_hz"] = rate_hz
    if seed is not None:
        sc.values["hand"]["seed"] = seed
    if bus is not None:
        sc = replace(sc, bus=bus)
    scenario, rate_hz = sc.name, int(sc.get("run", "servo_hz"))
    exe = build(cfg)
    tag = f"{scenario}-{rate_hz}-s{sc.get('hand', 'seed')}-"
    with tempfile.TemporaryDirectory(prefix=tag, dir=ensure(exe.parent / "runs")) as tmp:
        out = ensure(keep) if keep is not None else Path(tmp)
        run_cfg = Path(tmp) / f"{scenario}.run"     # its stem names the scenario in the summary
        run_cfg.write_text(run_config(sc))
        t0 = time.perf_counter()
        proc = subprocess.run([str(exe), str(run_cfg), str(out)], capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if proc.returncode not in (0, 1) or "result=" not in proc.stdout:
            raise RuntimeError(f"co-sim harness failed ({proc.returncode}): {proc.stderr.strip()}")
        if sc.get("run", "kind") == "bus":   # no firmware, no frames
            frames = isr = np.zeros(0)
            ticks, loads = np.zeros(0, dtype=TICK_DT), np.zeros(0, dtype=LOAD_DT)
        else:
            frames = np.genfromtxt(out / "frames.csv", delimiter=",", names=True, dtype=None)
            isr = np.genfromtxt(out / "isr.csv", delimiter=",", names=True, dtype=None)
            ticks = np.fromfile(out / "ticks.bin", dtype=TICK_DT)
            loads = np.fromfile(out / "loads.bin", dtype=LOAD_DT)
    summary: dict[str, str] = {}
    fails, warns = [], []
    for line in proc.stdout.splitlines():
        head, _, rest = line.partition("=")
        if head in ("fail", "warn"):
            (fails if head == "fail" else warns).append(rest)
            continue
        for kv in line.split(" "):
            k, _, v = kv.partition("=")
            summary[k] = v
    ok = proc.returncode == 0 and summary.get("result") == "PASS"
    isr = np.atleast_1d(isr)
    if sc.get("run", "kind") != "bus" and (int(summary["tick_bytes"]) != TICK_DT.itemsize
                                            or len(ticks) != len(isr)):
        raise RuntimeError(f"co-sim harness: {len(ticks)} ticks of {summary['tick_bytes']} bytes "
                           f"(TICK_DT: {TICK_DT.itemsize}) beside {len(isr)} ISR rows")
    return CosimRun(scenario, rate_hz, ok, summary, np.atleast_1d(frames), ticks, isr,
                    loads, wall, sc, fails, warns, sc.faults[0]["kind"] if sc.faults else "")


# ---------------------------------------------------------------------------- independent check

@dataclass
class Check:
    torque_err: np.ndarray        # (frames, 3) |reconstructed - commanded| (command codes)
    torque_budget: np.ndarray     # (frames, 3)
    force: np.ndarray             # (m, 3) reconstructed endpoint force, N (attributable frames)
    force_expected: np.ndarray    # (m, 3) n * k * max(0, depth)
    force_budget: np.ndarray      # (m,)
    depth: np.ndarray             # (m,) m, at the pose the firmware sampled
    t_force: np.ndarray           # (m,) s
    t_cmd: np.ndarray             # (frames, 3) commanded (upper candidate)
    t_rec: np.ndarray             # (frames, 3) reconstructed
    t_frame: np.ndarray           # (frames,) s

    @property
    def max_force_err(self) -> float:
        e = np.linalg.norm(self.force - self.force_expected, axis=1)
        return float(e.max()) if e.size else 0.0


def _frame_torque_budget(tmax: np.ndarray, cc: commutation.CommutationConfig) -> np.ndarray:
    """Worst-case |reconstructed - commanded| torque code for a sine frame: +-1/2 LSB output
    rounding and +-1/2 ROM LSB x t/2^SH per phase, through the amplifier's 2-of-3 reconstruction
    (<= sqrt(3)(|ea| + |eb|)), scaled to command codes, plus the commutation's ripple budget."""
    scale = (1 << cc.shift) / (1.5 * cc.rom.fs)
    per_phase = 0.5 + 0.5 * tmax / (1 << cc.shift)
    return 2 * np.sqrt(3) * per_phase * scale + commutation.SINE_RIPPLE_BUDGET * tmax


def check(r: CosimRun, cfg: TopConfig | None = None) -> Check:
    """Recompute the torque and force checks from the run's raw outputs with the golden models
    (`cfg`: the paper's configuration when None)."""
    cfg = cfg or configs.get("paper").top()
    cc = cfg.comm
    f = r.frames
    clk = r.num("clk_hz")
    normal = not r.fault
    normal_end = np.inf if normal else (r.num("cause_edge") or r.num("fault_cmd_edge"))
    # frames whose six loads all came before the cause (a frame the cause cuts through has some
    # channels zeroed: reaction_clocks covers those)
    last_load = f["start"] + cc.load_clocks + 1 + 5 * cc.skew_clocks
    sel = (f["start"] > 0) & (last_load < normal_end)
    f = f[sel]
    codes = np.stack([f[f"c{i}"] for i in range(6)], 1).astype(np.float64)
    q = np.stack([f[f"q{i}"] for i in range(3)], 1)
    q_index = r.vec("q_index")
    home = home_error(r)
    home_q = 256 * np.round(home / 256) * 2 * np.pi / 2**20   # whole quadrants, rad
    theta = cc.pole_pairs * (q - q_index)            # electrical angle from the index (winding 0)
    tlo = np.stack([f[f"tlo{i}"] for i in range(3)], 1).astype(np.float64)
    thi = np.stack([f[f"thi{i}"] for i in range(3)], 1).astype(np.float64)
    t_rec = np.empty_like(tlo)
    for m in range(3):
        ia, ib = codes[:, 2 * m] / cc.rom.fs, codes[:, 2 * m + 1] / cc.rom.fs
        _, s = commutation.motor_torque(ia, ib, theta[:, m])
        # a matched drive of command t gives s = 1.5 * (FS * t / 2^SH) / FS
        t_rec[:, m] = s / 1.5 * (1 << cc.shift)
    err = np.minimum(np.abs(t_rec - tlo), np.abs(t_rec - thi))
    budget = _frame_torque_budget(np.maximum(np.abs(tlo), np.abs(thi)), cc)

    # endpoint force at the pose the firmware sampled (frames attributable to one ISR)
    fs = (f["snap_edge"] >= 0) & np.all(tlo == thi, axis=1)
    qs = np.stack([f[f"qs{i}"] for i in range(3)], 1)[fs] + home_q   # in the firmware's homed frame
    nm_per_code = KT * AMP_GAIN * DAC_FS_V / CODE_FS
    tau = t_rec[fs] * nm_per_code
    jac = kinematics.jacobian(qs)
    force = np.linalg.solve(np.swapaxes(jac, -1, -2), tau[..., None])[..., 0]
    p0, n, k = wall_plane(r.scene)   # the scene's, not the harness's
    depth = (p0 - kinematics.fk(qs)) @ n
    mag = np.where(f["drive"][fs] == 1, k * np.maximum(depth, 0.0), 0.0)
    expected = n[None, :] * mag[:, None]
    # budget: torque budget through J^-T, 4 counts + 3 us of motion per joint through k J, float
    jit = np.linalg.inv(np.swapaxes(jac, -1, -2))
    s_jit = np.linalg.norm(jit, ord=2, axis=(1, 2))
    s_j = np.linalg.norm(jac, ord=2, axis=(1, 2))
    qd = np.gradient(q, f["start"] / clk, axis=0)[fs]
    dq = np.linalg.norm(qd, axis=1) * 3e-6 + np.sqrt(3) * interp_budget_counts() * 2 * np.pi / 2**20
    fb = (s_jit * np.linalg.norm(budget[fs] * nm_per_code, axis=1) + k * s_j * dq + 1e-4 * mag)
    return Check(torque_err=err, torque_budget=budget, force=force, force_expected=expected,
                 force_budget=fb, depth=depth, t_force=f["start"][fs] / clk, t_cmd=thi,
                 t_rec=t_rec, t_frame=f["start"] / clk)


def home_error(r: CosimRun) -> np.ndarray:
    """Firmware joint angle minus the truth of its sample, counts, at the first driving tick
    (the tick at the push start: its sample is the last before the push, the joints at rest at
    the free pose)."""
    t = r.ticks[np.flatnonzero(r.ticks["drive"] == 1)[0]]
    return (t["q_fw"] - t["q_true"]) * 2**20 / (2 * np.pi)


def interp_budget_counts(amplitude: float = 110.0, sweep_lines: int = 4) -> float:
    """Worst |interpolated - true| position of hapgate.golden.interp on ideal signals of this
    amplitude,
    counts (measured on a fine sweep with the golden model), plus 1/2 count of float."""
    n = sweep_lines * 4096
    lines = 0.1 + np.arange(n) * (sweep_lines / n)
    a, b = encsig.adc_codes(lines, encsig.SignalSpec(amplitude=amplitude))
    out = interp.run(a, b)
    err = out.pos - (lines - np.floor(lines[0])) * 1024
    return float(np.abs(err).max()) + 0.5


def reaction_clocks(r: CosimRun, channels: list[int]) -> int:
    """Clocks from the cause edge to the first load after which every load of these channels is
    zero (max over the channels); -1 if some channel never settles at zero."""
    cause = int(r.num("cause_edge"))
    worst = 0
    for c in channels:
        ld = r.loads[(r.loads["ch"] == c) & (r.loads["edge"] >= cause)]
        nz = np.flatnonzero(ld["code"] != 0)
        rest = ld[nz[-1] + 1:] if nz.size else ld
        if rest.size == 0:
            return -1
        worst = max(worst, int(rest["edge"][0]) - cause)
    return worst


# ---------------------------------------------------------------------------- make demo / bench

def _row(r: CosimRun, c: Check | None) -> list[object]:
    tx = r.num("bus_reads") + r.num("bus_writes")
    ferr = c.max_force_err if c is not None else float("nan")
    react = "-"
    if r.fault:
        clocks = int(r.summary["reaction_clocks"])
        react = f"{clocks / r.num('clk_hz') * 1e6:.2f} us ({clocks} clk)"
    return [f"{r.scenario} @ {r.rate_hz} Hz", f"{r.simulated_s * 1e3:.1f} ms",
            f"{r.num('wall_s'):.2f} s", f"{tx / r.num('wall_s') / 1e3:.0f} k",
            int(r.num("ticks")), f"{ferr * 1e3:.2f} mN", react,
            "PASS" if r.ok else "FAIL " + "; ".join(r.fails)]


def demo_section() -> bool:
    print("== firmware co-simulation (dsp-fw against the Verilated top over the EMIF bus) ==")
    t0 = time.perf_counter()
    exe = build()
    print(f"build: {exe.parent.name} ({time.perf_counter() - t0:.1f} s)")
    runs = [run("wall", 1000), run("wall", 10000), run("wdog"), run("hang"), run("dropout")]
    checks = [check(r) for r in runs]
    rows = [_row(r, c) for r, c in zip(runs, checks)]
    paper = configs.get("paper").top().comm
    bound = paper.frame_clocks + paper.wr_cycles + 1
    print(report.table(["scenario", "simulated", "wall clock", "bus tx/s", "ticks",
                        "max |F err|", f"zero torque after cause (<= {bound} clk)", "result"],
                       rows))
    for w in sorted({w for r in runs for w in r.warns}):
        print(f"note: {w} (tb/native/cosim/README.md, 'Known issue')")
    plt = report.pyplot()
    fig, ax = plt.subplots(1, 3, figsize=(15, 4))
    w, c = runs[0], checks[0]
    ax[0].plot(c.t_force * 1e3, np.maximum(c.depth, 0) * 1e3)
    ax[0].set(xlabel="time (ms)", ylabel="penetration depth (mm)", title="wall @ 1 kHz")
    for m in range(3):
        ax[1].plot(c.t_frame * 1e3, c.t_cmd[:, m], lw=2, alpha=0.5, label=f"commanded m{m}")
        ax[1].plot(c.t_frame * 1e3, c.t_rec[:, m], "k:", lw=0.8)
    ax[1].set(xlabel="time (ms)", ylabel="torque command code",
              title="commanded vs reconstructed (dotted)")
    ax[1].legend(fontsize=7)
    n = w.vec("wall_n")
    ax[2].plot(np.maximum(c.depth, 0) * 1e3, c.force @ n, ".", ms=2, label="F.n reconstructed")
    dd = np.linspace(0, max(c.depth.max(), 0) * 1e3, 10)
    ax[2].plot(dd, w.num("wall_k") * dd / 1e3, "r-", lw=1, label="k d")
    ax[2].set(xlabel="depth (mm)", ylabel="force along n (N)", title="force vs depth")
    ax[2].legend(fontsize=7)
    fig.tight_layout()
    path = report.figure_path("demo_cosim.png")
    report.save_figure(fig, path, dpi=110)
    plt.close(fig)
    print(f"figure: {path}")
    return all(r.ok for r in runs) and all(
        bool(np.all(ck.torque_err <= ck.torque_budget)) for ck in checks)


def bench_section(quick: bool = False) -> bool:
    print("== firmware co-simulation speed ==")
    build()
    rows = []
    ok = True
    buses = [BusTiming()] if quick else [BusTiming(), BusTiming(use_ready=True)]
    for bus in buses:
        for rate in (1000, 10000):
            r = run("wall", rate, bus)
            ok = ok and r.ok
            tx = r.num("bus_reads") + r.num("bus_writes")
            rows.append([f"{rate} Hz", "ready" if bus.use_ready else
                         f"{bus.setup}/{bus.strobe}/{bus.hold}", f"{r.simulated_s * 1e3:.0f} ms",
                         f"{r.num('wall_s'):.2f} s", int(tx), f"{tx / r.num('wall_s') / 1e3:.1f} k",
                         f"{r.num('clocks') / r.num('wall_s') / 1e6:.2f} M",
                         f"{r.num('sim_per_wall'):.4f}", "PASS" if r.ok else "FAIL"])
    for bus in buses:   # bus-bound: back-to-back SCRATCH write / read-back, no firmware
        r = run("bus", bus=bus)
        ok = ok and r.ok
        tx = r.num("bus_reads") + r.num("bus_writes")
        timing = "ready" if bus.use_ready else f"{bus.setup}/{bus.strobe}/{bus.hold}"
        rows.append(["bus only", timing,
                     f"{r.simulated_s * 1e3:.0f} ms", f"{r.num('wall_s'):.2f} s", int(tx),
                     f"{tx / r.num('wall_s') / 1e3:.1f} k",
                     f"{r.num('clocks') / r.num('wall_s') / 1e6:.2f} M",
                     f"{r.num('sim_per_wall'):.4f}", "PASS" if r.ok else "FAIL"])
    print(report.table(["tick", "bus setup/strobe/hold", "simulated", "wall", "bus tx",
                        "bus tx/s", "clocks/s", "sim us / wall us", "result"], rows))
    report.write_csv("bench_cosim.csv", ["tick", "bus", "simulated", "wall", "bus_tx", "tx_per_s",
                                         "clocks_per_s", "sim_per_wall", "result"], rows)
    return ok
