"""What `hapgate sweep` prints and plots from a sweep's records (the reporting: not part of a
job, so not in the cache key): the Z-width K_max table and map, the soak's totals, the
Monte-Carlo histogram. Works on records from a run or read back from a results.csv."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..device import zwidth


def _pos(r: dict[str, Any]) -> str:
    return str(r.get("position") or "interpolated")


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
                    "m_eff": float(sel[0]["m_eff_kg"])})
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
    fig.savefig(path, dpi=120)
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


def calib_plot(rows: list[dict[str, Any]], path: Any) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4))
    for mode in sorted({str(r["calibration"]) for r in rows}):
        v = [float(r["err_rms_elec_deg"]) for r in rows if str(r["calibration"]) == mode]
        ax.hist(v, bins=50, alpha=0.6, label=f"calibration {mode} ({len(v)} sets)")
    ax.set_xlabel("RMS error after convergence, electrical degrees")
    ax.set_ylabel("imperfection sets")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
