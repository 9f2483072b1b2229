"""What `hapgate sweep` prints and plots from a sweep's records (the reporting: not part of a
job, so not in the cache key): the Z-width K_max table and map, the soak's totals, the
Monte-Carlo histogram. Works on records from a run or read back from a results.csv."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..base.report import save_figure
from ..device import calib_mc, seu, zwidth


def _pos(r: dict[str, Any]) -> str:
    """The configuration's name: the position source, then what differs from the base
    configuration: the velocity when not the FIR, the hand when not the light one, the current
    loop when not 2 kHz, a link compliance (records from before an axis have none: its
    default)."""
    parts = [str(r.get("position") or "interpolated")]
    if str(r.get("velocity") or "fir") != "fir":
        parts.append(str(r["velocity"]))
    if str(r.get("hand") or "light") != "light":
        parts.append(f"{r['hand']} hand")
    if float(r.get("current_bw_hz") or 2000.0) != 2000.0:
        parts.append(f"{float(r['current_bw_hz']) / 1e3:g} kHz amplifier")
    if float(r.get("link_k") or 0.0):
        parts.append(f"link {float(r['link_k']):g} N m/rad")
    return ", ".join(parts)


def kmax_table(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """K_max per (servo rate, B): the largest K of a stable run below which every K is stable."""
    out = []
    for (pos, hz, bw) in sorted({(_pos(r), int(r["servo_hz"]), float(r["b_wall"]))
                                 for r in rows}):
        sel = sorted((r for r in rows if int(r["servo_hz"]) == hz and _pos(r) == pos and
                      float(r["b_wall"]) == bw), key=lambda r: float(r["k"]))
        kmax = 0.0
        for r in sel:
            if not r["stable"]:
                break
            kmax = float(r["k"])
        first_bad = next((float(r["k"]) for r in sel if not r["stable"]), math.inf)
        out.append({"position": pos, "servo_hz": hz, "b_wall": bw, "k_max": kmax,
                    "k_first_unstable": first_bad, "b_phys": float(sel[0]["b_phys_nsm"]),
                    "m_eff": float(sel[0]["m_eff_kg"]),
                    "tau_s": float(sel[0].get("tau_s") or zwidth.TAU_LOOP_S)})
    return out


def impact_table(rows: list[dict[str, Any]]) -> list[list[str]]:
    """The impact runs (zwidth test = "impact"): rate-hardness and the static F/x beside the
    virtual K, per servo rate and K."""
    def f(x: Any, fmt: str) -> str:
        v = float(x) if x not in (None, "") else math.nan
        return "-" if not math.isfinite(v) else format(v, fmt)
    out = []
    for r in sorted(rows, key=lambda r: (int(r["servo_hz"]), float(r["k"]), float(r["b_wall"]))):
        k = float(r["k"])
        out.append([str(r["servo_hz"]), f(k, ".0f"), f(r["b_wall"], "g"), f(r["v_contact"], ".3f"),
                    f(r["rate_hardness"], ".0f"), f(float(r["rate_hardness"]) / k, ".2f"),
                    f(r["k_static"], ".0f"), f(float(r["k_static"]) / k, ".3f")])
    return out


def zwidth_plot(rows: list[dict[str, Any]], path: Any) -> None:
    """The Z-width map: per configuration (position, servo rate) the K_max boundary over B
    (filled markers: K_max; the run above it was unstable), the stable runs as small dots,
    and the bounds 2(b - |B|)/T (ideal) and (b - |B|)/(T/2 + tau) (with the loop's latency)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8, 5.5))
    confs = sorted({(_pos(r), int(r["servo_hz"])) for r in rows})
    style = {("interpolated", 1000): ("o", "tab:blue"), ("interpolated", 10000): ("s", "tab:red"),
             ("interpolated, observer", 1000): ("v", "tab:orange"),
             ("interpolated, observer", 10000): ("P", "tab:brown"),
             ("quadrature", 1000): ("^", "tab:green"), ("quadrature", 10000): ("D", "tab:purple")}
    off = {c: 1.0 + 0.06 * (i - (len(confs) - 1) / 2) for i, c in enumerate(confs)}
    for conf in confs:
        pos, hz = conf
        mk, col = style.get(conf, ("x", "tab:gray"))
        sel = [r for r in rows if int(r["servo_hz"]) == hz and _pos(r) == pos]
        st = [r for r in sel if r["stable"]]
        ax.scatter([max(float(r["b_wall"]), 0.03) * off[conf] for r in st],
                   [float(r["k"]) for r in st], marker=".", s=10, color=col, alpha=0.5)
        tab = kmax_table(sel)
        ax.plot([max(t["b_wall"], 0.03) for t in tab], [max(t["k_max"], 60.0) for t in tab],
                marker=mk, color=col, lw=1.5, label=f"{pos}, {hz} Hz: K_max")
    bp = float(rows[0]["b_phys_nsm"])
    bs = np.geomspace(0.03, bp * 0.999, 40)
    for hz in sorted({c[1] for c in confs}):
        ax.plot(bs, [2 * (bp - x) * hz for x in bs], ls="--", color="k", lw=0.7)
        ax.plot(bs, [zwidth.latency_bound(bp, x, 1.0 / hz) for x in bs], ls="-.", color="k",
                lw=0.7)
        ax.annotate(f"{hz} Hz", (0.035, 2 * bp * hz), fontsize=7, va="bottom")
    ax.plot([], [], ls="--", color="k", lw=0.7, label="2(b-|B|)/T (passivity, ideal loop)")
    ax.plot([], [], ls="-.", color="k", lw=0.7, label="(b-|B|)/(T/2+tau), tau = 126 us")
    ax.axhline(3500, color="gray", ls=":", lw=1.0, label="35 N/cm (PHANToM-class target)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(0.025, 150)
    ax.set_ylim(60, 7e4)
    ax.set_xlabel("wall damping B, N s/m (B = 0 plotted at 0.03)")
    ax.set_ylabel("wall stiffness K, N/m")
    ax.set_title(f"Z-width: rtl gateware + firmware in the loop, axis beta, b = {bp:.2f} N s/m")
    ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


def soak_table(rows: list[dict[str, Any]], wall_s: float, workers: int) -> list[list[str]]:
    """The soak's totals as table rows."""
    tot = sum(int(r["samples"]) for r in rows)
    harness = sum(float(r["harness_s"]) for r in rows)
    gen = sum(float(r["gen_s"]) for r in rows)
    cpu = sum(float(r.get("cpu_s") or 0.0) for r in rows)      # (older records lack it)
    def s(k: str) -> int:
        return sum(int(r[k]) for r in rows)
    return [["jobs", str(len(rows))], ["ADC samples (3 axes)", f"{tot:.4g}"],
            ["wall time, s", f"{wall_s:.1f}"], ["workers", str(workers)],
            ["samples/s per worker (wall)", f"{tot / wall_s / max(workers, 1):.3g}"
             if wall_s > 0 else "-"],
            ["harness samples/s (RTL only)", f"{tot / harness:.3g}" if harness else "-"],
            ["stimulus generation, s (sum)", f"{gen:.1f}"],
            ["CPU s per 10^6 x 3 samples (shard cost)",
             f"{cpu / tot * 3e6:.2f}" if cpu else "-"],
            ["samples per CPU second", f"{tot / cpu:.3g}" if cpu else "-"],
            ["slips", str(s("slips"))], ["index latches checked", str(s("index_latches"))],
            ["index latch errors", str(s("index_latch_errors"))],
            ["max |pos - truth|, counts",
             f"{max(float(r['pos_err_max_counts']) for r in rows):.1f}"],
            ["segments below the limit", str(s("segments_below"))],
            ["false overspeed", str(s("false_overspeed"))],
            ["segments over 244.2 rev/s", str(s("segments_over"))],
            ["missed overspeed", str(s("missed_overspeed"))],
            ["peak clean speed, rev/s", f"{max(float(r['peak_clean_rev_s']) for r in rows):.3f}"],
            ["lowest noisy v_safe, rev/s",
             f"{min(float(r['v_safe_noisy_min_rev_s']) or math.inf for r in rows):.1f}"]]


PCTS = (5, 50, 95, 99)


def _f(rows: list[dict[str, Any]], key: str, status: str | None = None) -> np.ndarray:
    return np.array([float(r[key]) for r in rows if status is None or r["status"] == status])


def calib_tables(rows: list[dict[str, Any]]) -> dict[str, tuple[list[str], list[list[str]]]]:
    """The Monte-Carlo's tables (header, rows): percentiles of the error after convergence (off,
    on) and of the convergence distance; the sets per status; the error by harmonic level
    (what the calibration does not correct)."""
    n = len(rows)
    head = ["quantity", "sets", *[f"p{q}" for q in PCTS], "max"]
    pct: list[list[str]] = []
    for key, label in (("rms_off_deg", "RMS error, calibration off, deg el."),
                       ("rms_on_deg", "RMS error, calibration on, deg el."),
                       ("max_off_deg", "max error, calibration off, deg el."),
                       ("max_on_deg", "max error, calibration on, deg el.")):
        v = _f(rows, key)
        pct.append([label, str(v.size), *[f"{np.percentile(v, q):.3f}" for q in PCTS],
                    f"{v.max():.3f}"])
    conv = _f(rows, "convergence_lines", "converged")
    if conv.size:
        pct.append(["convergence distance (converged sets), lines", str(conv.size),
                    *[f"{np.percentile(conv, q):.0f}" for q in PCTS], f"{conv.max():.0f}"])
    st_rows = []
    for st in calib_mc.STATUSES:
        sel = [r for r in rows if r["status"] == st]
        on = _f(sel, "rms_on_deg")
        clip = _f(sel, "clip_frac")
        st_rows.append([st, str(len(sel)), f"{100 * len(sel) / max(n, 1):.2f} %",
                        f"{np.median(on):.3f}" if on.size else "-",
                        f"{np.median(_f(sel, 'rms_off_deg')):.3f}" if on.size else "-",
                        f"{100 * float(np.mean(clip > 0)):.0f} %" if clip.size else "-"])
    budget = [r for r in rows if float(r["rms_on_deg"]) <= 0.30 and float(r["max_on_deg"]) <= 1.3]
    harm: list[list[str]] = []
    hmax = np.array([max(float(r["h2"]), float(r["h3"])) for r in rows])
    for lo, hi in ((0.0, 0.005), (0.005, 0.01), (0.01, 0.015), (0.015, 0.0201)):
        sel = [r for r, h in zip(rows, hmax) if lo <= h < hi]
        if not sel:
            continue
        on = _f(sel, "rms_on_deg")
        ok = sum(float(r["rms_on_deg"]) <= 0.30 and float(r["max_on_deg"]) <= 1.3 for r in sel)
        harm.append([f"{100 * lo:.1f}..{100 * min(hi, 0.02):.1f} %", str(len(sel)),
                     f"{np.median(_f(sel, 'rms_off_deg')):.3f}", f"{np.median(on):.3f}",
                     f"{np.percentile(on, 95):.3f}", f"{100 * ok / len(sel):.1f} %"])
    return {"percentiles": (head, pct),
            "status": (["status", "sets", "share", "RMS on, median", "RMS off, median",
                        "sets that clip"], st_rows),
            "harmonics": (["max(h2, h3)", "sets", "RMS off, median", "RMS on, median",
                           "RMS on, p95", "within 0.30 deg RMS / 1.3 deg max"], harm),
            "budget": (["sets", "within 0.30 deg RMS and 1.3 deg max (issue 13's budget)"],
                       [[str(n), f"{len(budget)} ({100 * len(budget) / max(n, 1):.1f} %)"]])}


def calib_plot(rows: list[dict[str, Any]], path: Any) -> None:
    """Histograms: RMS and max error after convergence (off, on; log scale), the convergence
    distance, and the RMS on against the harmonic level (coloured by status)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axs = plt.subplots(2, 2, figsize=(10, 7.5))
    for ax, kind, label in ((axs[0, 0], "rms", "RMS"), (axs[0, 1], "max", "max")):
        allv = np.concatenate([_f(rows, f"{kind}_{m}_deg") for m in calib_mc.MODES])
        bins = np.geomspace(max(allv.min(), 1e-3) * 0.9, allv.max() * 1.1, 60)
        for m, col in (("off", "tab:red"), ("on", "tab:blue")):
            v = _f(rows, f"{kind}_{m}_deg")
            ax.hist(v, bins=bins, alpha=0.6, color=col,
                    label=f"calibration {m}: median {np.median(v):.2f}")
        ax.set_xscale("log")
        ax.set_xlabel(f"{label} error after convergence, electrical degrees")
        ax.set_ylabel("sets")
        ax.legend(fontsize=8)
    conv = _f(rows, "convergence_lines", "converged")
    ax = axs[1, 0]
    if conv.size:
        w = calib_mc.WINDOW_LINES            # distances are whole windows: bars centred on them
        ax.hist(conv, bins=np.arange(-w / 2, max(conv.max(), 4 * w) + w, w), color="tab:green")
    counts = {st: sum(r["status"] == st for r in rows) for st in calib_mc.STATUSES}
    ax.set_title(", ".join(f"{k}: {v}" for k, v in counts.items()), fontsize=8)
    ax.set_xlabel(f"convergence distance, lines of travel ({calib_mc.WINDOW_LINES}-line windows)")
    ax.set_ylabel("sets")
    ax = axs[1, 1]
    for st, col in zip(calib_mc.STATUSES, ("tab:blue", "tab:orange", "tab:red")):
        sel = [r for r in rows if r["status"] == st]
        if sel:
            ax.scatter([100 * max(float(r["h2"]), float(r["h3"])) for r in sel],
                       _f(sel, "rms_on_deg"), s=3, color=col, alpha=0.5, label=st)
    ax.axhline(0.30, color="gray", ls=":", lw=1, label="0.30 deg (issue 13)")
    ax.set_yscale("log")
    ax.set_xlabel("max(h2, h3), % of the fundamental")
    ax.set_ylabel("RMS error, calibration on, deg el.")
    ax.legend(fontsize=8, markerscale=3)
    fig.suptitle(f"Calibration Monte-Carlo: {len(rows)} imperfection sets, off and on")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


# ---------------------------------------------------------------------------------- seu
SEU_HEAD = ["runs", "bits", "masked %", "detected %", "latched %", "silent %",
            "viol.+latched %", "hang %", "dangerous", "SPFM %"]


def _seu_row(rows: list[dict[str, Any]], bits: int | str) -> list[str]:
    n = len(rows)
    cls = np.array([str(r["class"]) for r in rows])
    dang = int(sum(bool(r["dangerous"]) for r in rows))
    def pct(c: str) -> str:
        return f"{100 * float((cls == c).mean()):.1f}" if n else "-"
    return [str(n), str(bits), pct("masked"), pct("detected"), pct("latched"), pct("silent"),
            pct("violation_latched"), pct("hang"), str(dang),
            f"{100 * seu.spfm(dang, n):.2f}" if n else "-"]


def seu_plot(campaigns: dict[str, list[dict[str, Any]]], path: Any) -> None:
    """The injection campaigns side by side: per block (and all), the share of runs in each
    class as a stacked bar, one bar per campaign, with its SPFM; dangerous classes in red."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    colours = {"masked": "#9ecae1", "detected": "#31a354", "latched": "#a1d99b",
               "silent": "#de2d26", "violation_latched": "#fc9272", "hang": "#fdae6b"}
    blocks = sorted({str(r["block"]) for rows in campaigns.values() for r in rows}) + ["all"]
    names = list(campaigns)
    width = 0.8 / len(names)
    fig, ax = plt.subplots(figsize=(9, 4.8))
    for j, name in enumerate(names):
        rows = campaigns[name]
        left = np.zeros(len(blocks))
        for cls in seu.CLASSES:
            share = np.array([
                100.0 * sum(1 for r in sel if r["class"] == cls) / max(len(sel), 1)
                for sel in ([r for r in rows if b == "all" or r["block"] == b]
                            for b in blocks)])
            ax.barh(np.arange(len(blocks)) + (j - (len(names) - 1) / 2) * width, share,
                    width * 0.95, left=left, color=colours[cls],
                    label=cls.replace("_", " + ") if j == 0 else None,
                    hatch="//" if j else None, edgecolor="white", linewidth=0.3)
            left += share
        dang = sum(1 for r in rows if r["dangerous"])
        ax.annotate(f"{name}: SPFM {100 * seu.spfm(dang, len(rows)):.2f} % ({len(rows)} runs)",
                    (0.01, 0.97 - 0.06 * j), xycoords="axes fraction", fontsize=8, va="top")
    ax.set_yticks(np.arange(len(blocks)), blocks)
    ax.set_xlabel("share of runs, %  (bars: " + " / ".join(names) + ", hatched after the first)")
    ax.set_xlim(0, 100)
    ax.legend(fontsize=7, loc="lower right", ncol=3)
    ax.set_title("Fault injection: outcome per block")
    save_figure(fig, path)
    plt.close(fig)


def seu_tables(rows: list[dict[str, Any]], bits: dict[str, int] | None = None,
               registers: int = 20, worst: int = 10
               ) -> dict[str, tuple[list[str], list[list[str]]]]:
    """The campaign's tables (header, rows): per block, per register (the `registers` with
    the most dangerous runs; all of them in the CSV), the worst sites (the dangerous runs with
    the largest torque deviation, one per site, with the command that replays each)."""
    bits = bits or {}
    blocks = sorted({str(r["block"]) for r in rows})
    per_block = [[b, *_seu_row([r for r in rows if r["block"] == b], bits.get(b, "-"))]
                 for b in blocks]
    per_block.append(["all", *_seu_row(rows, sum(bits.values()) if bits else "-")])
    regs: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        regs.setdefault(str(r["register"]), []).append(r)
    reg_rows = sorted(([k, *_seu_row(v, "-")] for k, v in regs.items()),
                      key=lambda x: (-int(x[9]), -int(x[1]), x[0]))
    head_r = ["register", "runs", "masked %", "detected %", "latched %", "silent %",
              "viol.+latched %", "hang %", "dangerous", "SPFM %"]
    reg_rows = [[x[0], *x[1:2], *x[3:]] for x in reg_rows]
    dang = sorted((r for r in rows if r["dangerous"]),
                  key=lambda r: -float(r["max_dev_nm"]) if math.isfinite(
                      float(r["max_dev_nm"])) else -math.inf)
    seen: set[str] = set()
    worst_rows = []
    for r in dang:
        if r["site"] in seen:
            continue
        seen.add(str(r["site"]))
        worst_rows.append([str(r["site"]), str(r["class"]), str(r["mode"]),
                           f"{1e3 * float(r['at_s']):.4f}", str(int(r["frames"])),
                           f"{float(r['max_dev_nm']):.4f}", str(r["replay"])])
        if len(worst_rows) == worst:
            break
    return {"blocks": (["block", *SEU_HEAD], per_block),
            "registers": (head_r, reg_rows[:registers]),
            "registers_all": (head_r, reg_rows),
            "worst": (["site", "class", "mode", "at ms", "frames", "max dev N m", "replay"],
                      worst_rows)}
