"""`make demo`: run the design on the RTL and on the golden models, print the comparison, plot.

Today: the commutation sine ROM. Each section prints its run time beside its error.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict

import numpy as np

from ..base import toolenv
from ..base.paths import BUILD, ROOT, TB, ensure
from ..base.report import figure_path, pyplot, save_figure, table
from ..flows import blocks
from ..golden import encsig, interp, sine
from ..runners import cosim, native, sim
from . import bench_commutation, scene


def sine_section() -> tuple[list[list[object]], bool]:
    cfg = sine.SineRomConfig()
    codes = np.arange(4 * cfg.entries)
    dump = ensure(BUILD / "demo") / "sine_rtl.npy"
    dump.unlink(missing_ok=True)
    t0 = time.perf_counter()
    sim.run_cocotb(blocks.get("sine_lut"), "verilator", "cocotb_sine_lut", TB / "commutation",
                   params=sine.rtl_params(cfg), testcase="all_codes_bit_exact",
                   extra_env={"HG_MODEL": json.dumps(asdict(cfg)), "HG_DUMP": str(dump)},
                   quiet=True)
    t_rtl = time.perf_counter() - t0
    rtl = np.load(dump)
    t0 = time.perf_counter()
    model = sine.sine_model(codes, cfg)
    t_model = time.perf_counter() - t0
    t0 = time.perf_counter()
    truth = sine.sine_truth(codes, cfg)
    t_truth = time.perf_counter() - t0
    mism = int(np.count_nonzero(rtl != model))
    rows: list[list[object]] = []
    for name, out, secs in (("float truth", truth, t_truth), ("integer model", model, t_model),
                            ("RTL (cocotb+Verilator, incl. build)", rtl, t_rtl)):
        err = np.asarray(out, float) - truth
        rows.append([name, codes.size, f"{secs:.4f}", f"{np.sqrt(np.mean(err**2)):.4f}",
                     f"{np.abs(err).max():.4f}", "-" if out is truth else
                     str(int(np.count_nonzero(np.asarray(out) != model)))])
    plt = pyplot()
    fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    ax[0].plot(codes, rtl, label="RTL")
    ax[0].set_ylabel("code")
    ax[0].set_title(f"sine ROM: {cfg.entries}-entry quarter wave, FS={cfg.fs}")
    ax[1].plot(codes, rtl - truth, ".", ms=2)
    ax[1].axhline(sine.ERROR_BUDGET_LSB, color="r", lw=0.8)
    ax[1].axhline(-sine.ERROR_BUDGET_LSB, color="r", lw=0.8)
    ax[1].set_ylabel("RTL - FS*sin [LSB]")
    ax[1].set_xlabel("angle code")
    fig.tight_layout()
    save_figure(fig, figure_path("demo_sine_rom.png"), dpi=100)
    plt.close(fig)
    return rows, mism == 0


def interp_section(n: int = 1_000_000) -> tuple[list[list[object]], bool]:
    """Three encoder axes (paper-like front end ramping to 244 rev/s; paper-like reversals at
    up to 150 rev/s; a 110-code signal with a dropout, homing and fault clears), 1 s of 1 MSPS
    samples each, through the native Verilated RTL and the bit-exact model; error against the
    generator's float truth up to the first fault (after a fault the position is not trusted:
    the axis must be re-homed)."""
    cfg = interp.InterpConfig()
    names = ("ramp244_paper", "reversals_paper", "dropout_controls")
    scs = [encsig.scenario(name, n, seed=3) for name in names]
    a = np.stack([s.a for s in scs], 1)
    b = np.stack([s.b for s in scs], 1)
    idx = np.stack([s.index for s in scs], 1)
    native.build_interp(cfg)
    run = native.run_interp(a, b, idx, cfg, clear_at=[s.clear_at for s in scs],
                            arm_at=[s.arm_at for s in scs])
    rows: list[list[object]] = []
    ok = True
    plt = pyplot()
    fig, ax = plt.subplots(len(scs), 1, figsize=(9, 7), sharex=True)
    for i, sc in enumerate(scs):
        t0 = time.perf_counter()
        model = interp.run(sc.a, sc.b, sc.index, cfg, clear_at=sc.clear_at, arm_at=sc.arm_at)
        t_model = time.perf_counter() - t0
        rtl = run.axis(i)
        mism = native.first_mismatch(rtl, native.model_matrix(model))
        ok &= mism is None
        truth = sc.truth_lines * cfg.counts_per_line
        faulted = np.flatnonzero(rtl["faults"])
        upto = int(faulted[0]) if faulted.size else n
        err_deg = interp.counts_to_elec_deg(interp.truth_counts_error(rtl["pos"], truth), cfg)
        e = err_deg[:max(upto, 1)]
        first = (f"{upto} (bits {int(rtl['faults'][upto])})" if faulted.size else "none")
        rows.append([f"axis {i}: {sc.name}", n, f"{run.seconds:.3f}", f"{t_model:.3f}",
                     f"{np.sqrt(np.mean(e**2)):.3f}", f"{np.abs(e).max():.3f}", first,
                     int(rtl["index_count"][-1]), int(rtl["homed"][-1]),
                     "none" if mism is None else f"sample {mism[0]} {mism[1]}"])
        t_ms = np.arange(n) / 1000.0
        ax[i].plot(t_ms[::50], err_deg[::50], lw=0.5)
        ax[i].set_ylabel(f"axis {i}\nerr [el deg]")
        ax[i].set_title(sc.name, fontsize=9)
    ax[-1].set_xlabel("time [ms]")
    fig.tight_layout()
    save_figure(fig, figure_path("demo_interp.png"), dpi=100)
    plt.close(fig)
    return rows, ok


def main(_: argparse.Namespace) -> int:
    toolenv.apply()
    rows, ok = sine_section()
    print("Commutation sine ROM: 1024 angle codes (error in LSB of the 14-bit DAC code)")
    print(table(["engine", "samples", "seconds", "rms err", "max err", "mismatches vs model"],
                rows))
    print(f"plot: {figure_path('demo_sine_rom.png')}\n")
    rows, ok_i = interp_section()
    print("Encoder interpolator: 3 axes x 10^6 samples at 1 MSPS, native Verilated RTL "
          "(all 3 axes together) vs the bit-exact model; error vs float truth in electrical "
          "degrees, up to the first fault")
    print(table(["axis / scenario", "samples", "RTL seconds", "model seconds", "rms err",
                 "max err", "first fault", "index edges", "homed", "first mismatch"], rows))
    print(f"plot: {figure_path('demo_interp.png')}")
    ok &= ok_i
    print()
    ok &= bench_commutation.demo_section()
    print()
    ok &= cosim.demo_section()
    print()
    print("Virtual device, closed loop (scenes/short.toml: gateware + unchanged firmware + plant "
          "+ hand, `hapgate scene run`)", flush=True)
    ok &= scene.run_file(ROOT / "scenes" / "short.toml") == 0
    print("demo:", "RTL matches the models bit for bit" if ok else "RTL DIFFERS from a model")
    return 0 if ok else 1
