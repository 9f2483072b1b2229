"""`hapgate bringup PORT`: run the firmware's bring-up steps over the PC link (dsp-fw/README.md,
"Bring-up"; docs/bringup.md), print every measured value beside its threshold with PASS/FAIL and
each step's device time, and write DIR/bringup.json, the plots, a one-page report and
calibration.toml (`--apply` sends it with SET_CALIB).

Exit codes: 0 every check passes, 1 a check or a step fails, 2 bad arguments or a device that
does not answer. The same command runs on the virtual device (`hapgate device serve`) and on a
board: everything it shows comes from the device's own results (BU_RESULT, BU_CHECK)."""

from __future__ import annotations

import argparse
import html
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..base.paths import BUILD
from ..golden import calib, capture, encquality, kinematics, pclink
from ..host import api

STEPS = ("align", "homing", "guided", "encoder", "dynamics")
DEFAULT_DIRECTION = (1.0, -1.0, 0.0)     # +x -y: every joint turns (docs/bringup.md)
DEFAULT_REF_POSE_DEG = (4.0, 46.0, 43.0)  # the linkage's rest pose (hapgate.device.scene)
AMP_A_PER_V = 0.8                         # amplifier gain (dsp-fw README: 8 A at 10 V)
POLL_S = 0.05                             # progress polls: well inside the 250 ms link timeout
EXPECT_SHARE = 0.3                        # a joint is watched if it turns >= 30 % of the most
REST_SPEED, REST_S, REST_MAX_S = 2e-3, 0.3, 10.0   # m/s, s, s: the handle at rest after the move


class BringupError(Exception):
    """Bad arguments (exit 2)."""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("port", metavar="PORT", help="serial port or pyserial URL of the device")
    p.add_argument("--steps", default=",".join(STEPS),
                   help=f"comma-separated, in this order: {','.join(STEPS)} (default: all)")
    p.add_argument("--out", default=str(BUILD / "bringup"), metavar="DIR",
                   help="output folder (default build/bringup/)")
    p.add_argument("--apply", action="store_true",
                   help="send the calibration found to the device (SET_CALIB)")
    p.add_argument("--direction", default=",".join(f"{v:g}" for v in DEFAULT_DIRECTION),
                   metavar="DX,DY,DZ", help="the guided move's direction (default 1,-1,0)")
    p.add_argument("--ref-pose-deg", default=",".join(f"{v:g}" for v in DEFAULT_REF_POSE_DEG),
                   metavar="A,B,G", help="the reference pose the handle rests in at power-up")
    p.add_argument("--seed", type=int, default=1, help="identification excitation seed")
    p.add_argument("--timeout", type=float, default=5.0,
                   help="seconds to wait for the device's first answer")


def _floats(text: str, n: int, what: str) -> tuple[float, ...]:
    try:
        v = tuple(float(x) for x in text.split(","))
    except ValueError:
        raise BringupError(f"{what} {text!r}: expected {n} comma-separated numbers") from None
    if len(v) != n or not all(math.isfinite(x) for x in v):
        raise BringupError(f"{what} {text!r}: expected {n} finite comma-separated numbers")
    return v


def parse_steps(text: str) -> tuple[str, ...]:
    steps = tuple(s.strip() for s in text.split(",") if s.strip())
    bad = [s for s in steps if s not in STEPS]
    if bad or not steps or len(set(steps)) != len(steps):
        raise BringupError(f"--steps {text!r}: expected distinct names among {','.join(STEPS)}")
    return tuple(s for s in STEPS if s in steps)


def guided_expect(direction: tuple[float, ...], q_ref_deg: tuple[float, ...]) -> tuple[int, ...]:
    """The joint sign each joint turns by when the handle moves along `direction` from the
    reference pose (0: turns too little to be watched)."""
    d = np.asarray(direction, dtype=float)
    if not np.linalg.norm(d) > 0:
        raise BringupError("--direction: a non-zero vector")
    jac = kinematics.jacobian(np.deg2rad(np.asarray(q_ref_deg, dtype=float)))
    dq = np.linalg.solve(jac, d / np.linalg.norm(d))
    big = np.abs(dq) >= EXPECT_SHARE * np.max(np.abs(dq))
    return tuple(int(np.sign(x)) if b else 0 for x, b in zip(dq, big))


def run_step(dev: api.Device, step: str, axis: int, expect: tuple[int, ...] = (0, 0, 0),
             seed: int = 1) -> dict[str, Any]:
    """Start one step and follow it to its end; the step's record (wall_s: the PC's time)."""
    t0 = time.perf_counter()
    rc, v, lim = dev.bu_start(pclink.BU_STEPS[step], axis, expect, seed)
    if rc != 0:
        return {"step": step, "axis": axis, "err": pclink.BU_ERRORS[rc], "value": v,
                "limit": lim, "started": False, "duration_s": 0.0}
    while True:
        p = dev.bu_progress()
        if p["state"] == "IDLE":
            break
        time.sleep(POLL_S)
    dur = (dev.bu_result(axis, 4)[4] if step == "encoder"
           else dev.bu_result(axis, 1)[4 + 6 + pclink.BU_STEPS[step]])
    return {"step": step, "axis": axis, "err": p["err"], "value": p["value"],
            "limit": p["limit"], "started": True, "duration_s": float(dur),
            "wall_s": time.perf_counter() - t0}


def wait_at_rest(dev: api.Device, out: Any) -> float:
    """After the guided move: wait until the operator has let go and the handle rests (its
    speed below REST_SPEED over REST_S of device time, at most REST_MAX_S). Device seconds."""
    print("guided: let go of the handle", file=out, flush=True)
    s0 = dev.state()
    quiet_since = None
    while True:
        s = dev.state()
        t = (s.seq - s0.seq) / dev.servo_hz
        if float(np.linalg.norm(s.v)) >= REST_SPEED:
            quiet_since = None
        elif quiet_since is None:
            quiet_since = t
        if (quiet_since is not None and t - quiet_since >= REST_S) or t >= REST_MAX_S:
            return t
        time.sleep(POLL_S)


def _axis_record(dev: api.Device, axis: int) -> dict[str, Any]:
    r0 = dev.bu_result(axis, 0)
    r1 = dev.bu_result(axis, 1)
    r3 = dev.bu_result(axis, 3)
    cal = dev.bu_result(axis, 2)[0]
    flags = r0[2]
    i2z = int(cal.index_to_zero_counts)
    # the index's joint angle, in the plant's convention (hapgate.golden.calib.truth)
    qi = (-i2z if cal.encoder_dir > 0 else i2z - calib.QUARTER_LINE) * 360.0 / calib.COUNTS_PER_REV
    checks = []
    n = dev.bu_check(axis, 0)["count"]
    for k in range(n):
        c = dev.bu_check(axis, k)
        if c["done"]:
            checks.append({"name": c["name"], "value": c["value"], "limit": c["limit"],
                           "unit": c["unit"], "op": ">=" if c["ge"] else "<=",
                           "result": "PASS" if c["pass"] else "FAIL"})
    return {
        "homed": bool(cal.homed), "aligned": bool(cal.aligned),
        "index_q_deg": qi if cal.homed else None,
        "index_to_zero_counts": i2z if cal.homed else None,
        "comm_offset_elec_deg": float(cal.comm_offset_elec_deg) if cal.aligned else None,
        "phases_swapped": bool(cal.phases_swapped) if cal.aligned else None,
        "encoder_dir": int(cal.encoder_dir), "dir_confirmed": bool(cal.dir_confirmed),
        "pole_pairs": int(cal.pole_pairs),
        "refused": bool(flags & 16),
        "scan": {"scan_sign": int(r0[3]), "counts_per_elec": r0[6],
                 "counts_per_elec_cfg": r0[7], "pole_pairs_measured": r0[8],
                 "movement_elec_deg": r0[11], "home_travel_rad": r0[15],
                 "guided_move_rad": r0[16], "guided_wait_s": r0[17]},
        "encoder": None,   # the encoder step fills it (bringup())
        "dynamics": ({"inertia_kg_m2": r1[4], "b_visc_nms": r1[5], "tau_coulomb_nm": r1[6],
                      "tau_gravity_nm": r1[7], "kt_nm_per_a": r1[8] / AMP_A_PER_V,
                      "residual": r1[9], "pose_q_rad": [float(x) if np.isfinite(x) else None
                                                     for x in r3[4:7]],
                      "hold_excursion_rad": r3[7], "lag_s": r3[8],
                      "std_err": dict(zip(("inertia_kg_m2", "b_visc_nms", "tau_coulomb_nm",
                                           "tau_gravity_nm"), r3[9:13]))}
                     if any(c["name"] == "ident_residual" for c in checks)
                     else None),
        "checks": checks,
        "calib": cal,
    }


def _fmt(v: float | str) -> str:
    return v if isinstance(v, str) else f"{v:.4g}"


def print_step(rec: dict[str, Any], checks: list[dict[str, Any]], out: Any) -> None:
    head = f"axis {rec['axis']} {rec['step']:<8}" if rec["step"] != "guided" else "guided       "
    state = "OK" if rec["err"] == "OK" else f"ERROR {rec['err']}"
    if rec["err"] != "OK" and (rec["value"] or rec["limit"]):
        state += f" ({_fmt(rec['value'])} beside limit {_fmt(rec['limit'])})"
    if not rec["started"]:
        state = f"REFUSED {rec['err']}" + (f" ({_fmt(rec['value'])} beside limit "
                                            f"{_fmt(rec['limit'])})" if rec["value"] or rec["limit"]
                                            else "")
    if rec["err"] == "POLE_PAIRS" and "scan" in rec:
        sc = rec["scan"]
        state += (f": {sc['counts_per_elec']:.0f} counts per electrical cycle measured "
                  f"({sc['pole_pairs_measured']:.2f} pole pairs), {sc['counts_per_elec_cfg']:.0f} "
                  f"configured ({calib.COUNTS_PER_REV / sc['counts_per_elec_cfg']:.0f} pole pairs)")
    print(f"{head} device time {rec['duration_s']:7.3f} s  {state}", file=out)
    for c in checks:
        print(f"    {c['name']:<30} {_fmt(c['value']):>10} {c['unit']:<9} {c['op']} "
              f"{_fmt(c['limit']):<8} {c['result']}", file=out)


def print_fpga_cal(e: dict[str, Any], out: Any) -> None:
    c = e["fpga_cal"]
    amp = ("-" if c["amp_a"] is None else f"{c['amp_a']:.4g}/{c['amp_b']:.4g}")
    print(f"    capture: {e['entries']} samples, one in {e['decim'] + 1} at "
          f"{e['sample_hz']:.4g} Hz, {e['lines']:.2f} lines at {e['speed_rad_s']:.3g} rad/s",
          file=out)
    print(f"    FPGA online calibration: EN {int(c['en'])} FREEZE {int(c['freeze'])} "
          f"GEAR {c['gear']}: offsets {c['offset_a']:.4g}/{c['offset_b']:.4g} codes, "
          f"gains {c['gain_a']:.4g}/{c['gain_b']:.4g} (amp {amp} codes), "
          f"phase share {c['phase_share']:.4g}", file=out)


def _step_checks(dev: api.Device, rec: dict[str, Any]) -> list[dict[str, Any]]:
    if rec["step"] == "encoder":
        return rec.get("enc_checks", [])
    prefix = {"align": "align_", "homing": "home_", "guided": "guided_",
              "dynamics": "ident_"}[rec["step"]]
    axes = range(3) if rec["step"] == "guided" else [rec["axis"]]
    out = []
    for a in axes:
        n = dev.bu_check(a, 0)["count"]
        for k in range(n):
            c = dev.bu_check(a, k)
            if c["done"] and c["name"].startswith(prefix) and rec["started"]:
                out.append({"name": (f"axis{a}." if rec["step"] == "guided" else "") + c["name"],
                            "value": c["value"], "limit": c["limit"], "unit": c["unit"],
                            "op": ">=" if c["ge"] else "<=",
                            "result": "PASS" if c["pass"] else "FAIL"})
    return out


# ---------------------------------------------------------------- the encoder step
ENC_PREFIX = "enc_"


def fpga_cal(words: tuple[int, ...]) -> dict[str, Any]:
    """The axis's online encoder calibration registers (rtl/regs/REGISTERS.md, CAL_*), decoded:
    EN, FREEZE, MU, GEAR, UPDATES; the offsets in ADC codes, the gains, the phase share, and
    the amplitude the gain implies (the corrected amplitude is 127 codes)."""
    ctrl, stat, ofs, gain, phase = words

    def s16(x: int) -> int:
        return x - (1 << 16) if x & 0x8000 else x

    ga, gb = (gain & 0xFFFF) / 2 ** 14, (gain >> 16) / 2 ** 14
    return {"en": bool(ctrl & 1), "freeze": bool(ctrl & 2), "mu": (ctrl >> 4) & 0xF,
            "gear": stat & 0xFF, "updates": stat >> 16,
            "offset_a": s16(ofs & 0xFFFF) / 16, "offset_b": s16(ofs >> 16) / 16,
            "gain_a": ga, "gain_b": gb, "phase_share": s16(phase & 0xFFFF) / 2 ** 14,
            "amp_a": encquality.FULL_SCALE / ga if ga else None,
            "amp_b": encquality.FULL_SCALE / gb if gb else None}


def encoder_result(dev: api.Device, axis: int, rec: dict[str, Any]) -> dict[str, Any] | None:
    """After an ENCODER step: read its capture over the link (CAP_READ), compute the signal
    quality (hapgate.golden.encquality) and the checks; None (the step's error set) when the
    capture cannot be analysed."""
    r4 = dev.bu_result(axis, 4)
    captured, decim, entries, speed, sample_hz = bool(r4[2]), r4[5], r4[6], r4[7], r4[8]
    info = {"decim": int(decim), "entries": int(entries), "speed_rad_s": float(speed),
            "sample_hz": float(sample_hz), "fpga_cal": fpga_cal(tuple(r4[9:14]))}
    if not captured:
        rec["err"] = "CAPTURE"
        return None
    words = np.asarray(dev.cap_read(0, int(entries)), np.int64)
    a, b = capture.unpack(words, axis)
    info["a"], info["b"] = a, b
    try:
        q = encquality.analyse(a, b)
    except ValueError as exc:
        rec["err"] = "ANALYSIS"
        rec["why"] = str(exc)
        return None
    info["quality"] = q
    info["lines"] = q.cycles
    rec["enc_checks"] = [{"name": ENC_PREFIX + c.name, "value": c.value, "limit": c.limit,
                          "unit": c.unit, "op": "in", "result": c.result}
                         for c in encquality.checks(q)]
    return info


def write_lissajous(out: Path, encs: list[dict[str, Any] | None]) -> list[str]:
    """Per captured axis, lissajous_axisN.png: B against A (ADC codes), the fitted offsets and
    the fundamental's ellipse."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = []
    for i, e in enumerate(encs):
        if not e or "quality" not in e:
            continue
        q = e["quality"]
        fig, ax = plt.subplots(figsize=(4.2, 4.2))
        ax.plot(e["a"], e["b"], ".", ms=2, label="captured")
        t = np.linspace(0.0, 2 * np.pi, 200)
        d = np.deg2rad(q.phase_deg)
        ax.plot(q.offset_a + q.amp_a * np.sin(t), q.offset_b + q.amp_b * np.cos(t + d), "-",
                lw=1, label="fundamental")
        ax.plot([q.offset_a], [q.offset_b], "+", ms=10, label="offsets")
        ax.set_aspect("equal")
        ax.set_xlim(-128, 127)
        ax.set_ylim(-128, 127)
        ax.set_xlabel("A (ADC codes)")
        ax.set_ylabel("B (ADC codes)")
        ax.set_title(f"axis {i}: amp {q.amp_a:.1f}/{q.amp_b:.1f}, h2 {q.h2_pct:.2f} %, "
                     f"h3 {q.h3_pct:.2f} %", fontsize=8)
        ax.legend(fontsize=7, loc="lower right")
        fig.tight_layout()
        name = f"lissajous_axis{i}.png"
        fig.savefig(out / name, dpi=90)
        plt.close(fig)
        names.append(name)
    return names


def _encoder_html(doc: dict[str, Any]) -> str:
    """The encoder table: each metric per axis, the FPGA's online calibration beside it."""
    axes = doc["axes"]
    if not any(a.get("encoder") for a in axes):
        return ""
    rows = []
    beside = {"amp_a": "amp_a", "amp_b": "amp_b", "offset_a": "offset_a", "offset_b": "offset_b"}
    for k in ("amp_a", "amp_b", "ratio", "offset_a", "offset_b", "phase_deg", "h2_pct", "h3_pct",
              "radius_spread_pct"):
        cells = []
        for a in axes:
            e, c = a.get("encoder"), a.get("encoder_capture")
            if not e:
                cells.append("<td>-</td><td></td>")
                continue
            f = c["fpga_cal"].get(beside.get(k, ""), None) if c else None
            cells.append(f"<td>{e[k]:.4g}</td><td>{'' if f is None else f'{f:.4g}'}</td>")
        rows.append(f"<tr><th>{k}</th>{''.join(cells)}</tr>")
    extra = "".join(
        f"<tr><th>FPGA CAL {k}</th>" + "".join(
            f"<td colspan=2>{html.escape(str(a['encoder_capture']['fpga_cal'][k]))}</td>"
            if a.get("encoder_capture") else "<td colspan=2>-</td>" for a in axes) + "</tr>"
        for k in ("en", "freeze", "mu", "gear", "updates", "gain_a", "gain_b", "phase_share"))
    head = "".join(f"<th>axis {i}</th><th>FPGA CAL</th>" for i in range(len(axes)))
    return (f"<h2>Encoder signals</h2><table><tr><th></th>{head}</tr>{''.join(rows)}{extra}"
            "</table>")



def write_plots(out: Path, axes: list[dict[str, Any]]) -> list[str]:
    """The alignment scan (the fitted count-against-field line beside the configured one, the
    offset found) and the identification (the fitted model's torque response)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = []
    fig, ax = plt.subplots(1, 3, figsize=(12, 3.6))
    for i, a in enumerate(axes):
        s = a["scan"]
        x = np.linspace(0.0, 1.0, 50)           # electrical cycles of field
        if s["counts_per_elec"]:
            ax[i].plot(x, s["scan_sign"] * s["counts_per_elec"] * x, label="fitted")
        ax[i].plot(x, s["counts_per_elec_cfg"] * x, "--", label="configured pole pairs")
        off = a["comm_offset_elec_deg"]
        ax[i].set_title(f"axis {i}: offset {off:.1f} deg elec" if off is not None
                        else f"axis {i}: not aligned")
        ax[i].set_xlabel("field angle (electrical cycles)")
        ax[i].set_ylabel("counts")
        ax[i].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "alignment_scan.png", dpi=90)
    plt.close(fig)
    names.append("alignment_scan.png")
    fig, ax = plt.subplots(figsize=(6, 3.6))
    f = np.logspace(-1, 2, 200)
    w = 2 * np.pi * f
    for i, a in enumerate(axes):
        d = a["dynamics"]
        if d:
            g = 1.0 / np.abs(-d["inertia_kg_m2"] * w ** 2 + 1j * w * d["b_visc_nms"])
            ax.loglog(f, g, label=f"axis {i}: J {d['inertia_kg_m2']:.3g}, b {d['b_visc_nms']:.3g}")
    ax.set_xlabel("Hz")
    ax.set_ylabel("|position / torque| (rad/N m)")
    ax.set_title("identified dynamics")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "identification.png", dpi=90)
    plt.close(fig)
    names.append("identification.png")
    return names


def write_report(out: Path, doc: dict[str, Any], plots: list[str]) -> None:
    rows = []
    for i, a in enumerate(doc["axes"]):
        for c in a["checks"]:
            rows.append(f"<tr><td>{i}</td><td>{html.escape(c['name'])}</td><td>{c['value']:.4g}"
                        f"</td><td>{c['op']} {html.escape(_fmt(c['limit']))}</td>"
                        f"<td>{html.escape(c['unit'])}"
                        f"</td><td class={c['result']}>{c['result']}</td></tr>")
    keys = ("homed", "index_q_deg", "index_to_zero_counts", "comm_offset_elec_deg",
            "phases_swapped", "encoder_dir", "dir_confirmed", "pole_pairs")
    vals = "".join(f"<tr><th>{k}</th>" + "".join(f"<td>{html.escape(str(a[k]))}</td>"
                                                 for a in doc["axes"]) + "</tr>" for k in keys)
    steps = "".join(f"<tr><td>{html.escape(str(s['axis']))}</td><td>{s['step']}</td>"
                    f"<td>{s['duration_s']:.3f}</td><td>{html.escape(s['err'])}</td></tr>"
                    for s in doc["steps"])
    imgs = "".join(f'<img src="{p}" style="max-width:100%">' for p in plots)
    (out / "report.html").write_text(f"""<!doctype html><html><head><meta charset="utf-8">
<title>hapgate bring-up</title><style>body{{font:13px sans-serif;margin:1em}}
td,th{{padding:1px 6px;border-bottom:1px solid #ddd}}.PASS{{color:#080}}.FAIL{{color:#c00}}
</style></head><body><h1>Bring-up: {doc['result']}</h1>
<p>device time {doc['duration_s']:.2f} s</p>
<h2>Found</h2><table><tr><th></th><th>axis 0</th><th>axis 1</th><th>axis 2</th></tr>{vals}</table>
<h2>Steps</h2><table><tr><th>axis</th><th>step</th><th>device s</th><th>end</th></tr>{steps}</table>
<h2>Checks</h2><table><tr><th>axis</th><th>check</th><th>value</th><th>limit</th><th>unit</th>
<th></th></tr>{''.join(rows)}</table>{_encoder_html(doc)}{imgs}</body></html>
""", encoding="utf-8")


def bringup(dev: api.Device, steps: tuple[str, ...], expect: tuple[int, ...], seed: int,
            out: Any = None) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Run the steps, printing to out (default stdout); (step records, axis records)."""
    out = sys.stdout if out is None else out
    recs = []
    encs: list[dict[str, Any] | None] = [None, None, None]
    # The guided move first, while the handle still rests in the reference pose: there the
    # named direction turns each joint by the signs `expect` gives (the firmware needs nothing
    # before it, and the later steps use the direction it found). Then alignment and homing
    # axis by axis: the joints left free drift while another axis moves (the linkage couples
    # them), so each axis homes right after its scan walked it back to the reference pose,
    # where the search window is centred.
    plan = [("guided", -1, expect)] if "guided" in steps else []
    plan += [(step, a, (0, 0, 0)) for a in range(3) for step in ("align", "homing", "encoder")
             if step in steps]
    plan += [("dynamics", a, (0, 0, 0)) for a in range(3) if "dynamics" in steps]
    for step, axis, ex in plan:
        if step == "guided":
            print(f"guided: move the handle along the named direction now "
                  f"(joint signs {list(expect)})", file=out, flush=True)
        rec = run_step(dev, step, max(axis, 0), ex, seed)
        if step == "guided":
            rec["axis"] = "all"
        if step == "encoder":
            encs[axis] = encoder_result(dev, axis, rec) if rec["started"] else None
        rec["checks"] = _step_checks(dev, {**rec, "axis": max(axis, 0)})
        if rec["err"] == "POLE_PAIRS":
            r0 = dev.bu_result(rec["axis"], 0)
            rec["scan"] = {"counts_per_elec": r0[6], "counts_per_elec_cfg": r0[7],
                           "pole_pairs_measured": r0[8]}
        print_step(rec, rec["checks"], out)
        if step == "encoder" and encs[axis]:
            print_fpga_cal(encs[axis], out)
        elif step == "encoder" and rec.get("why"):
            print(f"    the capture cannot be analysed: {rec['why']}", file=out)
        recs.append(rec)
        if step == "guided" and rec["started"]:
            wait_at_rest(dev, out)
    axes = [_axis_record(dev, a) for a in range(3)]
    for i, (a, e) in enumerate(zip(axes, encs)):
        if e and "quality" in e:
            a["encoder"] = e["quality"].as_dict()
            a["encoder_capture"] = {k: e[k] for k in ("decim", "entries", "lines", "speed_rad_s",
                                                      "sample_hz", "fpga_cal")}
            a["encoder_samples"] = (e["a"], e["b"])
            a["checks"] += next(r["checks"] for r in recs
                                if r["step"] == "encoder" and r["axis"] == i)
    return recs, axes


def main(args: argparse.Namespace) -> int:
    try:
        steps = parse_steps(args.steps)
        direction = _floats(args.direction, 3, "--direction")
        q_ref = _floats(args.ref_pose_deg, 3, "--ref-pose-deg")
        expect = guided_expect(direction, q_ref)
    except BringupError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    out = Path(args.out)
    try:
        dev = api.Device.open(args.port, open_timeout=args.timeout)
    except api.HapticError as exc:
        print(f"error: {args.port}: the device does not answer: {exc}", file=sys.stderr)
        return 2
    try:
        with dev:
            recs, axes = bringup(dev, steps, expect, args.seed)
            cals = [a.pop("calib") for a in axes]
            samples = [a.pop("encoder_samples", None) for a in axes]
            steps_ok = all(r["err"] == "OK" for r in recs)
            checks_ok = all(c["result"] == "PASS" for a in axes for c in a["checks"])
            ok = steps_ok and checks_ok and not any(a["refused"] for a in axes)
            doc = {"result": "PASS" if ok else "FAIL",
                   "duration_s": float(sum(r["duration_s"] for r in recs)),
                   "steps": [{k: r[k] for k in ("step", "axis", "err", "value", "limit",
                                                "duration_s", "checks")} for r in recs],
                   "axes": axes}
            out.mkdir(parents=True, exist_ok=True)
            (out / "bringup.json").write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
            (out / "calibration.toml").write_text(calib.dumps(cals), encoding="utf-8")
            if any(sm is not None for sm in samples):
                np.savez(out / "encoder_capture.npz", **{
                    f"{ch}{i}": sm[k] for i, sm in enumerate(samples) if sm is not None
                    for k, ch in enumerate("ab")})
            plots = write_plots(out, axes)
            plots += write_lissajous(out, [
                {"a": sm[0], "b": sm[1], "quality": encquality.Quality(
                    **a["encoder"], cycles=a["encoder_capture"]["lines"])} if sm else None
                for a, sm in zip(axes, samples)])
            write_report(out, doc, plots)
            if args.apply:
                if not all(c.homed and c.aligned for c in cals):
                    print("apply: refused: not every axis is homed and aligned", file=sys.stderr)
                    ok = False
                else:
                    for a, c in enumerate(cals):
                        dev.set_calib(a, c)
                    print("applied: calibration.toml sent with SET_CALIB")
    except api.HapticError as exc:
        print(f"error: {args.port}: {exc}", file=sys.stderr)
        return 2
    print(f"bring-up {doc['result']} in {doc['duration_s']:.2f} s device time; wrote {out}/")
    return 0 if ok else 1
