"""`make demo`: run the design on the RTL and on the golden models, print the comparison, plot.

Today: the commutation sine ROM. Each section prints its run time beside its error.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict

import numpy as np

from . import blocks, sim, sine, toolenv
from .paths import TB, ensure, BUILD
from .report import figure_path, pyplot, table


def sine_section() -> tuple[list[list[object]], bool]:
    cfg = sine.SineRomConfig()
    codes = np.arange(4 * cfg.entries)
    dump = ensure(BUILD / "demo") / "sine_rtl.npy"
    dump.unlink(missing_ok=True)
    t0 = time.perf_counter()
    sim.run_cocotb(blocks.get("sine_lut"), "verilator", "cocotb_sine_lut", TB / "commutation",
                   params=sine.rtl_params(cfg), testcase="all_codes_bit_exact",
                   extra_env={"HG_MODEL": json.dumps(asdict(cfg)), "HG_DUMP": str(dump)}, quiet=True)
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
    fig.savefig(figure_path("demo_sine_rom.png"), dpi=100)
    plt.close(fig)
    return rows, mism == 0


def main(_: argparse.Namespace) -> int:
    toolenv.apply()
    rows, ok = sine_section()
    print("Commutation sine ROM: 1024 angle codes (error in LSB of the 14-bit DAC code)")
    print(table(["engine", "samples", "seconds", "rms err", "max err", "mismatches vs model"],
                rows))
    print(f"plot: {figure_path('demo_sine_rom.png')}")
    print("demo:", "RTL matches the model bit for bit" if ok else "RTL DIFFERS from the model")
    return 0 if ok else 1
