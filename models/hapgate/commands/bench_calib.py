"""Benchmark of the online encoder calibration (enc_interp CAL = 1, hapgate.golden.enccal):
an imperfection sweep with the calibration off and on, error against run time (model and
native RTL, with the RTL's mismatches against the model), convergence, and the resources
of one axis with and without the calibration stage (Yosys synth_ice40 -dsp)."""

from __future__ import annotations

import time

import numpy as np

from ..base.report import table, write_csv
from ..flows import blocks, flow
from ..golden import angle, enccal, encsig, interp
from ..golden.encsig import IDEAL, PAPER_LIKE, SignalSpec, with_spec
from ..runners import native

SWEEP_HEADERS = ["signals", "rev/s", "calibration", "engine", "samples", "seconds",
                 "rms [el deg]", "max [el deg]", "rms [mech deg]", "rms lines 200-400",
                 "updates", "mismatches vs model"]
RES_HEADERS = ["build", "ice40 cells", "SB_LUT4", "flip-flops", "SB_MAC16", "SB_RAM40_4K",
               "yosys seconds"]

SIGNALS: list[tuple[str, SignalSpec, float]] = [
    ("ideal R=127 (clips: no update)", IDEAL, 37.3),
    ("ideal R=120", with_spec(IDEAL, amplitude=120.0), 37.3),
    ("paper-like", PAPER_LIKE, 37.3),
    ("paper-like", PAPER_LIKE, 150.0),
    ("paper-like, no noise", with_spec(PAPER_LIKE, noise_lsb=0.0), 37.3),
    ("offsets +-5 %", with_spec(PAPER_LIKE, offset_a=6.35, offset_b=-6.35), 37.3),
    ("gains +-5 %", with_spec(PAPER_LIKE, gain_a=1.05, gain_b=0.95), 37.3),
    ("phase 3 deg", with_spec(PAPER_LIKE, phase_deg=3.0), 37.3),
    ("amplitude -30 %", with_spec(PAPER_LIKE, amplitude=127 * 0.7), 37.3),
    ("paper-like + 1 % 3rd harmonic", with_spec(PAPER_LIKE, h3=0.01), 37.3),
]


def _errors(pos: np.ndarray, x: np.ndarray, cfg: interp.InterpConfig, start: int
            ) -> tuple[np.ndarray, np.ndarray]:
    """Electrical-degree error from `start` on (mean removed), and over lines 200..400."""
    e = interp.truth_counts_error(pos, x * cfg.counts_per_line)
    tail = e[start:] - e[start:].mean()
    travel = np.abs(x - x[0])
    w = (travel >= 200) & (travel < 400)
    win = e[w] - e[w].mean() if w.any() else tail
    return interp.counts_to_elec_deg(tail, cfg), interp.counts_to_elec_deg(win, cfg)


def sweep(quick: bool) -> list[list[object]]:
    n = 200_000 if quick else 1_000_000
    rows: list[list[object]] = []
    for label, spec, speed in SIGNALS:
        x = enccal.paper_truth(n, speed, start=0.37)
        a, b = encsig.adc_codes(x, spec)
        start = int(np.argmax(np.abs(x - x[0]) >= 200))   # error counted after 200 lines
        for cal in (False, True):
            cfg = interp.InterpConfig(cal=cal)
            t0 = time.perf_counter()
            out = interp.run(a, b, None, cfg, cal_en=cal)
            secs = time.perf_counter() - t0
            runs = [("model", out.pos, secs, "-")]
            if cal:
                r = native.run_interp(a, b, None, cfg, columns=native.COLUMNS, cal_en=True)
                bad = np.count_nonzero(np.any(np.stack(
                    [r.axis(0)[c] != native.model_matrix(out)[c] for c in native.COLUMNS]), 0))
                runs.append(("rtl (native)", r.axis(0)["pos"], r.seconds, bad))
            ups = int(out.extra["cal_updates"][-1]) if cal else 0
            for engine, pos, t, mism in runs:
                d, win = _errors(pos, x, cfg, start)
                rms = float(np.sqrt(np.mean(d * d)))
                rows.append([label, speed, "on" if cal else "off", engine, n, f"{t:.3f}",
                             f"{rms:.4f}", f"{np.abs(d).max():.4f}", f"{rms / 1024:.2e}",
                             f"{np.sqrt(np.mean(win * win)):.4f}", ups, mism])
    return rows


def resources() -> list[list[object]]:
    rows: list[list[object]] = []
    for label, cfg in (("paper (CAL=0)", interp.InterpConfig()),
                       ("calibrated (CAL=1)", interp.InterpConfig(cal=True))):
        f = flow.synth(blocks.get("enc_interp"), cfg.rtl_params(), "ice40",
                       tag="cal" if cfg.cal else "nocal")
        r = f.resources
        ffs = sum(v for k, v in r.items() if k.startswith("SB_DFF"))
        rows.append([label, r.get("cells", "?"), r.get("SB_LUT4", "?"), ffs,
                     r.get("SB_MAC16", 0), r.get("SB_RAM40_4K", 0), f"{f.seconds:.1f}"])
    return rows


ANGLE_HEADERS = ["mode", "counts/line", "signals", "engine", "samples", "seconds", "learn s",
                 "rms [el deg]", "max [el deg]", "mismatches vs model"]
ANGLE_MODES: list[tuple[str, interp.InterpConfig]] = [
    ("paper (arcsine)", interp.InterpConfig()),
    ("calib + arcsine", interp.InterpConfig(cal=True)),
    ("calib + ratio", interp.InterpConfig(cal=True, ratio=True)),
    ("calib + ratio", interp.InterpConfig(cal=True, ratio=True, lut_bits=9)),
    ("calib + ratio + harmonic", interp.InterpConfig(cal=True, ratio=True, harm=True)),
    ("calib + ratio + harmonic", interp.InterpConfig(cal=True, ratio=True, harm=True,
                                                     lut_bits=9)),
]
ANGLE_SIGNALS: list[tuple[str, SignalSpec]] = [
    ("ideal R=127", IDEAL), ("paper-like", PAPER_LIKE),
    ("paper-like + 1 % 3rd harmonic", with_spec(PAPER_LIKE, h3=0.01)),
]


def angle_sweep(quick: bool) -> list[list[object]]:
    """Every angle-stage mode on ideal, paper-like and 1 % h3 signals at 37.3 rev/s: error from
    200 lines of travel on (mean removed) beside the run time of the model and the native RTL
    (the ratio modes: the RTL's mismatches against the model on every output column). The
    harmonic modes load a table learned (`angle.harmonic_fit`) from the positions of another
    run of the same front end (other noise, other start) with the table off; "learn s" is the
    time of that run and fit."""
    n = 200_000 if quick else 1_000_000
    x = enccal.paper_truth(n, 37.3, start=0.37)
    start = int(np.argmax(np.abs(x - x[0]) >= 200))
    rows: list[list[object]] = []
    for mode, cfg in ANGLE_MODES:
        for label, spec in ANGLE_SIGNALS:
            a, b = encsig.adc_codes(x, spec)
            cal = cfg.cal and spec is not IDEAL    # ideal R = 127 clips: calibration stays off
            kw: dict[str, object] = {}
            learn_s = "-"
            if cfg.harm:
                t0 = time.perf_counter()
                xl = enccal.paper_truth(n, 37.3, start=0.11)
                al, bl = encsig.adc_codes(xl, with_spec(spec, seed=spec.seed + 100))
                pl = interp.run(al, bl, None, cfg, cal_en=cal).pos
                kw = {"harm_table": angle.harmonic_fit(pl[n // 2:], cfg.lut_bits,
                                                       cfg.harm_log2), "harm_en": True}
                learn_s = f"{time.perf_counter() - t0:.3f}"
            t0 = time.perf_counter()
            out = interp.run(a, b, None, cfg, cal_en=cal, **kw)  # type: ignore[arg-type]
            runs = [("model", out.pos, time.perf_counter() - t0, "-")]
            if cfg.ratio:
                r = native.run_interp(a, b, None, cfg, columns=native.COLUMNS, cal_en=cal,
                                      **kw)  # type: ignore[arg-type]
                bad = np.count_nonzero(np.any(np.stack(
                    [r.axis(0)[c] != native.model_matrix(out)[c] for c in native.COLUMNS]), 0))
                runs.append(("rtl (native)", r.axis(0)["pos"], r.seconds, bad))
            for engine, pos, t, mism in runs:
                d, _ = _errors(pos, x, cfg, start)
                rows.append([mode, cfg.counts_per_line, label, engine, n, f"{t:.3f}", learn_s,
                             f"{np.sqrt(np.mean(d * d)):.4f}", f"{np.abs(d).max():.4f}", mism])
    return rows


def angle_resources() -> list[list[object]]:
    """One axis without calibration, per angle stage (Yosys synth_ice40 -dsp)."""
    rows: list[list[object]] = []
    for label, cfg in (("paper, ANGLE_REG=1", interp.InterpConfig(angle_reg=True)),
                       ("ratio 1024/line", interp.InterpConfig(ratio=True)),
                       ("ratio 4096/line, ANGLE_REG=1",
                        interp.InterpConfig(ratio=True, lut_bits=9, angle_reg=True)),
                       ("ratio 1024/line + harmonic", interp.InterpConfig(ratio=True, harm=True))):
        f = flow.synth(blocks.get("enc_interp"), cfg.rtl_params(), "ice40",
                       tag=f"angle{int(cfg.ratio)}{cfg.lut_bits}{int(cfg.angle_reg)}"
                           f"{int(cfg.harm)}")
        r = f.resources
        ffs = sum(v for k, v in r.items() if k.startswith("SB_DFF"))
        rows.append([label, r.get("cells", "?"), r.get("SB_LUT4", "?"), ffs,
                     r.get("SB_MAC16", 0), r.get("SB_RAM40_4K", 0), f"{f.seconds:.1f}"])
    return rows


def run(quick: bool) -> bool:
    t0 = time.perf_counter()
    rows = sweep(quick)
    print("== encoder calibration: imperfection sweep, error against run time (electrical "
          "degrees, from 200 lines of travel on; mean offset removed) ==")
    print(table(SWEEP_HEADERS, rows))
    print(f"csv: {write_csv('bench_calib_sweep.csv', SWEEP_HEADERS, rows)}")
    res = resources()
    print("\n== encoder calibration: resources of one axis (Yosys synth_ice40 -dsp) ==")
    print(table(RES_HEADERS, res))
    print(f"csv: {write_csv('bench_calib_resources.csv', RES_HEADERS, res)}")
    ang = angle_sweep(quick)
    print("\n== angle stage: paper / calib / calib + ratio, error against run time (electrical "
          "degrees, from 200 lines of travel on; mean offset removed) ==")
    print(table(ANGLE_HEADERS, ang))
    print(f"csv: {write_csv('bench_angle_sweep.csv', ANGLE_HEADERS, ang)}")
    ares = angle_resources()
    print("\n== angle stage: resources of one axis, no calibration (Yosys synth_ice40 -dsp) ==")
    print(table(RES_HEADERS, ares))
    print(f"csv: {write_csv('bench_angle_resources.csv', RES_HEADERS, ares)}")
    print(f"(calibration bench: {time.perf_counter() - t0:.1f} s)")
    return all(r[-1] in ("-", 0) for r in rows + ang)


__all__ = ["run", "sweep", "resources"]
