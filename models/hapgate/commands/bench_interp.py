"""Interpolator benchmark: run time beside error for every engine, the LUT-density sweep with
Yosys cells, and the error plots of the paper's method (build/reports/)."""

from __future__ import annotations

import json
import time
from dataclasses import asdict

import numpy as np

from ..base.paths import BUILD, TB, ensure
from ..base.report import figure_path, pyplot, save_figure, table, write_csv
from ..flows import blocks, flow
from ..golden import encsig, interp
from ..runners import native, sim

ENGINE_HEADERS = ["signals", "engine", "samples", "seconds", "samples/s", "rms [el deg]",
                  "max [el deg]", "rms [mech deg]", "mismatches vs model"]


def _err_deg(pos: np.ndarray, truth_lines: np.ndarray, cfg: interp.InterpConfig) -> np.ndarray:
    err = interp.truth_counts_error(pos, truth_lines * cfg.counts_per_line)
    return interp.counts_to_elec_deg(err, cfg)


def _row(signals: str, engine: str, n: int, secs: float, err: np.ndarray, mism: object
         ) -> list[object]:
    return [signals, engine, n, f"{secs:.3f}", f"{n / secs:.3e}",
            f"{np.sqrt(np.mean(err**2)):.4f}", f"{np.abs(err).max():.4f}",
            f"{np.sqrt(np.mean(err**2)) / 1024:.2e}", mism]


def _cocotb_positions(simulator: str, scenario: str, n: int, cfg: interp.InterpConfig
                      ) -> tuple[np.ndarray, float]:
    dump = ensure(BUILD / "bench") / f"interp_{simulator}_{scenario}.npy"
    kw = dict(params=cfg.rtl_params(), testcase="scenario_bit_exact", quiet=True,
              extra_env={"HG_MODEL": json.dumps(asdict(cfg)), "HG_SCENARIO": scenario,
                         "HG_SAMPLES": str(n), "HG_DUMP": str(dump)})
    block = blocks.get("enc_interp")
    sim.run_cocotb(block, simulator, "cocotb_enc_interp", TB / "interp",
                   **kw | {"extra_env": kw["extra_env"] | {"HG_SAMPLES": "50"}})  # build
    t0 = time.perf_counter()
    sim.run_cocotb(block, simulator, "cocotb_enc_interp", TB / "interp", **kw)
    return np.load(dump), time.perf_counter() - t0


def engines_table(quick: bool) -> list[list[object]]:
    cfg = interp.InterpConfig()
    n_fast = 1_000_000 if quick else 4_000_000
    n_cocotb = {"verilator": 5_000 if quick else 20_000, "icarus": 2_000 if quick else 5_000}
    rows: list[list[object]] = []
    sims = sim.simulators()
    for signals in ("bench_ideal", "bench_paper"):
        sc = encsig.scenario(signals, n_fast)
        label = signals.removeprefix("bench_")
        t0 = time.perf_counter()
        ref = interp.atan2_counts(sc.a, sc.b, cfg)
        t_ref = time.perf_counter() - t0
        wrap = np.round(sc.truth_lines - ref / cfg.counts_per_line)   # whole lines: unwrap
        rows.append(_row(label, "float atan2 on the samples", n_fast, t_ref,
                         _err_deg(ref + wrap * cfg.counts_per_line, sc.truth_lines, cfg), "-"))
        interp.run(sc.a, sc.b, None, cfg)      # warm-up: first-touch page faults of the heap
        t0 = time.perf_counter()
        model = interp.run(sc.a, sc.b, None, cfg)
        t_model = time.perf_counter() - t0
        rows.append(_row(label, "bit-exact model (numpy, warm)", n_fast, t_model,
                         _err_deg(model.pos, sc.truth_lines, cfg), "-"))
        native.build_interp(cfg, axes=1)
        for axes in (1, 3):
            a = np.repeat(sc.a[:, None], axes, 1)
            b = np.repeat(sc.b[:, None], axes, 1)
            run = native.run_interp(a, b, None, cfg, columns=["pos"])
            mism = sum(int(np.count_nonzero(run.axis(i)["pos"] != model.pos))
                       for i in range(axes))
            rows.append(_row(label, f"Verilator native, {axes} ax, pos only",
                             n_fast, run.seconds, _err_deg(run.axis(0)["pos"], sc.truth_lines,
                                                           cfg), mism))
        run = native.run_interp(np.repeat(sc.a[:, None], 3, 1), np.repeat(sc.b[:, None], 3, 1),
                                None, cfg)
        rows.append(_row(label, "Verilator native, 3 ax, all outputs", n_fast, run.seconds,
                         _err_deg(run.axis(0)["pos"], sc.truth_lines, cfg),
                         int(np.count_nonzero(run.axis(0)["pos"] != model.pos))))
        run = native.run_interp(sc.a[:200_000], sc.b[:200_000], None, cfg,
                                clk_hz=interp.BOARD_CLK_HZ, columns=["pos"])
        rows.append(_row(label, "Verilator native, 1 ax, CLK 48 MHz", 200_000, run.seconds,
                         _err_deg(run.axis(0)["pos"], sc.truth_lines[:200_000], cfg),
                         int(np.count_nonzero(run.axis(0)["pos"] != model.pos[:200_000]))))
        for s in sims:
            m = n_cocotb[s]
            pos, secs = _cocotb_positions(s, signals, m, cfg)
            short = encsig.scenario(signals, m)   # the same stimulus the cocotb run generated
            rows.append(_row(label, f"cocotb {s}, 1 ax", m, secs,
                             _err_deg(pos, short.truth_lines, cfg),
                             int(np.count_nonzero(pos != interp.run(short.a, short.b).pos))))
    return rows


SWEEP_HEADERS = ["lut bits/45deg", "counts/line", "ideal rms [el deg]", "ideal max [el deg]",
                 "paper rms [el deg]", "paper max [el deg]", "model seconds", "ice40 cells",
                 "SB_LUT4", "yosys seconds"]


def lut_sweep(quick: bool) -> list[list[object]]:
    n = 200_000 if quick else 1_000_000
    rows: list[list[object]] = []
    scs = {k: encsig.scenario(k, n) for k in ("bench_ideal", "bench_paper")}
    for bits in range(5, 10):
        cfg = interp.InterpConfig(lut_bits=bits)
        errs = {}
        t0 = time.perf_counter()
        for k, sc in scs.items():
            errs[k] = _err_deg(interp.run(sc.a, sc.b, None, cfg).pos, sc.truth_lines, cfg)
        secs = time.perf_counter() - t0
        f = flow.synth(blocks.get("enc_interp"), cfg.rtl_params(), "ice40", tag=f"lut{bits}")
        e_i, e_p = errs["bench_ideal"], errs["bench_paper"]
        rows.append([bits, cfg.counts_per_line, f"{np.sqrt(np.mean(e_i**2)):.4f}",
                     f"{np.abs(e_i).max():.4f}", f"{np.sqrt(np.mean(e_p**2)):.4f}",
                     f"{np.abs(e_p).max():.4f}", f"{secs:.3f}", f.resources.get("cells", "?"),
                     f.resources.get("SB_LUT4", "?"), f"{f.seconds:.1f}"])
    return rows


def error_plots() -> str:
    """Histogram and error against electrical angle of the paper's method (ideal and paper-like
    signals); the jump at the 45-degree LUT switch shows in the paper-like curve."""
    cfg = interp.InterpConfig()
    plt = pyplot()
    fig, ax = plt.subplots(2, 2, figsize=(11, 7))
    for col, name in enumerate(("bench_ideal", "bench_paper")):
        sc = encsig.scenario(name, 200_000)
        err = _err_deg(interp.run(sc.a, sc.b, None, cfg).pos, sc.truth_lines, cfg)
        ang = np.mod(sc.truth_lines, 1.0) * 360.0
        ax[0, col].hist(err, bins=120)
        ax[0, col].set_title(f"{name.removeprefix('bench_')} signals: error histogram "
                             f"(rms {np.sqrt(np.mean(err**2)):.3f} deg)")
        ax[0, col].set_xlabel("error [electrical deg]")
        ax[1, col].plot(ang, err, ".", ms=1)
        for q in range(9):
            ax[1, col].axvline(45 * q, color="r" if q % 2 else "k", lw=0.5)
        ax[1, col].set_xlabel("electrical angle [deg] (red: 45-deg LUT switch)")
        ax[1, col].set_ylabel("error [deg]")
    fig.tight_layout()
    path = figure_path("bench_interp_error.png")
    save_figure(fig, path, dpi=100)
    plt.close(fig)
    return str(path)


def run(quick: bool) -> bool:
    t0 = time.perf_counter()
    rows = engines_table(quick)
    print("== interpolator: run time against error (electrical degrees per line; truth = the "
          "generator's float angle) ==")
    print(table(ENGINE_HEADERS, rows))
    print(f"csv: {write_csv('bench_interp_engines.csv', ENGINE_HEADERS, rows)}")
    sweep = lut_sweep(quick)
    print("\n== interpolator: arcsine LUT density sweep (model error; Yosys synth_ice40 -dsp of "
          "one axis) ==")
    print(table(SWEEP_HEADERS, sweep))
    print(f"csv: {write_csv('bench_interp_lut_sweep.csv', SWEEP_HEADERS, sweep)}")
    print(f"plot: {error_plots()}")
    print(f"(interpolator bench: {time.perf_counter() - t0:.1f} s)")
    return all(r[-1] in ("-", 0) for r in rows)
