"""`make bench`: run time beside error for every engine, as tables on stdout and CSV/PNG in
build/reports/. Speed is printed here, never asserted in a test.

The same tables go into the generated figures page, docs/figures.md, one section per part of
the bench, each headed by the date, the commit (`git rev-parse --short HEAD`, "-dirty" when the
tracked tree has changes) and the machine (CPU model, cores, load average) it was measured on. A
run with `--only` replaces the sections it ran and keeps the others as they were measured.
The page is written atomically (a temporary file in docs/, then a rename).

    python -m hapgate.commands.bench [--quick] [--only sine fw ...]   (make bench BENCH_ARGS=...)
"""

from __future__ import annotations

import argparse
import datetime as dt
import io
import os
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from ..base import toolenv
from ..base.paths import BUILD, ROOT, ensure
from ..base.report import table, write_csv
from ..runners import cosim
from . import (
    bench_bringup,
    bench_calib,
    bench_commutation,
    bench_host,
    bench_interp,
    bench_velobs,
    bench_view,
)

FIGURES = ROOT / "docs" / "figures.md"
MARK = "<!-- bench section: {} -->"
MARK_RE = re.compile(r"^<!-- (bench|hand) section: ([\w-]+) -->$", re.M)
# A section written by hand (its marker "<!-- hand section: NAME -->", e.g. the test tiers' run
# times): kept as it is, after the generated ones, by every run


def _sine(quick: bool) -> bool:
    from . import demo

    headers = ["engine", "samples", "seconds", "rms err", "max err", "mismatches vs model"]
    rows, ok = demo.sine_section()
    print("== sine ROM (1024 codes; error in DAC LSB) ==")
    print(table(headers, rows))
    print(f"csv: {write_csv('bench_sine_rom.csv', headers, rows)}")
    return ok


def _device(quick: bool) -> bool:
    from . import bench_device

    return bench_device.run(quick)


def _fw(quick: bool) -> bool:
    print("== DSP firmware: servo step cost (make -C dsp-fw bench) ==", flush=True)
    r = subprocess.run(["make", "-s", "-C", str(ROOT / "dsp-fw"), "bench"],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    print(r.stdout, end="")
    return r.returncode == 0


def _seu(quick: bool) -> bool:
    """A slice of each fault-injection campaign (scenes/sweeps/seu.toml on `paper`,
    seu_hardened.toml on `hardened`: the first N of their seeded jobs, uncached): the per-block
    table and the runs per second on two workers."""
    n = 60 if quick else 400
    ok = True
    for spec in ("seu", "seu_hardened"):
        print(f"== fault injection: the first {n} runs of scenes/sweeps/{spec}.toml, uncached, "
              "2 workers ==", flush=True)
        out = ensure(BUILD / "reports" / f"bench_{spec}")
        r = subprocess.run([sys.executable, "-m", "hapgate.commands.cli", "sweep",
                            str(ROOT / "scenes" / "sweeps" / f"{spec}.toml"), "--workers", "2",
                            "--limit", str(n), "--no-cache", "--out", str(out)],
                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        print(r.stdout, end="")
        ok &= r.returncode == 0
    return ok


def _soc(quick: bool) -> bool:
    """The SoC's cycle budget (issue 36): the firmware image, then the servo step's CPU cycles
    (mcycle, the worst of the run) with the hand in a 20 N/cm wall, against the 1 kHz tick at
    48 MHz, beside the simulation's real-time factor."""
    from ..runners import soc

    ticks = 10 if quick else 40
    clk_hz, rate_hz = 48_000_000, 1000        # the ECP5 board's SoC clock, the servo's rate
    print(f"== the SoC: the servo step's cycles in a wall ({ticks} ticks in contact, "
          "hapgate.runners.soc.wall_run), VexRiscv_FullCfu with the float unit at 48 MHz ==",
          flush=True)
    fw = soc.build_firmware()
    print(f"firmware image: text {fw.text} B, data {fw.data} B, bss {fw.bss} B")
    t0 = time.perf_counter()
    run, states = soc.wall_run(fw, ensure(BUILD / "reports" / "bench_soc"), ticks, clk_hz,
                               rate_hz)
    wall_s = time.perf_counter() - t0
    tick = clk_hz // rate_hz
    cyc = run.ram["soc_isr_cycles_max"]
    sim_s = run.summary["clocks"] / clk_hz
    ok = 16 in states and run.summary["irq_missed_sets"] == 0 and cyc < tick
    f = states[16].f[2] if 16 in states else float("nan")
    print(table(["scene", "ticks", "force N", "step cycles (max)", "tick load", "IRQ.MISSED",
                 "simulated s", "wall s", "real-time x"],
                [["wall, hand in contact", ticks, f"{f:.2f}", cyc, f"{100 * cyc / tick:.1f} %",
                  run.summary["irq_missed_sets"], f"{sim_s:.3f}", f"{wall_s:.1f}",
                  f"{sim_s / wall_s:.4f}"]]))
    print(f"(the budget: {tick} cycles a tick; soft float alone took ~72 000, rtl/soc/README.md "
          "\"The budget\"; wall s: the probe and the wall run, builds cached)")
    return _soc_fidelity() and ok


def _soc_fidelity() -> bool:
    """The soc fidelity of the virtual device (scene run.fidelity = "soc"): its real-time
    factor beside its error against the rtl fidelity on the same scene (scenes/grip.toml, 30 ms:
    the pose held still, so both fidelities' ticks see the same inputs; the budget is derived
    in tb/device/test_soc_fidelity.py)."""
    from ..base.paths import ROOT
    from ..device import runner, soc
    from ..device import scene as scene_mod

    print("== the soc fidelity: the SoC in the virtual device's closed loop against the rtl "
          "fidelity (native firmware), scenes/grip.toml, 30 ms ==", flush=True)
    raws = {}
    for fid in ("rtl", "soc"):
        sc = scene_mod.load(ROOT / "scenes" / "grip.toml").override(
            {"run.duration_s": 0.03, "run.fidelity": fid})
        raws[fid] = runner.simulate(sc)
    dtau, ddac, frames = soc.compare(raws["rtl"], raws["soc"])
    rows = []
    for fid, raw in raws.items():
        s = raw.summary
        sim, wall, cpu = float(s["sim_s"]), float(s["wall_s"]), float(s["cpu_s"])
        rows.append([fid, s["clk_hz"], f"{sim:.3f}", f"{wall:.2f}", f"{sim / wall:.4f}",
                     f"{sim / cpu:.4f}",
                     f"{dtau * 1e6:.2f}" if fid == "soc" else "-",
                     ddac if fid == "soc" else "-", frames if fid == "soc" else "-"])
    print(table(["fidelity", "clock Hz", "simulated s", "wall s", "real-time x (wall)",
                 "real-time x (CPU)", "torque diff vs rtl uN m", "DAC diff vs rtl LSB",
                 "frames compared"], rows))
    print("(simulated s: scene time after the 9.1 ms power-up, which both also simulate; "
          "budget: torque within one firmware torque code, 14.6 uN m, DAC within 1 LSB)")
    return 0 <= ddac <= 1 and dtau < 0.48 / 32767


# name -> (title on the figures page, runner); the order of `make bench`
SECTIONS: dict[str, tuple[str, Callable[[bool], bool]]] = {
    "sine": ("Sine ROM", _sine),
    "interp": ("Encoder interpolator", bench_interp.run),
    "calib": ("Encoder calibration", bench_calib.run),
    "velobs": ("Velocity: window FIR and tracking observer", bench_velobs.run),
    "commutation": ("Commutation and DAC scheduler", bench_commutation.run),
    "cosim": ("Firmware co-simulation", cosim.bench_section),
    "device": ("Virtual device", _device),
    "host": ("Host API over the PC link", bench_host.run),
    "host-c": ("The C servo loop beside the Python loop", bench_host.run_c),
    "bringup": ("Bring-up: device time and accuracy per step", bench_bringup.run),
    "fw": ("DSP firmware: servo step cost", _fw),
    "seu": ("Fault injection: runs per second", _seu),
    "soc": ("The SoC: the servo step's cycle budget", _soc),
    "view": ("The live view: real-time factor with and without a viewer", bench_view.run),
}


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--quick", action="store_true", help="smaller runs")
    p.add_argument("--only", nargs="+", metavar="PART", choices=list(SECTIONS),
                   help=f"run only these parts ({', '.join(SECTIONS)}); the figures page keeps "
                        "the others as they were")


class _Tee(io.TextIOBase):
    """Everything printed goes to the terminal and into a buffer for the figures page."""

    def __init__(self, out: io.TextIOBase) -> None:
        self.out, self.buf = out, io.StringIO()

    def write(self, s: str) -> int:
        self.out.write(s)
        return self.buf.write(s)

    def flush(self) -> None:
        self.out.flush()


def _git(*argv: str) -> str:
    try:
        return subprocess.run(["git", *argv], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return ""


def commit() -> str:
    """Short hash of HEAD, with "-dirty" when tracked files differ from it."""
    head = _git("rev-parse", "--short", "HEAD") or "unknown"
    return head + ("-dirty" if _git("status", "--porcelain", "--untracked-files=no") else "")


def machine() -> str:
    model = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = ""
    if hasattr(os, "getloadavg"):
        load = f", load average {os.getloadavg()[0]:.1f} at the start"
    return f"{model}, {os.cpu_count()} cores{load}"


def _sections(text: str) -> dict[str, str]:
    """The sections of an existing figures page, by name, each from its marker to the next (a
    hand-written one by "hand:NAME")."""
    marks = list(MARK_RE.finditer(text))
    return {(m.group(2) if m.group(1) == "bench" else f"hand:{m.group(2)}"):
            text[m.start():marks[i + 1].start() if i + 1 < len(marks) else None].rstrip() + "\n"
            for i, m in enumerate(marks)}


def section_text(name: str, stamp: str, output: str, ok: bool) -> str:
    title = SECTIONS[name][0]
    verdict = "" if ok else "\n**This part reported a mismatch or a failure.**\n"
    return (f"{MARK.format(name)}\n## {title}\n\n{stamp}\n{verdict}\n```text\n"
            f"{output.strip()}\n```\n")


def render(sections: dict[str, str]) -> str:
    head = ("# Figures\n\n"
            "Generated by `make bench` (`models/hapgate/commands/bench.py`); do not edit by hand,\n"
            "but for the sections marked as written by hand, which every run keeps.\n"
            "Each part says when, at which commit and on which machine it was measured: run\n"
            "times depend on the machine and its load, errors and mismatches do not. Tables:\n"
            "run time beside error for every engine; CSVs and plots go to `build/reports/`.\n"
            "Re-run one part with `make bench BENCH_ARGS=\"--only PART\"`.\n")
    parts = [sections[n] if n in sections else
             f"{MARK.format(n)}\n## {SECTIONS[n][0]}\n\nNot measured yet.\n" for n in SECTIONS]
    parts += [v for k, v in sections.items() if k.startswith("hand:")]
    return head + "\n" + "\n".join(parts)


def write_atomic(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def main(args: argparse.Namespace) -> int:
    toolenv.apply()
    only = getattr(args, "only", None) or list(SECTIONS)
    quick = bool(getattr(args, "quick", False))
    stamp = (f"Measured {dt.date.today().isoformat()} at commit `{commit()}` on {machine()}"
             f"{' (`--quick`)' if quick else ''}.")
    old = _sections(FIGURES.read_text(encoding="utf-8")) if FIGURES.exists() else {}
    ok = True
    for name in only:
        tee = _Tee(sys.stdout)
        real, sys.stdout = sys.stdout, tee
        try:
            part_ok = bool(SECTIONS[name][1](quick))
        finally:
            sys.stdout = real
        print()
        output = tee.buf.getvalue().replace(f"{ROOT}/", "")   # paths as the repository names them
        old[name] = section_text(name, stamp, output, part_ok)
        ok &= part_ok
    write_atomic(FIGURES, render(old))
    print(f"figures: {FIGURES}")
    print("bench:", "all engines agree with the models" if ok else "MISMATCH or failure above")
    return 0 if ok else 1


if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m hapgate.commands.bench",
                                     description=__doc__.split("\n\n")[0])
    add_arguments(parser)
    sys.exit(main(parser.parse_args()))
