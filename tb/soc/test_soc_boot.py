"""The hapgate SoC boots the firmware and talks to the PC (issue 36, first step).

The firmware (dsp-fw/src unchanged, with dsp-fw/board/riscv/) is cross-built for the SoC's
RV32IM CPU (`make -C dsp-fw riscv`); the Verilated hapgate_soc_top (the VexRiscv CPU, its RAM
loaded with that image, the UART, the bridge, and the whole of hapgate_top) runs it from reset.
Frames built by the project's own PC-link encoder (hapgate.golden.pclink) go to the UART's rx
pin bit by bit at 1 Mbaud; the tx pin is decoded the same way and the replies checked field by
field. The servo tick is checked in simulation time: the FPGA's ticks, the interrupts they
raise, the handler runs and their acknowledgements. The servo step's cost in CPU cycles is
printed against the 1 kHz budget, and that it fits is asserted over a wall scene with the hand in
contact (the servo enabled, a calibration sent over the link): every tick serviced, each within
half a tick (issue 36's goal). Its float arithmetic runs on the SoC's float unit (rtl/soc/
hg_fpu_cfu.v behind libgcc's __addsf3 ... __divsf3, dsp-fw/board/riscv/fpu.c): soft float alone
took ~72 000 cycles of the 48 000 (rtl/soc/README.md, "The budget").
"""

from __future__ import annotations

import re
import struct
import subprocess
from pathlib import Path

import pytest
from hapgate.golden import pclink
from hapgate.runners import soc

CLK_HZ = 48_000_000        # the SoC's clock (the ECP5 board's 48 MHz)
BAUD = 1_000_000           # issue 36: the PC link at 1 Mbaud
RATE_HZ = 1000             # the firmware's default servo rate (dsp-fw/README.md, servo rate_hz)
TICK = CLK_HZ // RATE_HZ   # FPGA clocks per servo tick (rtl/regs: TICK_DIV = CLK_HZ / rate)
BIT = CLK_HZ // BAUD       # clocks per UART bit
RAM_BYTES = 128 * 1024     # rtl/soc/README.md: the SoC's RAM
FW_VERSION = 0x0100        # dsp-fw/README.md: PING's firmware version
FPGA_ID = 0x4847_0104      # rtl/bus/README.md: ID, "HG" map 1.4
IRQ_WORD = 0x05            # rtl/bus/README.md: IRQ, W1C
# libgcc's entry points the float unit takes over, by function id (funct3; rtl/soc/README.md)
FLOAT_UNIT_OPS = ("addsf3", "subsf3", "mulsf3", "divsf3")
RUN_CLOCKS = 14 * TICK     # 14 ms from reset (the last reply ends near 5 ms)

# what the PC sends, and when (rising edge after reset): a PING while the firmware still boots
# (its bytes wait in the receive FIFO), then three version-2 requests whose first bytes arrive
# while the first tick's handler runs (the FIFO holds them: the handler is not interrupted), the
# middle one 45 bytes long
SCENE_NONE = struct.pack("<B3f3f3f", pclink.SCENE_NONE, 0, 0, 0, 0, 0, 1, 0, 0, 0)
REQUESTS = [
    (TICK // 5, pclink.encode(pclink.PING, 1)),
    (TICK + 2_000, pclink.encode(pclink.INFO, 2, version=pclink.VERSION2)),
    (TICK + 2_000, pclink.encode(pclink.SET_SCENE, 3, SCENE_NONE, version=pclink.VERSION2)),
    (TICK + 2_000, pclink.encode(pclink.GET_STATS, 4, version=pclink.VERSION2)),
]

# The budget's scene: hapgate.runners.soc.wall_run (the wall, its depth and the calibration)
WALL_K, WALL_DEPTH = soc.WALL_K, soc.WALL_DEPTH
BUDGET_TICKS = 40          # ticks checked with the hand in the wall

@pytest.fixture(scope="module")
def fw() -> soc.Firmware:
    return soc.build_firmware()


@pytest.fixture(scope="module")
def boot(fw: soc.Firmware, tmp_path_factory: pytest.TempPathFactory) -> soc.SocRun:
    return soc.run(fw, RUN_CLOCKS, REQUESTS, tmp_path_factory.mktemp("soc_boot"),
                   clk_hz=CLK_HZ, baud=BAUD)


_states = soc.states


@pytest.fixture(scope="module")
def wall(fw: soc.Firmware, tmp_path_factory: pytest.TempPathFactory
         ) -> tuple[soc.SocRun, dict[int, pclink.State], int]:
    """The wall run (soc.wall_run): its states by seq and the edge from which the wall holds
    (its SET_SCENE's reply; the run's end if there is none)."""
    run, states = soc.wall_run(fw, tmp_path_factory.mktemp("soc_wall"), BUDGET_TICKS,
                               clk_hz=CLK_HZ, rate_hz=RATE_HZ, baud=BAUD)
    held = [first for first, _, f in _frames(run)
            if f.seq == 15 and f.msg_type == pclink.SET_SCENE | pclink.REPLY]
    return run, states, held[0] if held else run.summary["clocks"]


def _sent_ends() -> list[int]:
    """The edge at which each request's last stop bit ends (sends queue back to back)."""
    ends, free = [], 0
    for edge, data in REQUESTS:
        start = max(edge, free)
        free = start + len(data) * 10 * BIT
        ends.append(free)
    return ends


def _frames(run: soc.SocRun) -> list[tuple[int, int, pclink.Frame]]:
    """(edge of the first byte's start bit, of the delimiter's, frame) for every reply."""
    out, start = [], None
    chunk = bytearray()
    for edge, byte, _ in run.tx:
        if start is None:
            start = edge
        if byte == 0:
            if chunk:
                out.append((start, edge, pclink.decode(bytes(chunk))))
            chunk, start = bytearray(), None
        else:
            chunk.append(byte)
    return out


def test_firmware_image(fw: soc.Firmware) -> None:
    """The image links against picolibc (its memory functions and libm) and libgcc alone,
    nothing undefined, RV32IM with the soft-float ABI, fits the RAM with its stack, and its
    .hex is the image word by word. Float add, subtract, multiply and divide are the board's
    (fpu.c: one CUSTOM_0 instruction each, for the float unit), not libgcc's."""
    nm = subprocess.run(["riscv64-unknown-elf-nm", "-u", str(fw.elf)], capture_output=True,
                        text=True, check=True).stdout
    assert nm.strip() == "", nm
    mapfile = (fw.elf.with_suffix(".map")).read_text()
    libs = set(re.findall(r"/(lib\w+)\.a\(", mapfile))
    assert libs == {"libc", "libgcc"}, libs     # picolibc keeps its libm in libc.a
    assert "libc.a(libm_math_sf_sin.c.o)" in mapfile   # sinf: picolibc's float kernel
    assert "libgcc.a(floatsisf.o)" in mapfile           # conversions, comparisons: libgcc's
    for m in FLOAT_UNIT_OPS:
        assert f"libgcc.a({m}.o)" not in mapfile, m
        assert re.search(rf"\.text\.__{m}\s+0x[0-9a-f]+\s+0x8\s+\S*board/riscv/fpu\.o",
                         mapfile), m
    objs = set(re.findall(r"riscv/src/(\w+)\.o", mapfile))
    assert objs == {p.stem for p in (soc.FW / "src").glob("*.c")}
    hdr = subprocess.run(["riscv64-unknown-elf-readelf", "-h", "-A", str(fw.elf)],
                         capture_output=True, text=True, check=True).stdout
    assert "ELF32" in hdr and "RISC-V" in hdr, hdr
    assert re.search(r"Flags:\s+0x0\b", hdr), hdr               # no float ABI: soft float
    assert re.search(r'Tag_RISCV_arch: "rv32i2p1_m2p0(_zmmul1p0)?"', hdr), hdr   # no F, D, A, C
    assert fw.text + fw.data + fw.bss <= RAM_BYTES
    words = fw.hex.read_text().split()
    image = fw.elf.with_suffix(".bin").read_bytes()
    assert len(words) == len(image) // 4 == (fw.text + fw.data) // 4
    assert all(int(w, 16) == int.from_bytes(image[4 * i:4 * i + 4], "little")
               for i, w in enumerate(words))
    for funct3, m in enumerate(FLOAT_UNIT_OPS):
        a = fw.symbols[f"__{m}"]
        insn, ret = (int.from_bytes(image[a + k:a + k + 4], "little") for k in (0, 4))
        # CUSTOM_0, rd = a0, funct3, rs1 = a0, rs2 = a1, funct7 0; then ret
        assert insn == (0x0B | 10 << 7 | funct3 << 12 | 10 << 15 | 11 << 20), hex(insn)
        assert ret == 0x0000_8067, hex(ret)
    print(f"\nSoC firmware (RV32IM, -O2, soft-float ABI, float unit): text {fw.text} B, "
          f"data {fw.data} B, bss {fw.bss} B (8 KiB of it the stack), RAM {RAM_BYTES} B")


def test_ping_info_over_the_uart(boot: soc.SocRun) -> None:
    """Every request is answered once, in order, with the right contents, after it arrived;
    the tx pin's bytes are 8N1 at the configured baud, back to back within a reply."""
    s = boot.summary
    assert s["tx_framing_errors"] == 0 and s["tx_bytes"] > 0
    frames = _frames(boot)
    assert [(f.msg_type, f.seq, f.version) for _, _, f in frames] == [
        (pclink.PING | pclink.REPLY, 1, 1), (pclink.INFO | pclink.REPLY, 2, 2),
        (pclink.SET_SCENE | pclink.REPLY, 3, 2), (pclink.GET_STATS | pclink.REPLY, 4, 2)]
    ping, info, scene, stats = (f for _, _, f in frames)
    assert pclink.parse_ping(ping.data) == (FW_VERSION, FPGA_ID, RATE_HZ)
    i = pclink.parse_info(info.data)
    assert (i.fw_version, i.protocol, i.fpga_id, i.servo_hz, i.baud) == (
        FW_VERSION, pclink.VERSION2, FPGA_ID, RATE_HZ, BAUD)
    assert scene.data == b""
    st = pclink.parse_stats(stats.data[:28])
    assert st["good"] == 4 and st["rejected"] == 0
    assert all(v == 0 for k, v in st.items() if k.startswith("bad_"))
    for (first, _, f), end in zip(frames, _sent_ends()):
        assert first > end, f"reply {f.seq} started at edge {first}, before its request ended"
    starts = [e for e, _, _ in boot.tx]
    assert all(b - a >= 10 * BIT for a, b in zip(starts, starts[1:]))
    lat = [(first - end) / CLK_HZ * 1e6 for (first, _, _), end in zip(frames, _sent_ends())]
    print("\nreply latency from the request's last stop bit: "
          + ", ".join(f"{f.seq}: {t:.0f} us" for (_, _, f), t in zip(frames, lat)))


def test_tick_interrupt(boot: soc.SocRun) -> None:
    """The FPGA's tick comes every TICK clocks; each interrupt it raises runs the handler once
    (the firmware's count), which acknowledges it with one IRQ write, and nothing traps. The
    handler's cost is printed against the 1 kHz budget."""
    s, ram = boot.summary, boot.ram
    assert s["fpga_ticks"] >= RUN_CLOCKS // TICK - 1
    assert s["fpga_period_min"] == s["fpga_period_max"] == TICK
    assert ram["soc_trap_cause"] == 0, f"trap: mcause 0x{ram['soc_trap_cause']:x} " \
                                       f"at 0x{ram['soc_trap_pc']:x}"
    handled = [t for t in boot.ticks if t[1]]
    assert len(handled) >= 2
    assert s["ticks"] - s["acked"] in (0, 1)            # the last may still be running
    assert s["acked"] == s["irq_writes"] == ram["soc_isr_count"]
    # an interrupt rises only on an FPGA tick: a whole number of tick periods apart
    rises = [t[0] for t in boot.ticks]
    assert all((b - a) % TICK == 0 for a, b in zip(rises, rises[1:]))
    cycles = ram["soc_isr_cycles_max"]
    hi = s["irq_high_max"]
    assert 0 < cycles < hi                               # mcycle inside the irq-to-ack span
    print(f"\nservo step (hg_bringup_isr, mcycle): last {ram['soc_isr_cycles_last']}, max "
          f"{cycles} cycles = {100 * cycles / TICK:.0f} % of the {RATE_HZ} Hz tick at "
          f"{CLK_HZ // 1_000_000} MHz ({TICK} cycles; goal 50 %); irq to acknowledgement "
          f"{s['irq_high_min']}..{hi} clocks; {s['irq_retired'] / max(s['irq_clocks'], 1):.2f} "
          f"instructions per clock in the handler; {s['fpga_ticks']} FPGA ticks, "
          f"{s['acked']} handled")


def test_servo_keeps_the_1khz_tick(wall: tuple[soc.SocRun, dict[int, pclink.State], int]
                                   ) -> None:
    """Over BUDGET_TICKS ticks with the hand in a wall (the servo enabled, a force on every
    step), in simulation time: every FPGA tick raises an interrupt (IRQ.MISSED never set), the
    handler sees SEQ advance by exactly one per interrupt, and each interrupt is acknowledged
    within half a tick (issue 36's goal) by the handler's one IRQ write; the servo latched no
    error and pushes into the wall at the end."""
    run, states, held_from = wall
    s, ram = run.summary, run.ram
    assert ram["soc_trap_cause"] == 0, f"trap: mcause 0x{ram['soc_trap_cause']:x}"
    assert s["irq_missed_sets"] == 0 and s["irq_missed_end"] == 0
    assert s["ticks"] == s["fpga_ticks"]                 # no tick while one was pending
    assert s["period_min"] == s["period_max"] == TICK
    assert s["acked"] >= s["fpga_ticks"] - 1 and s["acked"] == ram["soc_isr_count"]
    assert s["irq_writes"] == s["acked"]
    seqs = [t[3] for t in run.ticks]
    assert all(b - a == 1 for a, b in zip(seqs, seqs[1:])), seqs
    in_wall = [t for t in run.ticks if t[0] > held_from and t[1]]
    assert len(in_wall) >= BUDGET_TICKS
    assert s["irq_high_max"] <= TICK // 2
    # the last state: enabled, no error latched, the wall pushing back along its normal
    assert 16 in states, "no reply to the last GET_STATE"
    last = states[16]
    assert last.flags & 1 and not last.flags & 2 and last.err == 0
    assert last.scene == pclink.SCENE_WALL
    assert last.f[2] == pytest.approx(WALL_K * WALL_DEPTH, rel=1e-3)
    assert abs(last.f[0]) < 1e-6 and abs(last.f[1]) < 1e-6
    cycles = ram["soc_isr_cycles_max"]
    print(f"\nwall, hand in contact ({last.f[2]:.2f} N), {len(in_wall)} ticks: servo step "
          f"(mcycle) max {cycles} cycles = {100 * cycles / TICK:.1f} % of the {RATE_HZ} Hz tick at "
          f"{CLK_HZ // 1_000_000} MHz; irq to acknowledgement max {s['irq_high_max']} clocks "
          f"({100 * s['irq_high_max'] / TICK:.1f} %); {s['fpga_ticks']} FPGA ticks, "
          f"{s['acked']} handled, IRQ.MISSED never set")


def test_soc_lint_and_waivers_kept_apart() -> None:
    """Our SoC sources are verilator -Wall clean with the project's waivers; VexRiscv's own
    waivers (rtl/lint/vexriscv.vlt) name only its file."""
    from hapgate.base import toolenv
    from hapgate.base.paths import RTL, RTL_INCLUDE

    toolenv.apply()
    vlt = RTL / "lint" / "vexriscv.vlt"
    rules = [ln for ln in vlt.read_text().splitlines() if ln.startswith("lint_off")]
    assert rules and all('-file "*/pythondata_cpu_vexriscv/verilog/VexRiscv_FullCfu.v"' in ln
                         for ln in rules)
    cmd = ["verilator", "--lint-only", "-Wall", "--top-module", "hapgate_soc_top",
           str(RTL / "lint" / "waivers.vlt"), str(vlt), f"-I{RTL_INCLUDE}",
           *map(str, soc.sources())]
    r = subprocess.run(cmd, capture_output=True, text=True, check=False)
    problems = [ln for ln in (r.stdout + r.stderr).splitlines() if ln.startswith("%")]
    assert r.returncode == 0 and not problems, "\n".join(problems)
    ice = subprocess.run(["iverilog", "-g2005", "-Wall", "-Wno-timescale", "-o", "/dev/null",
                          "-s", "hapgate_soc_top", f"-I{RTL_INCLUDE}", *map(str, soc.sources())],
                         capture_output=True, text=True, check=False)
    ours = [ln for ln in ice.stderr.splitlines() if "VexRiscv_FullCfu.v" not in ln]
    assert ice.returncode == 0 and not ours, ice.stderr
    assert Path(soc.vexriscv_source()).name == "VexRiscv_FullCfu.v"
