"""Commutation benchmark (`make bench`) and demo section (`make demo`).

run(quick): ripple and torque error against the ROM size (64/128/256/512 quarter-wave entries =
8..11 electrical angle bits), with Yosys cells (synth_ice40 -dsp of the whole commutator), and
run time per engine. demo_section(): RTL vs model vs truth with run time beside error, and the
paper's figures from the RTL's own codes (plots in build/reports/).
"""

from __future__ import annotations

import json
import time

import numpy as np

from ..base import toolenv
from ..base.paths import BUILD, TB, ensure
from ..base.report import figure_path, pyplot, save_figure, table, write_csv
from ..flows import blocks, flow
from ..golden import commutation as cm
from ..golden.sine import SineRomConfig
from ..runners import native_comm, sim
from .replay_commutation import run_rtl

ROM_SIZES = (6, 7, 8, 9)   # addr_bits: 64, 128, 256, 512 entries


def _sweep_codes(cfg: cm.CommutationConfig) -> tuple[dict[int, np.ndarray], dict[int, cm.Sweep]]:
    codes, sweeps = {}, {}
    for mode in (cm.SINE, cm.SIX_STEP):
        sw, fr = cm.sweep_frames(cfg, mode)
        sweeps[mode], codes[mode] = sw, cm.commutate(fr, cfg)
    return codes, sweeps


def _random_sine(n: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray, cm.Frames]:
    rng = np.random.default_rng(seed)
    pos = rng.integers(0, 1 << 32, (n, 3))
    tq = rng.integers(-32767, 32768, (n, 3))
    off = rng.integers(0, 1024, (n, 3))
    return pos, tq, off, cm.Frames.make(pos, tq, offset=off)


def rom_sweep(quick: bool) -> tuple[list[str], list[list[object]]]:
    n = 20_000 if quick else 500_000
    headers = ["ROM entries", "angle bits", "sine ripple p-p %", "mean err %", "six-step ripple %",
               "rms err LSB", "max err LSB", "LUT4", "RAM", "MAC16", "cells", "model s"]
    rows: list[list[object]] = []
    block = blocks.get("commutator")
    for ab in ROM_SIZES:
        cfg = cm.CommutationConfig(rom=SineRomConfig(addr_bits=ab))
        t0 = time.perf_counter()
        codes, sweeps = _sweep_codes(cfg)
        fig = cm.figures(cfg, codes, sweeps)
        pos, tq, off, fr = _random_sine(n)
        # offsets are in 1/1024 cycle in the random set: scale to this ROM's grid
        fr.offset = (off * cfg.codes) // 1024
        err = cm.commutate(fr, cfg) - cm.truth(pos, tq, fr.offset, cfg)
        secs = time.perf_counter() - t0
        f = flow.synth(block, cfg.rtl_params(), "ice40", tag=f"rom{ab}")
        r = f.resources
        rows.append([cfg.rom.entries, cfg.angle_bits, f"{100 * fig['sine_ripple']:.3f}",
                     f"{100 * (fig['sine_mean'] / 1.5 - 1):+.3f}",
                     f"{100 * fig['six_step_ripple']:.3f}",
                     f"{np.sqrt(np.mean(err ** 2)):.2f}", f"{np.abs(err).max():.2f}",
                     r.get("SB_LUT4", 0), r.get("SB_RAM40_4K", 0), r.get("SB_MAC16", 0),
                     r.get("cells", 0), f"{secs:.2f}"])
    return headers, rows


def _truth_and_model(n: int, seed: int, cfg: cm.CommutationConfig):
    """n random SINE frames through the float truth and the bit-exact model, each timed (CPU)."""
    pos, tq, off, fr = _random_sine(n, seed=seed)
    t0 = time.process_time()
    tr = cm.truth(pos, tq, off, cfg)
    t_truth = time.process_time() - t0
    t0 = time.process_time()
    mod = cm.commutate(fr, cfg)
    t_model = time.process_time() - t0
    return fr, tr, t_truth, mod, t_model


# the shipped clocks (48 MHz default, 12 MHz iCE40 board), others the RTL accepts, the slowest
RTL_CLOCKS = (48_000_000, 12_000_000, 6_000_000, 24_000_000, 100_000_000, 2_000_000)


def engine_speed(quick: bool) -> tuple[list[str], list[list[object]], bool]:
    cfg = cm.CommutationConfig(clk_hz=50_000_000)
    n_model = 100_000 if quick else 2_000_000
    n_rtl = 20_000 if quick else 200_000
    headers = ["engine", "frames", "CPU s", "frames/s (CPU)", "rms err LSB", "max err LSB",
               "mismatches vs model"]
    rows: list[list[object]] = []
    fr, tr, t_truth, mod, t_model = _truth_and_model(n_model, 2, cfg)
    e = mod - tr
    rows.append(["float truth", n_model, f"{t_truth:.3f}", f"{n_model / t_truth:.3g}", "0", "0",
                 "-"])
    rows.append(["integer model (numpy)", n_model, f"{t_model:.3f}", f"{n_model / t_model:.3g}",
                 f"{np.sqrt(np.mean(e ** 2)):.2f}", f"{np.abs(e).max():.2f}", "-"])
    ok = True
    small = fr.take(slice(0, n_rtl))
    skipped = {}
    for clk_hz in RTL_CLOCKS:
        c = cfg.with_(clk_hz=clk_hz)
        native_comm.build_commutation(c)                  # (cached; not timed)
        run = native_comm.run_commutation(small, c)
        skipped[clk_hz] = run
        e = run.codes - tr[:n_rtl]
        mism = int(np.count_nonzero(run.codes != mod[:n_rtl]))
        sched = native_comm.schedule_errors(run, c)
        ok &= mism == 0 and sched == 0
        rows.append([f"RTL native @ {clk_hz / 1e6:g} MHz ({c.frame_clocks} clk/frame, "
                     f"{run.edges / (n_rtl + 1):.0f} evaluated, {sched} timing errors)", n_rtl,
                     f"{run.cpu_seconds:.2f}", f"{n_rtl / run.cpu_seconds:.3g}",
                     f"{np.sqrt(np.mean(e ** 2)):.2f}", f"{np.abs(e).max():.2f}", str(mism)])
    # the same frames with every clock evaluated (no idle skip): identical words and load clocks
    for clk_hz in (48_000_000, 12_000_000):
        c = cfg.with_(clk_hz=clk_hz)
        run = native_comm.run_commutation(small, c, skip=False)
        same = (np.array_equal(run.codes, skipped[clk_hz].codes)
                and np.array_equal(run.load_clocks, skipped[clk_hz].load_clocks))
        e = run.codes - tr[:n_rtl]
        mism = int(np.count_nonzero(run.codes != mod[:n_rtl]))
        sched = native_comm.schedule_errors(run, c)
        ok &= mism == 0 and sched == 0 and same
        rows.append([f"RTL native @ {clk_hz / 1e6:g} MHz, every clock ({sched} timing errors; "
                     f"{'identical to' if same else 'DIFFERS from'} the skipping run)", n_rtl,
                     f"{run.cpu_seconds:.2f}", f"{n_rtl / run.cpu_seconds:.3g}",
                     f"{np.sqrt(np.mean(e ** 2)):.2f}", f"{np.abs(e).max():.2f}", str(mism)])
    return headers, rows, ok


def run(quick: bool) -> bool:
    toolenv.apply()
    print("== commutation: ripple and error vs ROM size (model through the motor model; "
          "Yosys synth_ice40 -dsp of the three-motor commutator) ==")
    h, rows = rom_sweep(quick)
    print(table(h, rows))
    print(f"csv: {write_csv('bench_commutation_rom.csv', h, rows)}")
    _plot_rom(rows)
    print("== commutation: run time per engine (random SINE frames, error vs float truth in "
          "DAC LSB; RTL: the native harness, idle clocks skipped unless 'every clock') ==")
    h, rows, ok = engine_speed(quick)
    print(table(h, rows))
    print(f"csv: {write_csv('bench_commutation_engines.csv', h, rows)}")
    return ok


def _plot_rom(rows: list[list[object]]) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.5))
    n = [int(r[0]) for r in rows]
    ax[0].semilogx(n, [float(r[2]) for r in rows], "o-", base=2)
    ax[0].axhline(0.3, color="r", lw=0.8)
    ax[0].set_xlabel("quarter-wave ROM entries")
    ax[0].set_ylabel("sine torque ripple p-p [%]")
    ax[1].semilogx(n, [float(r[5]) for r in rows], "o-", base=2, label="rms")
    ax[1].semilogx(n, [float(r[6]) for r in rows], "s-", base=2, label="max")
    ax[1].set_xlabel("quarter-wave ROM entries")
    ax[1].set_ylabel("code error vs truth [LSB]")
    ax[1].legend()
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, figure_path("bench_commutation_rom.png"), dpi=100)
    plt.close(fig)


def demo_section() -> bool:
    """`make demo`: 1000 random frames on truth, model and RTL; the paper's figures from the RTL."""
    toolenv.apply()
    cfg = cm.CommutationConfig()        # the 48 MHz default
    n = 1000
    fr, tr, t_truth, mod, t_model = _truth_and_model(n, 3, cfg)
    rtl, load_ns, t_rtl = run_rtl(fr, cfg)
    rows = []
    for name, out, secs in (("float truth", tr, t_truth), ("integer model", mod, t_model),
                            ("RTL (native Verilator, incl. build)", rtl, t_rtl)):
        e = np.asarray(out, float) - tr
        rows.append([name, n * 6, f"{secs:.4f}", f"{np.sqrt(np.mean(e ** 2)):.3f}",
                     f"{np.abs(e).max():.3f}",
                     "-" if out is tr else str(int(np.count_nonzero(out != mod)))])
    print("Commutation: 1000 random SINE frames x 6 channels (error vs float truth, DAC LSB)")
    print(table(["engine", "samples", "seconds", "rms err", "max err", "mismatches vs model"],
                rows))
    print("DAC loads after the frame start (ns, 48 MHz): "
          + ", ".join(f"{t:.0f}" for t in load_ns[0]))
    # the paper's figures from the RTL's codes (Verilator, 16 MHz: short frames)
    fcfg = cm.CommutationConfig(clk_hz=16_000_000)
    dump = ensure(BUILD / "demo") / "commutation_figures.npz"
    dump.unlink(missing_ok=True)
    t0 = time.perf_counter()
    sim.run_cocotb(blocks.get("commutator"), "verilator", "cocotb_commutator", TB / "commutation",
                   params=fcfg.rtl_params(), testcase="paper_figures",
                   extra_env={"HG_MODEL": json.dumps(fcfg.to_json()), "HG_DUMP": str(dump)},
                   quiet=True)
    t_fig = time.perf_counter() - t0
    z = np.load(dump)
    codes = {cm.SINE: z["sine"], cm.SIX_STEP: z["six_step"]}
    sweeps = {m: cm.sweep_positions(fcfg) for m in (cm.SINE, cm.SIX_STEP)}
    fig = cm.figures(fcfg, codes, sweeps)
    paths = cm.plot_figures(fcfg, codes, sweeps)
    print(table(["figure (from the RTL's codes)", "paper", "measured"], [
        ["six-step ripple (max-min)/max", "13.4 %", f"{100 * fig['six_step_ripple']:.2f} %"],
        ["six-step mean torque", "3*sqrt(3)/pi = 1.654", f"{fig['six_step_mean']:.4f}"],
        ["sine ripple p-p", "<= 0.3 % (issue)", f"{100 * fig['sine_ripple']:.3f} %"],
        ["sine mean torque", "1.5", f"{fig['sine_mean']:.4f}"],
        ["mean ratio sine/six-step", "~0.91 (1.5/1.65)", f"{fig['mean_ratio']:.4f}"],
    ]))
    print(f"({2 * len(sweeps[cm.SINE].pos)} RTL frames in {t_fig:.1f} s incl. build); plots: "
          + ", ".join(paths))
    return bool(np.array_equal(rtl, mod))
