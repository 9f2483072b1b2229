"""The hapgate SoC (rtl/soc/): the firmware image of its soft CPU and the native Verilator
harness of the whole controller in one FPGA (tb/native/soc/).

`build_firmware()` builds dsp-fw for the SoC (`make -C dsp-fw riscv`, Debian's
riscv64-unknown-elf-gcc and picolibc; make rebuilds only what changed) into build/soc/fw/ and
returns its image, sizes and symbols. `build()` Verilates rtl/soc/hapgate_soc_top.v with the
pinned VexRiscv (pythondata-cpu-vexriscv's VexRiscv_FullCfu.v, read unmodified) and the harness
(one cached build per clock, baud and source hash, under build/native/). The RAM's image is
read when the simulation starts, from the working directory (hapgate_soc_top's FW_FILE), so a
new firmware needs no new Verilator build. `run()` runs it: frames sent to the UART's rx pin,
the bytes decoded from its tx pin, the servo ticks seen on the register file's irq.
`run_fpu()` runs the SoC's float unit (rtl/soc/hg_fpu_cfu.v) alone on operand arrays through
its custom-function port (tb/native/soc/fpu_harness.cpp); `build_fpu_check()` builds the test
image that compares it with libgcc's soft float on the simulated SoC (tb/native/soc/fpu_check.c).
"""

from __future__ import annotations

import bisect
import re
import subprocess
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..base import cbuild
from ..base.paths import BUILD, ROOT, RTL, TB, ensure, locked
from ..golden import configs, pclink
from ..golden.top import SOURCES, TopConfig
from . import native

FW = ROOT / "dsp-fw"
FW_BUILD = BUILD / "soc" / "fw"           # make's BUILD; the image in FW_BUILD/riscv/
HERE = TB / "native" / "soc"
TESTB = TB / "native" / "device" / "testb.h"   # the shared testbench wrapper
SOC_SOURCES = ("soc/hg_soc_ram.v", "soc/hg_uart.v", "soc/hg_mtimer.v", "soc/hg_emif_master.v",
               "soc/hg_fpu_cfu.v", "soc/hg_soc.v", "soc/hapgate_soc_top.v")
# RV32IM, mcycle, Wishbone instruction and data buses, and the custom-function port (CfuPlugin)
# that the float unit hg_fpu_cfu sits on: VexRiscv_Full.v with --cfu true
VEXRISCV_VARIANT = "VexRiscv_FullCfu.v"
BAUD = 1_000_000                          # hapgate_soc_top's default
FW_HEX = "hapgate-fw.hex"                 # hapgate_soc_top's default FW_FILE (relative)
# the firmware's own figures in its RAM (dsp-fw/board/riscv/soc.h), read at the end of a run
SYMBOLS = ("soc_isr_cycles_last", "soc_isr_cycles_max", "soc_isr_count", "soc_trap_cause",
           "soc_trap_pc")


def vexriscv_source() -> Path:
    """The packaged VexRiscv variant (third-party source: its waivers are rtl/lint/vexriscv.vlt)."""
    import pythondata_cpu_vexriscv as vex  # the pinned PyPI package (requirements.lock)

    return Path(vex.data_location) / VEXRISCV_VARIANT


def sources() -> list[Path]:
    """hapgate_soc_top's sources: the whole FPGA, the SoC, the CPU."""
    return [RTL / s for s in SOURCES] + [RTL / s for s in SOC_SOURCES] + [vexriscv_source()]


@dataclass(frozen=True)
class Firmware:
    elf: Path
    hex: Path
    text: int            # bytes, as riscv64-unknown-elf-size prints them
    data: int
    bss: int             # .bss with the reserved stack
    symbols: dict[str, int]
    log: str             # make's output


def build_firmware(build: Path = FW_BUILD) -> Firmware:
    """`make -C dsp-fw riscv` into `build` (serialised between parallel callers)."""
    ensure(build)
    with locked(build / "make"):
        r = subprocess.run(["make", "-s", "-C", str(FW), f"BUILD={build}", "riscv"],
                           capture_output=True, text=True, timeout=900, check=False)
    if r.returncode != 0:
        raise cbuild.BuildError("make -C dsp-fw riscv failed:\n" + (r.stdout + r.stderr)[-4000:],
                                build, r.stdout + r.stderr)
    m = re.search(r"^\s*(\d+)\s+(\d+)\s+(\d+)\s+\d+\s+[0-9a-f]+\s+\S*hapgate-fw\.elf", r.stdout,
                  re.M)
    if not m:
        raise cbuild.BuildError(f"no size line in make's output:\n{r.stdout}", build, r.stdout)
    elf = build / "riscv" / "hapgate-fw.elf"
    nm = subprocess.run(["riscv64-unknown-elf-nm", str(elf)], capture_output=True, text=True,
                        check=True).stdout
    syms = {p[2]: int(p[0], 16) for p in (ln.split() for ln in nm.splitlines()) if len(p) == 3}
    return Firmware(elf, build / "riscv" / FW_HEX, int(m[1]), int(m[2]), int(m[3]), syms,
                    r.stdout)


def soc_config(clk_hz: int = 48_000_000) -> TopConfig:
    """hapgate_soc_top's FPGA: hapgate_top's defaults (the paper's design) at clk_hz, as the
    board tops build it (the ECP5 board's named configuration at 48 MHz)."""
    cfg = configs.get("ecp5").top()
    if cfg.clk_hz != clk_hz:
        cfg = replace(cfg, clk_hz=clk_hz)
    return cfg


def build(clk_hz: int = 48_000_000, baud: int = BAUD) -> Path:
    """The Verilated SoC with its harness (cached); returns the executable."""
    cfg = soc_config(clk_hz)
    p = cfg.rtl_params()
    params = {"CLK_HZ": clk_hz, "ASIN_FILE": p["ASIN_FILE"], "SINE_FILE": p["SINE_FILE"],
              "BAUD": baud}
    return native.verilate_harness(
        "soc_harness", "hapgate_soc_top", [HERE / "public.vlt", *sources()], params,
        [HERE / "soc_harness.cpp"],
        cflags=f"-std=c++17 -DCLK_HZ={clk_hz} -DBAUD={baud} -I{TESTB.parent}",
        inputs=[TESTB])


@dataclass
class SocRun:
    summary: dict[str, int]
    tx: list[tuple[int, int, bool]]           # (edge of the start bit, byte, stop bit high)
    ticks: list[tuple[int, int, int, int]]    # (irq rise edge, fall edge or 0, accesses, SEQ)
    ram: dict[str, int]                       # the firmware's figures (SYMBOLS) at the end
    wall_s: float
    sent: list[tuple[int, bytes]] = field(default_factory=list)

    @property
    def tx_bytes(self) -> bytes:
        return bytes(b for _, b, ok in self.tx if ok)


def run(fw: Firmware, clocks: int, sends: list[tuple[int, bytes]], out: Path,
        clk_hz: int = 48_000_000, baud: int = BAUD, trace: bool = False,
        profile: bool = False, symbols: tuple[str, ...] = SYMBOLS) -> SocRun:
    """Simulate `clocks` rising edges from reset with `fw`'s image in the RAM, sending each
    (edge, bytes) on the rx pin; outputs in `out` (with `profile`, out/profile.txt:
    `profile_by_function` reads it). `symbols`: the RAM words read at the end (SocRun.ram)."""
    exe = build(clk_hz, baud)
    ensure(out)
    peek = {s: fw.symbols[s] for s in symbols}
    cmd = [str(exe), f"clocks={clocks}", f"out={out}",
           "peek=" + ",".join(f"0x{a:x}" for a in peek.values())]
    cmd += [f"send={e}:{b.hex()}" for e, b in sends]
    if trace:
        cmd.append(f"trace={out / 'soc.vcd'}")
    if profile:
        cmd.append("profile=1")
    t0 = time.perf_counter()
    r = subprocess.run(cmd, cwd=fw.hex.parent, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        raise RuntimeError(f"soc_harness exited {r.returncode}: {r.stderr}")
    summary: dict[str, int] = {}
    words: dict[int, int] = {}
    for ln in r.stdout.splitlines():
        k, _, v = ln.partition("=")
        if k == "peek":
            a, _, w = v.partition(":")
            words[int(a, 16)] = int(w)
        elif v.lstrip("-").isdigit():
            summary[k] = int(v)
    tx = [(int(e), int(b), ok == "1") for e, b, ok in
          (ln.split() for ln in (out / "tx.txt").read_text().splitlines())]
    ticks = [(int(a), int(b), int(c), int(d)) for a, b, c, d in
             (ln.split() for ln in (out / "ticks.txt").read_text().splitlines())]
    return SocRun(summary, tx, ticks, {s: words[a] for s, a in peek.items()}, wall, sends)


# The budget's scene (issue 36): the servo enabled (every axis calibrated over the link: homed
# and aligned, the FPGA's pole pairs) in a wall of the scenes' 20 N/cm, its surface WALL_DEPTH
# beyond the pose the still encoders give, so that the hand is in contact on every tick
WALL_K = 2000.0            # N/m
WALL_DEPTH = 0.002         # m: 4 N into the wall
WALL_N = (0.0, 0.0, 1.0)   # the wall's normal
CAL_WORDS = (3, 1, 0, 2, 0, 0)   # HOMED | ALIGNED, encoder +1, phases in order, 2 pole pairs


def states(r: SocRun) -> dict[int, pclink.State]:
    """The GET_STATE replies of a run, by their seq."""
    return {f.seq: pclink.parse_state(f.data) for f in pclink.split(r.tx_bytes)
            if f.msg_type == pclink.GET_STATE | pclink.REPLY}


def wall_run(fw: Firmware, out: Path, ticks: int = 40, clk_hz: int = 48_000_000,
             rate_hz: int = 1000, baud: int = BAUD) -> tuple[SocRun, dict[int, pclink.State]]:
    """The budget's wall: at 2 ticks the calibration of every axis, ENABLE and a GET_STATE
    (seq 14) that finds the pose (a probe run), then the same set-up with the wall WALL_DEPTH
    beyond that pose (SET_SCENE, seq 15, 4 ticks later), `ticks` ticks in contact and a last
    GET_STATE (seq 16). Returns the wall run and its states by seq; the probe is out/probe."""
    tick = clk_hz // rate_hz
    setup = 2 * tick
    sends = [(setup, f) for f in (
        *(pclink.encode(pclink.SET_CALIB, 10 + a, pclink.set_calib(a, CAL_WORDS),
                        version=pclink.VERSION2) for a in range(3)),
        pclink.encode(pclink.ENABLE, 13, b"\x01"),
        pclink.encode(pclink.GET_STATE, 14))]
    probe = run(fw, setup + 6 * tick, sends, out / "probe", clk_hz=clk_hz, baud=baud)
    found = states(probe)
    if 14 not in found:
        raise RuntimeError("no reply to the probe's GET_STATE: the link loop got no CPU time?")
    p = found[14].p
    p0 = tuple(p[i] + WALL_DEPTH * WALL_N[i] for i in range(3))
    scene = pclink.set_scene(pclink.SCENE_WALL, p0, WALL_N, WALL_K, 0.0)
    start = setup + 4 * tick
    sends += [(start, pclink.encode(pclink.SET_SCENE, 15, scene)),
              (start + (ticks + 1) * tick, pclink.encode(pclink.GET_STATE, 16))]
    r = run(fw, start + (ticks + 3) * tick, sends, out / "wall", clk_hz=clk_hz, baud=baud)
    return r, states(r)


def profile_by_function(fw: Firmware, out: Path) -> list[tuple[str, int, int]]:
    """(function, clocks, instructions retired) while the tick interrupt was pending, from a
    run with `profile`, the largest first (the ELF's function symbols as ranges)."""
    nm = subprocess.run(["riscv64-unknown-elf-nm", "-n", "-S", "--defined-only", str(fw.elf)],
                        capture_output=True, text=True, check=True).stdout
    funcs = sorted((int(p[0], 16), int(p[1], 16), p[3]) for p in
                   (ln.split() for ln in nm.splitlines()) if len(p) == 4 and p[2] in "tTW")
    starts = [f[0] for f in funcs]
    acc: dict[str, list[int]] = {}
    for ln in (out / "profile.txt").read_text().splitlines():
        pc_s, c_s, r_s = ln.split()
        pc = int(pc_s, 16)
        i = bisect.bisect_right(starts, pc) - 1
        name = funcs[i][2] if i >= 0 and pc < funcs[i][0] + max(funcs[i][1], 1) else "?"
        a = acc.setdefault(name, [0, 0])
        a[0] += int(c_s)
        a[1] += int(r_s)
    return sorted(((k, v[0], v[1]) for k, v in acc.items()), key=lambda t: -t[1])


FPU_HARNESS = HERE / "fpu_harness.cpp"


def build_fpu() -> Path:
    """The float unit alone with its harness (cached); returns the executable."""
    return native.verilate_harness(
        "fpu_harness", "hg_fpu_cfu", [RTL / "soc" / "hg_fpu_cfu.v"], {}, [FPU_HARNESS],
        cflags=f"-std=c++17 -I{TESTB.parent}", inputs=[TESTB])


@dataclass
class FpuRun:
    result: np.ndarray     # uint32: the response word of each command
    latency: np.ndarray    # clocks from the command's acceptance to its response's valid
    summary: dict[str, int]


def run_fpu(fid: np.ndarray, a: np.ndarray, b: np.ndarray, out: Path, seed: int = 1,
            stall: bool = True) -> FpuRun:
    """One command per element (function id, rs1, rs2 as uint32), in order, paced at random
    (`seed`; `stall`: gaps between commands and responses held back) as the CPU may."""
    exe = build_fpu()
    ensure(out)
    rec = np.stack([fid, a, b], axis=1).astype("<u4")
    (out / "fpu_in.bin").write_bytes(rec.tobytes())
    r = subprocess.run([str(exe), f"in={out / 'fpu_in.bin'}", f"out={out / 'fpu_out.bin'}",
                        f"seed={seed}", f"stall={int(stall)}"], capture_output=True, text=True,
                       check=False)
    if r.returncode != 0:
        raise RuntimeError(f"fpu_harness exited {r.returncode}: {r.stderr}")
    res = np.fromfile(out / "fpu_out.bin", dtype="<u4").reshape(-1, 2)
    summary = {k: int(v) for k, _, v in (ln.partition("=") for ln in r.stdout.splitlines())}
    return FpuRun(res[:, 0].astype(np.uint32), res[:, 1].astype(np.uint32), summary)


FPU_CHECK = HERE / "fpu_check.c"
SOFT_FLOAT = ("addsf3", "subsf3", "mulsf3", "divsf3")   # libgcc's members the float unit replaces
# the test image's result words (fpu_check.c), as "name" or "name.i" for array element i
FPU_CHECK_WORDS = {"check_done": 1, "check_count": 4, "check_bad": 4, "check_first": 5,
                   "check_nan": 4, "check_subnormal": 4, "soc_trap_cause": 1, "soc_trap_pc": 1}


def _make_var(name: str) -> str:
    """A variable of dsp-fw/Makefile (the riscv target's flags), as make expands it."""
    r = subprocess.run(["make", "-s", "-C", str(FW), "--eval", "hg-print-%: ; @echo $($*)",
                        f"hg-print-{name}"], capture_output=True, text=True, check=True)
    return r.stdout.strip()


def build_fpu_check(build: Path = BUILD / "soc" / "fpu_check", random: int = 1000) -> Firmware:
    """The image of tb/native/soc/fpu_check.c with the SoC's start-up, linker script and float
    unit functions (dsp-fw/board/riscv/), compiled with the riscv target's flags, and libgcc's
    own __addsf3, __subsf3, __mulsf3, __divsf3 (their members of the libgcc.a that target links,
    the entry points renamed __soft_*). `random`: pseudo-random pairs per kind and operation.
    Its .hex is named as hapgate_soc_top's FW_FILE, in `build`."""
    ensure(build)
    prefix, arch = _make_var("RISCV"), _make_var("RISCV_ARCH").split()
    cflags = _make_var("RISCV_CFLAGS").split()
    board = FW / "board" / "riscv"
    inc = [f"-I{FW / 'include'}", f"-I{board}"]
    cflags = [f for f in cflags if not f.startswith("-I")] + inc + [f"-DFPU_CHECK_RANDOM={random}u"]
    gcc = prefix + "gcc"

    def run_(cmd: list[str]) -> str:
        r = subprocess.run(cmd, cwd=build, capture_output=True, text=True, check=False)
        if r.returncode != 0:
            raise cbuild.BuildError(f"{' '.join(cmd)} failed:\n{r.stdout}{r.stderr}", build,
                                    r.stdout + r.stderr)
        return r.stdout

    with locked(build / "make"):
        libgcc = run_([gcc, *arch, "--specs=picolibc.specs", "-print-libgcc-file-name"]).strip()
        objs = []
        for m in SOFT_FLOAT:
            run_([prefix + "ar", "x", libgcc, f"{m}.o"])
            run_([prefix + "objcopy", f"--redefine-sym=__{m}=__soft_{m}", f"{m}.o", f"soft_{m}.o"])
            objs.append(f"soft_{m}.o")
        for src in (FPU_CHECK, board / "fpu.c"):
            run_([gcc, *cflags, "-c", str(src), "-o", f"{src.stem}.o"])
            objs.append(f"{src.stem}.o")
        run_([gcc, *arch, *inc, "-c", str(board / "start.S"), "-o", "start.o"])
        elf = build / "fpu-check.elf"
        run_([gcc, *arch, "--specs=picolibc.specs", "-nostartfiles", "-T",
              str(board / "hapgate-soc.ld"), "-Wl,--gc-sections",
              f"-Wl,-Map={build / 'fpu-check.map'}", *objs, "start.o", "-o", elf.name])
        run_([prefix + "objcopy", "-O", "binary", elf.name, "fpu-check.bin"])
        image = (build / "fpu-check.bin").read_bytes()
        image += bytes(-len(image) % 4)
        words = np.frombuffer(image, dtype="<u4")
        (build / FW_HEX).write_text("".join(f"{w:08x}\n" for w in words))
        size = run_([prefix + "size", elf.name]).splitlines()[-1].split()
        nm = run_([prefix + "nm", elf.name])
    syms = {p[2]: int(p[0], 16) for p in (ln.split() for ln in nm.splitlines()) if len(p) == 3}
    for name, n in FPU_CHECK_WORDS.items():
        for i in range(n if n > 1 else 0):
            syms[f"{name}.{i}"] = syms[name] + 4 * i
    return Firmware(elf, build / FW_HEX, int(size[0]), int(size[1]), int(size[2]), syms, "")


def fpu_check_symbols() -> tuple[str, ...]:
    """The RAM words `run` reads back from the fpu_check image (FPU_CHECK_WORDS)."""
    return tuple(n if k == 1 else f"{n}.{i}" for n, k in FPU_CHECK_WORDS.items()
                 for i in range(k))
