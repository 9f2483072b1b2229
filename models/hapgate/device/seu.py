"""Fault injection into the gateware's flip-flops in the closed loop (issue 38): the job of the
`seu` sweep kind, its classification and the single-point fault metric.

One job = one run of the virtual device (scenes/seu/rest.toml: a hand resting on a wall) on
the saboteur netlist (hapgate.flows.saboteur: every flip-flop of hapgate_top, each with an
injection port), with one fault drawn from the job's seed:

- the site uniformly over every flip-flop bit of the design (so each block weighs by its bits);
- a single-event upset (probability `p_seu`, default 0.5: the bit inverted once, at one clock
  edge) or a stuck-at-0/1 (equally likely) held for a log-uniform number of DAC frames in
  1..`frames_max` (default 512 frames = 8.2 ms);
- the time uniformly over the clocks of `t_min_s`..`t_max_s` of scene time (default 1..20 ms).

Its reference is the clean run of the same scene on the same build (run once, cached in
build/sweeps/cache/seu_ref/). `classify` compares the two (the budgets and the classes are
stated in scenes/seu/README.md and docs/verification.md, "Fault injection"):

- hang: the harness did not finish, or the DSP was not served (two servo ticks or more fewer
  than the reference's after the injection);
- detected: a latch (the firmware's latched error, or a sticky fault bit of STATUS that the
  reference does not have) and every DAC channel at zero from at most REACT_S after the tick
  that shows the latch on, with no torque violation earlier than FTTI before that zero;
- silent: a torque violation with nothing latched;
- violation_latched: a violation, latched, but not brought to zero in time (counted as
  dangerous, like silent);
- latched: latched without a violation and without reaching zero in time;
- masked: no violation, nothing latched (`identical` says whether the torque and the DAC
  loads are the reference's bit for bit).

A torque violation: the delivered torque of any motor (the plant's, after the amplifier) more
than BUDGET_DEV_NM from the reference's for two frames in a row or more, or a frame-to-frame
step more than BUDGET_STEP_NM beyond the reference's step; judged from the injection to the
end of the run, or to the safe state (all DAC codes zero) once a latch or the FPGA watchdog
(a hang) has brought it. SPFM = 1 − dangerous / runs (ISO 26262-5 at equal failure rates per
bit), dangerous = silent + violation_latched + hangs with a violation.
"""

from __future__ import annotations

import functools
import math
import shlex
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..base import cache
from ..base.paths import BUILD, ROOT, ensure, locked
from ..flows import saboteur
from . import runner
from .harness import DeviceError
from .scene import load as load_scene

SCENE = ROOT / "scenes" / "seu" / "rest.toml"
# the budgets (scenes/seu/README.md): stated, not taken from the configuration under test
BUDGET_DEV_NM = 0.01        # N m per motor: 2.1 % of the 0.48 N m full scale, 0.2 N at the handle
BUDGET_DEV_FRAMES = 2       # "more than one frame": two consecutive frames or more outside
BUDGET_STEP_NM = 0.02       # N m per frame (16 us) beyond the reference's own step
REACT_S = 50e-6             # latch tick -> all DAC codes zero: the ISR's 14 accesses (28 us),
                            # one frame (16 us) and the load (2 us), rounded up
HANG_TICKS = 2              # ticks missing after the injection that make the DSP "not served"
STICKY = 0x7 | 0x1F000      # STATUS: FAULT[2:0], WDOG, CFG_ERR, BUS_ERR, PROTO_ERR, HW_FAULT
CLASSES = ("masked", "detected", "latched", "silent", "violation_latched", "hang")
MODES = ("flip", "stuck0", "stuck1")
DEFAULTS: dict[str, Any] = {"p_seu": 0.5, "t_min_s": 1e-3, "t_max_s": 20e-3, "frames_max": 512}
RUN_TIMEOUT_S = 300.0
FRAME_S = 16e-6


# ---------------------------------------------------------------------------------- injections
@dataclass(frozen=True)
class Injection:
    site: str           # register[bit]
    index: int          # the site's index in the design's list
    block: str
    register: str
    mode: str           # flip | stuck0 | stuck1
    at_s: float         # scene time of the first injected clock edge
    frames: int         # stuck: DAC frames held (flip: 0)

    def cfg_line(self, design: saboteur.Design) -> str:
        """The run configuration's fault line (harness_common.h: the site's port bit)."""
        port = design.sites[self.index].port
        if self.mode == "flip":
            return f"fault = {self.at_s!r} seu {port}\n"
        return f"fault = {self.at_s!r} stuck {port} {int(self.mode == 'stuck1')} {self.frames}\n"

    def replay(self, scene: Path | str = SCENE) -> str:
        """The command line that runs this injection again and prints its class."""
        rel = Path(scene).resolve()
        rel = rel.relative_to(ROOT) if rel.is_relative_to(ROOT) else rel
        cmd = ["hapgate", "seu", "run", str(rel), "--site", self.site, "--mode", self.mode,
               "--at-s", repr(self.at_s)]
        if self.mode != "flip":
            cmd += ["--frames", str(self.frames)]
        return shlex.join(cmd)


def draw(seed: int, design: saboteur.Design, clk_hz: int, p: Mapping[str, Any]) -> Injection:
    """The injection of job seed `seed` (site, mode, time, duration: module docstring)."""
    q = {**DEFAULTS, **{k: p[k] for k in DEFAULTS if k in p}}
    rng = np.random.default_rng([int(seed), 0x5E0])
    i = int(rng.integers(len(design.sites)))
    u = rng.random(3)
    mode = "flip" if u[0] < float(q["p_seu"]) else ("stuck1" if u[1] < 0.5 else "stuck0")
    e0, e1 = round(float(q["t_min_s"]) * clk_hz), round(float(q["t_max_s"]) * clk_hz)
    edge = int(rng.integers(e0, e1 + 1))
    frames = 0 if mode == "flip" else int(min(int(q["frames_max"]), math.floor(
        math.exp(u[2] * math.log(int(q["frames_max"]) + 1)))))
    s = design.sites[i]
    return Injection(s.name, i, s.block, s.register, mode, edge / clk_hz, max(frames, 0))


def injection(design: saboteur.Design, site: str, mode: str, at_s: float,
              frames: int = 0) -> Injection:
    """An injection by name (the replay command's): site `register[bit]` or its index."""
    if mode not in MODES:
        raise ValueError(f"mode: {mode!r}: one of {', '.join(MODES)}")
    if mode != "flip" and frames < 1:
        raise ValueError("frames: a stuck-at lasts at least one frame")
    s = design.find(site)
    return Injection(s.name, s.index, s.block, s.register, mode, float(at_s),
                     0 if mode == "flip" else int(frames))


# ---------------------------------------------------------------------------------- runs
@dataclass
class Trace:
    """What the classification reads of one run (scene times, s)."""
    t: np.ndarray               # frame starts
    tau: np.ndarray             # delivered motor torque per frame, N m (n x 3)
    tick_t: np.ndarray
    tick_err: np.ndarray
    tick_status: np.ndarray
    load_t: np.ndarray
    load_ch: np.ndarray
    load_code: np.ndarray
    cpu_s: float = 0.0
    ok: bool = True             # the harness finished
    why: str = ""

    @staticmethod
    def of(raw: runner.Raw) -> Trace:
        s = raw.summary
        t0 = int(s["scene0_us"]) * 1e-6
        ld = raw.loads
        return Trace(raw.frames["t"].copy(), raw.frames["tau"].copy(), raw.ticks["t"].copy(),
                     raw.ticks["err"].copy(), raw.ticks["status"].copy(),
                     ld["edge"] / raw.clk_hz - t0, ld["ch"].copy(), ld["code"].copy(),
                     float(s.get("cpu_s", "nan")))

    @staticmethod
    def failed(why: str) -> Trace:
        e = np.zeros(0)
        return Trace(e, np.zeros((0, 3)), e, e.astype(np.uint8), e.astype(np.uint32), e,
                     e.astype(np.int32), e.astype(np.int32), ok=False, why=why)

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: v for k, v in asdict(self).items() if isinstance(v, np.ndarray)}


@functools.lru_cache(maxsize=4)
def _setup(scene_digest: str, scene_path: str) -> tuple[Any, saboteur.Design, int]:
    del scene_digest                                # (the cache's key: the scene's content)
    sc = load_scene(scene_path)
    if tuple(sc.run.axes) != (0, 1, 2) or sc.run.fidelity != "rtl":
        raise ValueError(f"{scene_path}: run.axes: the campaign runs the whole design "
                         "(axes 0, 1, 2, rtl fidelity)")
    clk = runner.choose_clock(sc)
    return sc, saboteur.device_design(clk, str(sc.run.config)), clk


def setup(scene_path: Path | str = SCENE) -> tuple[Any, saboteur.Design, int]:
    """The scene, its saboteur design and clock (cached per process)."""
    sc = load_scene(scene_path)
    return _setup(sc.digest(), str(scene_path))


def simulate(sc: Any, design: saboteur.Design, inj: Injection | None,
             out_dir: Path | None = None) -> Trace:
    """One run on the saboteur build (no injection: the reference); a harness that fails or
    exceeds RUN_TIMEOUT_S gives a failed Trace (a hang)."""
    extra = inj.cfg_line(design) if inj is not None else ""
    try:
        raw = runner.simulate(sc, gate=False, saboteur=design, extra=extra, out_dir=out_dir,
                              timeout_s=RUN_TIMEOUT_S)
    except DeviceError as exc:
        return Trace.failed(str(exc)[-300:])
    return Trace.of(raw)


def reference(sc: Any, design: saboteur.Design) -> Trace:
    """The clean run of the scene on the saboteur build (cached under build/sweeps/cache/
    seu_ref/, keyed by the scene's content and the build)."""
    exe = runner.build(runner.choose_clock(sc), 7, gate=False, saboteur=design)
    key = cache.digest(data={"scene": sc.digest(), "exe": exe.parent.name}, length=24)
    d = ensure(BUILD / "sweeps" / "cache" / "seu_ref")
    f = d / f"{key}.npz"
    with locked(f):
        if not f.exists():
            tr = simulate(sc, design, None)
            if not tr.ok:
                raise DeviceError(f"the reference run failed: {tr.why}")
            if (tr.tick_err != 0).any():
                raise DeviceError("the reference run latched a firmware error: no reference")
            tmp = d / f".{key}.npz"
            with open(tmp, "wb") as fh:
                np.savez(fh, cpu_s=tr.cpu_s, **tr.arrays())
            tmp.replace(f)
    z = np.load(f)
    return Trace(**{k: z[k] for k in z.files if k != "cpu_s"}, cpu_s=float(z["cpu_s"]))


# ---------------------------------------------------------------------------------- classes
def safe_from(tr: Trace, t_i: float) -> float:
    """The time from which every DAC channel stays at zero (its loads from then on and its
    last load are 0), not before t_i; inf if some channel's last word is not zero."""
    t_z = t_i
    for ch in range(6):
        sel = tr.load_ch == ch
        codes, times = tr.load_code[sel], tr.load_t[sel]
        if codes.size == 0:
            continue
        nz = np.flatnonzero(codes != 0)
        if nz.size and nz[-1] == codes.size - 1:
            return math.inf
        if nz.size:
            t_z = max(t_z, float(times[nz[-1] + 1]))
    return t_z


def _first_run(mask: np.ndarray, n: int) -> int:
    """Index of the first run of at least n True in a row (-1: none), vectorised."""
    if n <= 1:
        hit = np.flatnonzero(mask)
        return int(hit[0]) if hit.size else -1
    c = np.convolve(mask.astype(np.int32), np.ones(n, np.int32), mode="valid")
    hit = np.flatnonzero(c == n)
    return int(hit[0]) if hit.size else -1


def classify(ref: Trace, run: Trace, t_i: float, servo_hz: int = 1000) -> dict[str, Any]:
    """The class of one run against its reference (module docstring) and what it rests on."""
    out: dict[str, Any] = {"class": "", "dangerous": False, "violation": False,
                           "latched": False, "safe": False, "identical": False,
                           "max_dev_nm": math.nan, "max_step_nm": math.nan,
                           "t_violation_s": math.nan, "t_latch_s": math.nan,
                           "t_zero_s": math.nan, "fw_err": 0, "status_new": 0, "to_zero": False}
    if not run.ok:
        out.update({"class": "hang", "dangerous": True, "violation": True})
        return out
    n_ref = int((ref.tick_t >= t_i).sum())
    n_run = int((run.tick_t >= t_i).sum())
    hang = n_run <= n_ref - HANG_TICKS
    # the latch: the firmware's error, or a sticky STATUS fault bit the reference has not
    m = min(ref.tick_t.size, run.tick_t.size)
    after = run.tick_t[:m] >= t_i
    new_bits = (run.tick_status[:m] & ~ref.tick_status[:m]) & STICKY
    lat = after & ((run.tick_err[:m] != 0) | (new_bits != 0))
    k = np.flatnonzero(lat)
    latched = bool(k.size)
    t_l = float(run.tick_t[k[0]]) if latched else math.inf
    if latched:
        out["fw_err"] = int(run.tick_err[:m][after].max())
        out["status_new"] = int(np.bitwise_or.reduce(new_bits[after]))
    t_z = safe_from(run, t_i)
    # the judged window: from the injection to the end, or to the safe state once a latch or
    # the watchdog (a hang) has brought it
    t_end = t_z if (math.isfinite(t_z) and (latched or hang)) else math.inf
    n = min(ref.t.size, run.t.size)
    t = run.t[:n]
    win = (t >= t_i) & (t < t_end)
    dev = np.abs(run.tau[:n] - ref.tau[:n]).max(axis=1)
    step = np.zeros(n)
    step[1:] = np.abs(np.diff(run.tau[:n], axis=0) - np.diff(ref.tau[:n], axis=0)).max(axis=1)
    step_win = win.copy()
    step_win[1:] &= win[:-1]                         # both frames of the step in the window
    i_dev = _first_run(win & (dev > BUDGET_DEV_NM), BUDGET_DEV_FRAMES)
    i_step = _first_run(step_win & (step > BUDGET_STEP_NM), 1)
    cand = [float(t[i]) for i in (i_dev, i_step) if i >= 0]
    violation = bool(cand)
    t_v = min(cand) if cand else math.inf
    sel = t >= t_i
    out.update({"violation": violation, "latched": latched, "safe": math.isfinite(t_z),
                "max_dev_nm": float(dev[sel].max()) if sel.any() else 0.0,
                "max_step_nm": float(step[sel].max()) if sel.any() else 0.0,
                "t_violation_s": t_v, "t_latch_s": t_l, "t_zero_s": t_z})
    ftti = 1.0 / servo_hz + REACT_S
    detected = (latched and math.isfinite(t_z) and t_z <= t_l + REACT_S
                and (not violation or t_z - t_v <= ftti))
    if hang:
        cls = "hang"
    elif detected:
        cls = "detected"
    elif violation and not latched:
        cls = "silent"
    elif violation:
        cls = "violation_latched"
    elif latched:
        cls = "latched"
    else:
        cls = "masked"
    out["class"] = cls
    out["dangerous"] = cls in ("silent", "violation_latched") or (hang and violation)
    out["to_zero"] = cls == "silent" and math.isfinite(t_z)
    if cls == "masked":
        sl = run.t >= t_i
        ls, lr = run.load_t >= t_i, ref.load_t >= t_i
        out["identical"] = bool(
            run.t.size == ref.t.size and np.array_equal(run.tau[sl], ref.tau[sl])
            and np.array_equal(run.load_code[ls], ref.load_code[lr]))
    return out


def spfm(dangerous: int, total: int) -> float:
    """The single-point fault metric at equal failure rates per bit: 1 - dangerous / total."""
    return 1.0 - dangerous / total if total else math.nan


# ---------------------------------------------------------------------------------- the job
def check(p: Mapping[str, Any]) -> None:
    for k in ("p_seu", "t_min_s", "t_max_s"):
        v = p.get(k, DEFAULTS[k])
        if not isinstance(v, int | float) or isinstance(v, bool) or not math.isfinite(v):
            raise ValueError(f"fixed.{k}: a number")
    if not 0 <= float(p.get("p_seu", 0.5)) <= 1:
        raise ValueError("fixed.p_seu: a probability, 0..1")
    fm = p.get("frames_max", DEFAULTS["frames_max"])
    if not isinstance(fm, int) or isinstance(fm, bool) or fm < 1:
        raise ValueError("fixed.frames_max: an integer >= 1")
    sc = load_scene(p.get("base", SCENE))
    t0, t1 = float(p.get("t_min_s", 1e-3)), float(p.get("t_max_s", 20e-3))
    if not 0 < t0 <= t1 < float(sc.run.duration_s):
        raise ValueError(f"fixed.t_min_s, t_max_s: 0 < t_min_s <= t_max_s < the scene's "
                         f"{sc.run.duration_s} s")
    if tuple(sc.run.axes) != (0, 1, 2) or sc.run.fidelity != "rtl":
        raise ValueError("sweep.base: the campaign's scene runs axes 0, 1, 2 at rtl fidelity")


def run_one(scene_path: Path | str, inj: Injection, out_dir: Path | None = None
            ) -> tuple[dict[str, Any], Trace, Trace]:
    """One injection and its classification (with the two traces)."""
    sc, design, _clk = setup(scene_path)
    ref = reference(sc, design)
    tr = simulate(sc, design, inj, out_dir)
    rec = classify(ref, tr, inj.at_s, int(sc.run.servo_hz))
    return rec, ref, tr


def job(p: Mapping[str, Any]) -> dict[str, Any]:
    """One injection of the campaign (module docstring): the fault, its class, the replay."""
    check(p)
    scene_path = str(p.get("base", SCENE))
    sc, design, clk = setup(scene_path)
    inj = draw(int(p["seed"]), design, clk, p)
    rec, _ref, tr = run_one(scene_path, inj)
    return {"site": inj.site, "site_index": inj.index, "block": inj.block,
            "register": inj.register, "mode": inj.mode, "at_s": inj.at_s,
            "frames": inj.frames, **rec, "harness_cpu_s": tr.cpu_s,
            "replay": inj.replay(scene_path)}
