"""The virtual device at model fidelity (scene `run.fidelity = "model"`): the FPGA replaced by a
transaction-level C++ port of the golden models (tb/native/device/model_harness.cpp), the
unchanged firmware, the multirate plant. Plain g++, no Verilator; built once per source set
(cached under build/native/model_harness-<hash>/). What it simplifies and how far it can differ
from the RTL: tb/native/device/README.md, "Model fidelity".

`simulate(scene)` returns the same `harness.Raw` as the RTL path, so `runner.metrics`, `events`
and `hapgate.device.result` work unchanged.
"""

from __future__ import annotations

import subprocess
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ..base import cache, cbuild
from ..base.paths import BUILD, ensure
from ..flows import regmap
from ..golden import configs, encsig, interp
from ..golden.commutation import CommutationConfig
from ..golden.interp import InterpConfig
from ..golden.sine import quarter_table
from ..runners import cosim
from . import harness
from .scene import SceneError

SOURCES = [harness.HERE / "model_harness.cpp", harness.HERE / "harness_common.cpp",
           harness.HERE / "plant.cpp"]
HEADERS = [harness.HERE / "harness_common.h", harness.HERE / "plant.h",
           harness.HERE / "dac_word.h", harness.HERE / "bus_hal.h"]
MECH_US = 16              # mechanics step of the multirate plant, us (README "Model fidelity")
# -flto: the plant's small calls (amplifier, DAC command, joint angles) inline into the harness;
# no -ffast-math and no FMA target, so the floating point is the RTL harness's bit for bit (test)
CXX = ["g++", "-std=c++17", "-O3", "-flto=auto", "-fno-math-errno", "-Wall", "-Wextra", "-Werror"]
# What the model replaces, for the run's "built" list.
REPLACES = "golden models in place of the gateware (interpolators, register file, commutator, " \
           "DAC scheduler: transaction level)"


def build(test_limits: bool = False) -> Path:
    """Compile the model harness with the plant and the firmware library (cached)."""
    defs = (f"HG_SCENE_K_MAX_TEST={harness.K_MAX_TEST:.1f}",) if test_limits else ()
    fw_srcs = (sorted((harness.FW / "src").glob("*.c"))
               + sorted((harness.FW / "include").glob("*.h")))
    key = cache.digest(files=[*SOURCES, *HEADERS, *fw_srcs], data=" ".join(CXX + list(defs)))

    def make(bdir: Path) -> None:
        lib = cosim._fw_lib(bdir, defines=defs)
        cbuild.run([*CXX, *(f"-D{d}" for d in defs), f"-I{harness.HERE}",
                    f"-I{harness.FW / 'include'}", *map(str, SOURCES), str(lib), "-lm", "-o",
                    str(bdir / "model_harness")], bdir / "build.log", "model harness")

    try:
        bdir = cache.cached_dir(BUILD / "native", f"model_harness-{key}", make,
                                done="model_harness")
    except cbuild.BuildError as exc:
        raise harness.DeviceError(str(exc)) from None
    return bdir / "model_harness"


def _regs(clk_hz: int) -> list[str]:
    """Every register of the map (RDL, at this clock): word, reset value, the mask of its plain
    writable storage, and the range a range-checked write must be in (-1 -1: none)."""
    lines = []
    for r in regmap.load(clk_hz).registers:
        wmask, lo, hi = 0, -1, -1
        for f in r.fields:
            if "w" in f.sw and f.sw != "w" and not f.singlepulse and not f.woclr:
                wmask |= f.mask
            if f.range_min is not None or f.range_max is not None:
                lo = f.range_min if f.range_min is not None else 0
                hi = f.range_max if f.range_max is not None else (1 << 32) - 1
        lines.append(f"reg = {r.word} {r.reset} {wmask} {lo} {hi}")
    return lines


def _refuse(scene: Any, key: str, msg: str) -> SceneError:
    return SceneError(f"{scene.source}: {key}: {msg}")


def supported(scene: Any) -> None:
    """Refuse what the model does not simulate faithfully (SceneError naming the file and key,
    the command's exit 2, nothing written): a waveform trace, the ADC record, quadrature-only
    position, an
    encoder whose noise-free signal clips or leaves the signal-loss window anywhere on a line
    (the model sees clipping only at the samples it evaluates, README)."""
    cfg = InterpConfig()
    if scene.run.trace:
        raise _refuse(scene, "run.trace", "a waveform needs the gateware (fidelity \"rtl\")")
    if "adc" in scene.run.record:
        raise _refuse(scene, "run.record", "\"adc\": the model computes the ADC words only "
                      "where it needs them; use fidelity \"rtl\"")
    if harness._coarse(scene):   # (run.position, or run.config's angle)
        raise _refuse(scene, "run.position" if scene.run.position == "quadrature" else
                      "run.config", "\"quadrature\" needs fidelity \"rtl\"")
    if harness._observer(scene):
        raise _refuse(scene, "run.velocity" if scene.run.velocity == "observer" else
                      "run.config", "\"observer\" needs fidelity \"rtl\" (the model reports "
                      "the window FIR's velocity)")
    if harness.scripted_pc(scene):
        raise _refuse(scene, "pc" if getattr(scene, "pc", None) is not None else "fault",
                      "the scripted PC's link is simulated with the gateware only; use "
                      "fidelity \"rtl\"")
    x = np.linspace(0.0, 1.0, 4096, endpoint=False)
    for i in scene.run.axes:
        spec = scene.encoders[int(i)].spec(seed=0)
        a, b = encsig.adc_codes(x, replace(spec, noise_lsb=0.0))
        a32, b32 = a.astype(np.int32), b.astype(np.int32)
        amp2 = a32 * a32 + b32 * b32
        margin = 6.0 * spec.noise_lsb
        peak = np.maximum(np.abs(a32).max(), np.abs(b32).max()) + margin
        if peak >= 127 or np.sqrt(amp2.min()) - margin < cfg.amp_min or \
                np.sqrt(amp2.max()) + margin > cfg.amp_max:
            raise _refuse(scene, f"encoder.{i}", "the signal (with 6 sigma of noise) reaches the "
                          "ADC's clipping or the signal-loss window: the model evaluates only "
                          "some samples; use fidelity \"rtl\"")


def run_config(scene: Any, q0: np.ndarray, clk_hz: int, mask: int, mech_us: int) -> str:
    cfg = InterpConfig()
    comm = CommutationConfig(clk_hz=clk_hz)
    if comm.angle_bits != 10 or comm.dac_bits != 14 or comm.rom.fs != 8191:
        raise harness.DeviceError("the model harness has the shipped commutation configuration")
    top = configs.get("paper").replace(clk_hz=clk_hz).top()
    lines = [harness.run_config(scene, q0).rstrip("\n"),
             f"mech_us = {mech_us}", f"axis_mask = {mask}", f"clk_hz = {clk_hz}",
             # the DAC schedule at this clock (the t_WCS strobe lengthens the write above 20 MHz):
             # channel 0's load edge after the frame start (runner.build's HG_LOAD_CLOCKS), strobe
             f"dac_load = {top.comm.load_clocks + 1} {top.comm.wr_cycles}",
             f"asin_lut = {' '.join(str(int(v)) for v in interp.asin_table(cfg))}",
             f"sine_rom = {' '.join(str(int(v)) for v in quarter_table(comm.rom))}",
             f"interp = {cfg.lut_bits} {cfg.vel_log2w} {cfg.amp_min} {cfg.amp_max} "
             f"{cfg.loss_samples} 0", *_regs(clk_hz)]
    return "\n".join(lines) + "\n"


def simulate(scene: Any, clk_hz: int | None = None, mask: int | None = None,
             progress: Any = None, out_dir: Path | None = None,
             mech_us: int = MECH_US) -> harness.Raw:
    """Run the scene at model fidelity once; the same records as runner.simulate."""
    import tempfile
    supported(scene)
    clk = harness.choose_clock(scene) if clk_hz is None else int(clk_hz)
    m = harness.axis_mask(scene) if mask is None else int(mask)
    exe = build(bool(getattr(scene.firmware, "test_limits", False)))
    q0 = harness.start_pose(scene)
    built = [REPLACES, "firmware (dsp-fw)",
             f"plant ({', '.join(str(a) for a in scene.run.axes)} free; mechanics every "
             f"{mech_us} us, amplifier exact at every DAC word)"]
    skipped = [f"axis {i} (interpolator, signals; joint held)" for i in range(3) if not m >> i & 1]
    skipped += ["gateware (Verilator)", "waveform trace"]
    skipped += [] if harness.record_mask(scene) & 1 else ["plant records"]
    with tempfile.TemporaryDirectory(prefix="scene-", dir=ensure(BUILD / "native" / "runs")) as t:
        tmp = Path(t) if out_dir is None else ensure(out_dir)
        (tmp / "plant.cfg").write_text(harness.plant_config(scene, q0))
        (tmp / "run.cfg").write_text(run_config(scene, q0, clk, m, mech_us))
        t0 = time.perf_counter()
        proc = subprocess.Popen([str(exe), str(tmp / "plant.cfg"), str(tmp / "run.cfg"),
                                 str(tmp)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True)
        errs = harness._progress_reader(proc, float(scene.run.duration_s), progress)
        stdout = proc.stdout.read() if proc.stdout else ""
        rc = proc.wait()
        wall = time.perf_counter() - t0
        if rc != 0:
            raise harness.DeviceError(f"model harness failed ({rc}): {errs.strip()}")
        summary = dict(kv.split("=", 1) for kv in stdout.split())
        if int(summary["frame_bytes"]) != harness.FRAME_DT.itemsize or \
                int(summary["tick_bytes"]) != harness.TICK_DT.itemsize:
            raise harness.DeviceError("record layout of the harness and the runner differ")
        frames = np.fromfile(tmp / "frames.bin", dtype=harness.FRAME_DT)
        ticks = np.fromfile(tmp / "ticks.bin", dtype=harness.TICK_DT)
        loads = np.fromfile(tmp / "loads.bin", dtype=harness.LOAD_DT)
    return harness.Raw(summary, frames, ticks, loads, float(summary.get("wall_s", wall)), clk, m,
                      built, skipped, None, None)
