"""The virtual device at soc fidelity (scene `run.fidelity = "soc"`): the Verilated SoC
(rtl/soc/hapgate_soc_top.v: VexRiscv running the cross-built firmware image, and the same
hapgate_top) in the closed loop of tb/native/device/device_harness.cpp, built with HG_SOC
(tb/native/device/README.md "SoC fidelity").

The harness runs none of the firmware: the firmware's own power-up, servo, bring-up and link
run on the CPU. What a board would hold in flash, the scene's board (its stored calibration,
servo rate, PC-force timeout, the power-up pose with bring-up's bounds, the environment it
renders, and without a PC the time it enables its forces) reaches the firmware as a board's
would: written into the image's configuration sector `hg_board_setup`
(dsp-fw/board/board_main.h `hg_board_setup_t`) of the copy of the image the run loads, as a
flashing tool writes a configuration sector. `build()` is cached per source hash (one
Verilator build per baud); the image is read from the run's directory at start, so a new
firmware or a new setup needs no new build.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..runners import native
from ..runners import soc as soc_runner
from .harness import ENV_KINDS, FW, HERE, T_HOLD_S, DeviceError
from .scene import SOC_CLK_HZ

CLK_HZ = SOC_CLK_HZ
BAUD = soc_runner.BAUD
SETUP_MAGIC = 0x46434748       # "HGCF", HG_BOARD_SETUP_MAGIC
SETUP_WORDS = 39               # sizeof(hg_board_setup_t) / 4 (checked against the ELF's symbol)
# bring-up's bounds on the virtual device's linkage (harness_common.cpp fw_bringup_config, the
# rtl fidelity's): align_cycles, align_rate, travel_max
BRINGUP_BOUNDS = (0.5, 0.25, 3.2)
# the firmware's RAM words the harness reads: the tick observation, the link's counters, the
# handler's longest cycle count (dsp-fw/board/riscv/soc.h, board_main.h)
OBS_SYMBOLS = ("soc_tick_obs", "hg_board_link_stats", "soc_isr_cycles_max")
HARNESS = [HERE / "device_harness.cpp", HERE / "harness_common.cpp", HERE / "plant.cpp",
           HERE / "uart_link.cpp", HERE / "view_link.cpp"]


def build(baud: int = soc_runner.BAUD) -> Path:
    """The SoC with the device harness (HG_SOC), cached; returns the executable."""
    cfg = soc_runner.soc_config(CLK_HZ)
    p = cfg.rtl_params()
    params = {"CLK_HZ": CLK_HZ, "ASIN_FILE": p["ASIN_FILE"], "SINE_FILE": p["SINE_FILE"],
              "BAUD": int(baud)}
    c = cfg.comm
    headers = [HERE / n for n in ("plant.h", "uart_link.h", "view_link.h", "harness_common.h",
                                  "stage_clocks.h", "bus_hal.h", "dac_word.h", "testb.h")]
    return native.verilate_harness(
        "device_harness_soc", "hapgate_soc_top",
        [soc_runner.HERE / "public.vlt", *soc_runner.sources()], params, HARNESS,
        cflags=(f"-std=c++17 -DHG_SOC=1 -DCLK_HZ={CLK_HZ} -DAXIS_MASK=7 -DHG_TRACE=0 "
                f"-DHG_SIM_GATE=0 -DHG_LOAD_CLOCKS={c.load_clocks + 1} "
                f"-DHG_DAC_BITS={c.dac_bits} -DHG_DAC_OFFSET_BINARY={int(c.offset_binary)} "
                f"-DHG_DAC_SKEW={c.skew_clocks} -DHG_DAC_FRAME={c.frame_clocks} "
                f"-I{HERE} -I{FW / 'include'}"),
        ldflags="-lm",
        inputs=[*headers, HERE.parent / "vl_internals.h",
                *sorted((FW / "include").glob("*.h"))])


def _f32(x: float) -> int:
    return int(np.asarray(x, dtype=np.float32).view(np.uint32))


def _i32(x: int) -> int:
    return int(x) & 0xFFFFFFFF


def setup_words(scene: Any, q0: np.ndarray, linked: bool) -> list[int]:
    """The board's stored setup for this scene (hg_board_setup_t, 32-bit words): what the rtl
    fidelity's harness gives its native firmware (harness_common.cpp fw_config, fw_store_calib,
    fw_bringup_config, fw_power_up's environment, and the scene's enable at its start when no
    PC is linked)."""
    words = [SETUP_MAGIC, SETUP_WORDS]
    comm_err = [int(v) for v in scene.firmware.comm_offset_error_counts]
    for i, a in enumerate(scene.calib()):
        w = [int(v) for v in a.words()]    # flags dir swapped pole_pairs index_to_zero offset
        if w[0] & 2:                        # HG_CAL_ALIGNED: the scene's deliberate error
            w[5] = (w[5] + comm_err[i]) & 1023
        words += [_i32(v) for v in w]
    words.append(int(scene.run.servo_hz))
    timeout_ms = getattr(scene.firmware, "pc_force_timeout_ms", None)
    words.append(_i32(-1 if timeout_ms is None
                      else int(round(timeout_ms * scene.run.servo_hz / 1000))))
    words += [_f32(v) for v in q0] + [_f32(v) for v in BRINGUP_BOUNDS]
    env = scene.env
    words.append(ENV_KINDS[env.kind])
    words += [_f32(v) for v in (getattr(env, "point", None) or (0.0, 0.0, 0.0))]
    words += [_f32(v) for v in (getattr(env, "normal", None) or (0.0, 0.0, 0.0))]
    words += [_f32(float(getattr(env, k, 0.0) or 0.0)) for k in ("k", "b", "ki")]
    # without a PC the scene starts with its forces enabled: the first tick at or after scene
    # time 0 renders them (the rtl harness enables after the tick before scene time 0)
    words.append(0 if linked else int(round(T_HOLD_S * 1e6)))
    if len(words) != SETUP_WORDS:
        raise DeviceError(f"the board setup has {len(words)} words, not {SETUP_WORDS}")
    return words


def write_image(fw: soc_runner.Firmware, words: list[int], out: Path) -> Path:
    """A copy of the firmware image with the setup in its configuration sector, as the SoC's
    RAM loads it (hapgate_soc_top's FW_FILE in `out`)."""
    addr = fw.symbols.get("hg_board_setup")
    if addr is None:
        raise DeviceError(f"{fw.elf}: no hg_board_setup (the configuration sector)")
    lines = fw.hex.read_text().split()
    k = addr // 4
    if addr % 4 or k + len(words) > len(lines):
        raise DeviceError(f"{fw.elf}: hg_board_setup at {addr:#x} is not in the image")
    if any(int(x, 16) for x in lines[k:k + len(words)]):
        raise DeviceError(f"{fw.elf}: the configuration sector of the image is not empty")
    for i, w in enumerate(words):
        lines[k + i] = f"{w & 0xFFFFFFFF:08x}"
    path = out / soc_runner.FW_HEX
    path.write_text("\n".join(lines) + "\n")
    return path


def prepare(scene: Any, q0: np.ndarray, out: Path, linked: bool) -> str:
    """The firmware (built if needed) with this scene's setup into `out`; returns the run
    configuration's soc line (the firmware's RAM addresses the harness reads)."""
    fw = soc_runner.build_firmware()
    write_image(fw, setup_words(scene, q0, linked), out)
    missing = [s for s in OBS_SYMBOLS if s not in fw.symbols]
    if missing:
        raise DeviceError(f"{fw.elf}: no {', '.join(missing)}")
    return "soc_obs = " + " ".join(str(fw.symbols[s]) for s in OBS_SYMBOLS) + "\n"


def parts(scene: Any) -> tuple[list[str], list[str]]:
    """What a soc run builds and what it skips (the summary table's first lines)."""
    built = ["soft CPU (VexRiscv_FullCfu) + float unit, RAM, UART, timer, bridge",
             "firmware image (dsp-fw, cross-built RV32IM)",
             "interpolator axes 0, 1, 2", "commutator + DAC scheduler", "bus + register file",
             f"plant ({', '.join(str(a) for a in scene.run.axes)} free)"]
    return built, ["waveform trace"]


def compare(rtl: Any, at_soc: Any, settle_s: float = 1e-3) -> tuple[float, int, int]:
    """The cross-check of one scene run at rtl and at soc fidelity (runner.simulate's Raw):
    the largest difference of the firmware's torque commands over the last enabled ticks both
    have (N m), the largest DAC code difference over the frames both have from `settle_s` after
    the later first enabled tick (LSB), and the number of frames compared. The ticks pair up
    by their order: a scene whose pose is held still (a rigid grip) sees the same inputs at
    both fidelities' tick phases."""
    a, b = rtl.ticks[rtl.ticks["drive"] == 1], at_soc.ticks[at_soc.ticks["drive"] == 1]
    n = min(a.size, b.size)
    if n == 0:
        return float("nan"), -1, 0
    dtau = float(np.abs(a["tau_fw"][-n:] - b["tau_fw"][-n:]).max())
    t_on = max(float(a["t"][0]), float(b["t"][0])) + settle_s
    da = rtl.frames["dac"][rtl.frames["t"] > t_on].astype(int)
    db = at_soc.frames["dac"][at_soc.frames["t"] > t_on].astype(int)
    m = min(len(da), len(db))
    ddac = int(np.abs(da[-m:] - db[-m:]).max()) if m else -1
    return dtau, ddac, m
