"""What a scene run returns, how its [expect] checks are judged, and what is written out.

`RunResult` is filled by the closed-loop runner (`hapgate.device.runner.run`). `evaluate()`
judges the scene's `[expect]` table against the run's metrics: ``max_X`` passes when
``metrics[X] <= limit``, ``min_X`` when ``metrics[X] >= limit``, ``zero_torque_within_us`` when
``metrics["zero_torque_us"] <= limit``, ``fw_error`` when it equals ``metrics["fw_error"]``.
A metric the run did not compute (or a non-finite one) is a FAIL with its reason — never a
silent pass. `summary_text()` is the table `hapgate scene run` prints; `write()` puts
`summary.json`, `run.npz` and the PNG plots (each only when its data was recorded) into a folder.

Conventions of the arrays (SI): ``t`` [s] (N,); ``q`` [rad] (N, 3) true joint angles; ``p`` [m]
(N, 3) true endpoint; ``f_hand`` [N] (N, 3) the force the device applies to the hand (at rest on a
wall: ``+n k depth``); ``tau`` [N m] (N, 3) motor torque; ``dac`` [code] (F, 6) int16, channel
``2 i + j`` = motor i, phase j; ``dac_t`` [s] (F,); further recorded names (``adc``, ``pos``,
``current``) as the runner documents them. Arrays of unsimulated axes hold their held value.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..base import report
from ..base.atomic import write_bytes
from ..golden import kinematics
from .scene import ExpectCfg, Scene

# [expect] key -> the metric it reads
METRIC_OF = {"max_force_error_n": "force_error_n",
             "max_position_error_counts": "position_error_counts",
             "zero_torque_within_us": "zero_torque_us",
             "min_torque_ratio": "torque_ratio", "max_torque_ratio": "torque_ratio",
             "max_energy_drift_frac": "energy_drift_frac", "max_slips": "slips",
             "fw_error": "fw_error", "min_link_bad_frames": "link_bad_frames",
             "pc_force_zero_within_ms": "pc_force_zero_ms"}
PER_SAMPLE3 = ("q", "p", "f_hand", "tau")   # (N, 3) arrays on the t grid


@dataclass
class RunResult:
    scene: Scene
    sim_s: float                     # simulated time, s
    wall_s: float                    # wall-clock time of the run, s
    rtf: float                       # real-time factor = sim_s / wall_s
    fidelity: str                    # "rtl" | "model"
    clk_hz: int                      # FPGA clock actually simulated, Hz
    axes: tuple[int, ...]            # simulated axes
    built: list[str] = field(default_factory=list)      # human-readable parts built
    skipped: list[str] = field(default_factory=list)    # ... and skipped
    arrays: dict[str, np.ndarray] = field(default_factory=dict)   # see the module doc
    events: list[dict] = field(default_factory=list)    # kind, axis, cause_s, zero_torque_s,
    #                                                     reaction_us
    metrics: dict[str, float | int | str] = field(default_factory=dict)   # names: METRIC_OF
    per_axis: dict[str, list[float]] = field(default_factory=dict)   # one value per entry
    #             of `axes` (e.g. pos_err_rms_counts), or one per motor 0..2 (e.g. torque_ratio)
    cpu_s: float = math.nan          # CPU time of the run (the one-core figure), s

    @property
    def rtf_cpu(self) -> float:
        """Real-time factor on one core: simulated time over the run's CPU time."""
        return self.sim_s / self.cpu_s if self.cpu_s > 0 else math.nan


@dataclass(frozen=True)
class Outcome:
    key: str                 # the [expect] key
    limit: object            # its value in the scene
    metric: str              # the metric it reads
    measured: object         # the metric's value (None: not measured)
    passed: bool
    reason: str              # why it failed ("" when it passed)

    def row(self) -> list[object]:
        meas = "-" if self.measured is None else self.measured
        return [self.key, self.limit, self.metric, meas, "PASS" if self.passed else "FAIL",
                self.reason]

    def as_dict(self) -> dict[str, object]:
        return {"key": self.key, "limit": _plain(self.limit), "metric": self.metric,
                "measured": _plain(self.measured), "result": "PASS" if self.passed else "FAIL",
                "reason": self.reason}


def missing_records(r: RunResult) -> list[str]:
    """Names in the scene's `record` for which the run returned no array (never silent)."""
    return [k for k in r.scene.run.record if k not in r.arrays]


def evaluate(expect: ExpectCfg, metrics: dict[str, float | int | str]) -> list[Outcome]:
    """Judge every [expect] check that is set against the metrics (rules: module doc)."""
    out = []
    for key, limit in expect.items():
        metric = METRIC_OF[key]
        if metric not in metrics or metrics[metric] is None:
            out.append(Outcome(key, limit, metric, None, False, "not measured"))
            continue
        value = metrics[metric]
        if key == "fw_error":
            ok = isinstance(value, str) and value == limit
            out.append(Outcome(key, limit, metric, value, ok, "" if ok else
                               f"firmware error is {value}, expected {limit}"))
            continue
        if isinstance(value, str | bool) or not isinstance(value, int | float | np.number):
            out.append(Outcome(key, limit, metric, value, False, "not a number"))
            continue
        x = float(value)
        if not math.isfinite(x):
            out.append(Outcome(key, limit, metric, value, False, "not finite"))
            continue
        if key.startswith("min_"):
            ok, why = x >= limit, f"{x:.4g} < {limit}"   # type: ignore[operator]
        else:
            ok, why = x <= limit, f"{x:.4g} > {limit}"   # type: ignore[operator]
        out.append(Outcome(key, limit, metric, _plain(value), bool(ok), "" if ok else why))
    return out


def verdict(outcomes: list[Outcome]) -> str:
    """PASS when every check holds (also when the scene has none), else FAIL."""
    return "PASS" if all(o.passed for o in outcomes) else "FAIL"


# ------------------------------------------------------------------------------- the table


AXIS_NAMES = ("alpha", "beta", "gamma")


def summary_text(r: RunResult, outcomes: list[Outcome]) -> str:
    s = r.scene
    parts = [f"scene {s.name} ({s.source})",
             "built:   " + ("; ".join(r.built) or "-"),
             "skipped: " + ("; ".join(r.skipped) or "-")]
    if missing_records(r):
        parts.append("WARNING: recorded but not produced by the run: "
                     + ", ".join(missing_records(r)))
    parts.append("")
    clk = f"{r.clk_hz / 1e6:g} MHz" + (" (auto)" if s.run.clk_hz == 0 else "")
    parts.append(report.table(
        ["fidelity", "clock", "axes", "servo Hz", "simulated s", "wall s", "real-time x",
         "CPU s", "real-time x (CPU)"],
        [[r.fidelity, clk, ",".join(map(str, r.axes)), s.run.servo_hz, r.sim_s, r.wall_s,
          r.rtf, r.cpu_s, r.rtf_cpu]]))
    if r.per_axis:
        names = list(r.per_axis)
        rows = []
        for i, a in enumerate(r.axes):
            rows.append([f"{a} {AXIS_NAMES[a]}"]
                        + [_at(r.per_axis[n], i, a, len(r.axes)) for n in names])
        parts += ["", report.table(["axis", *names], rows)]
    if r.metrics:
        parts += ["", report.table(["metric", "value"],
                                   [[k, _plain(v)] for k, v in r.metrics.items()])]
    if r.events:
        parts += ["", "safety events:", report.table(
            ["kind", "axis", "cause_s", "zero_torque_s", "reaction_us"],
            [[e.get("kind", "-"), _fmt(e.get("axis"), "{}"), _fmt(e.get("cause_s"), "{:.6f}"),
              _fmt(e.get("zero_torque_s"), "{:.6f}"), _fmt(e.get("reaction_us"), "{:.2f}")]
             for e in r.events])]
    if outcomes:
        parts += ["", report.table(["expect", "limit", "metric", "measured", "result", "why"],
                                   [o.row() for o in outcomes])]
    n_ok = sum(o.passed for o in outcomes)
    parts += ["", f"result: {verdict(outcomes)} ({n_ok}/{len(outcomes)} expects hold; "
                  f"{r.sim_s:.4g} s simulated in {r.wall_s:.4g} s, {r.rtf:.3g}x real time)"]
    return "\n".join(parts)


def _fmt(x: object, spec: str) -> str:
    """A table cell with a fixed format; "-" when missing, "inf"/"nan" when not finite."""
    if x is None:
        return "-"
    if isinstance(x, float | np.floating) and not math.isfinite(x):
        return str(float(x))
    return spec.format(_plain(x))


def _at(values: list[float], i: int, axis: int, n_axes: int) -> object:
    """Value of the i-th simulated axis (= axis): lists are per simulated axis or per motor."""
    if len(values) == n_axes:
        v = values[i]
    elif len(values) == 3:
        v = values[axis]
    else:
        return "-"
    return _fmt(v, "{:.4g}") if isinstance(v, float | np.floating) else v


def _plain(x: object) -> object:
    """JSON-able scalar: numpy scalars to Python, non-finite floats to None."""
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, tuple | list):
        return [_plain(v) for v in x]
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    return x


def summary_dict(r: RunResult, outcomes: list[Outcome]) -> dict[str, object]:
    return _plain({
        "name": r.scene.name, "file": r.scene.source, "result": verdict(outcomes),
        "sim_s": r.sim_s, "wall_s": r.wall_s, "rtf": r.rtf, "cpu_s": r.cpu_s,
        "rtf_cpu": r.rtf_cpu, "fidelity": r.fidelity,
        "clk_hz": r.clk_hz, "axes": list(r.axes), "servo_hz": r.scene.run.servo_hz,
        "built": list(r.built), "skipped": list(r.skipped),
        "missing_records": missing_records(r),
        "expects": [o.as_dict() for o in outcomes], "metrics": dict(r.metrics),
        "per_axis": {k: list(v) for k, v in r.per_axis.items()}, "events": list(r.events),
        "arrays": {k: [list(np.shape(v)), str(np.asarray(v).dtype)]
                   for k, v in r.arrays.items()},
        "scene": r.scene.summary()})   # type: ignore[return-value]


# ------------------------------------------------------------------------------- outputs


def check_arrays(r: RunResult) -> None:
    """Shapes as documented (a runner bug shows here, not as a wrong plot)."""
    a = r.arrays
    n = None
    if "t" in a:
        if np.ndim(a["t"]) != 1:
            raise ValueError(f"arrays['t'] must be 1-D, got shape {np.shape(a['t'])}")
        n = len(a["t"])
    for k in PER_SAMPLE3:
        if k in a and (n is None or np.shape(a[k]) != (n, 3)):
            raise ValueError(f"arrays[{k!r}] must be (len(t), 3) = ({n}, 3), "
                             f"got {np.shape(a[k])}")
    if "dac" in a:
        f = np.shape(a["dac"])
        if len(f) != 2 or f[1] != 6 or "dac_t" not in a or np.shape(a["dac_t"]) != (f[0],):
            raise ValueError(f"arrays['dac'] must be (F, 6) with dac_t (F,), got {f} and "
                             f"{np.shape(a.get('dac_t'))}")


def write(r: RunResult, outdir: Path, outcomes: list[Outcome]) -> list[Path]:
    """summary.json, run.npz and the plots into outdir (which exists). Returns the paths."""
    check_arrays(r)
    outdir = Path(outdir)
    paths = [outdir / "summary.json", outdir / "run.npz"]
    write_bytes(paths[0], json.dumps(summary_dict(r, outcomes), indent=2, allow_nan=False)
                + "\n")
    write_bytes(paths[1], report.npz_bytes({k: np.asarray(v) for k, v in r.arrays.items()}))
    return paths + plots(r, outdir)


def plots(r: RunResult, outdir: Path) -> list[Path]:
    a, s = r.arrays, r.scene
    want = []
    if "t" in a and ("p" in a or "q" in a):
        want.append(("position.png", _plot_position))
    if "p" in a and "f_hand" in a and s.env.kind in ("wall", "spring"):
        want.append(("force_depth.png", _plot_force_depth))
    if "dac" in a and "dac_t" in a:
        want.append(("dac.png", _plot_dac))
    if "t" in a and "tau" in a:
        want.append(("torque.png", _plot_torque))
    if not want:
        return []
    plt = report.pyplot()
    out = []
    for name, fn in want:
        fig = fn(plt, r)
        path = Path(outdir) / name
        report.save_figure(fig, path, dpi=110)
        plt.close(fig)
        out.append(path)
    return out


def _plot_position(plt, r: RunResult):  # noqa: ANN001, ANN202
    a, s = r.arrays, r.scene
    t = np.asarray(a["t"])
    fig, axs = plt.subplots(2 if ("p" in a and "q" in a) else 1, 1, figsize=(8, 6),
                            sharex=True, squeeze=False)
    row = 0
    if "p" in a:
        ax = axs[row, 0]
        p = np.asarray(a["p"])
        p0 = p[0] if len(p) else np.zeros(3)
        for i, c in enumerate("xyz"):
            ax.plot(t, 1e3 * (p[:, i] - p0[i]), color=f"C{i}", label=f"{c} endpoint")
        if s.hand.kind != "none" and len(t):
            tgt = s.hand.target(t, p0)
            for i, c in enumerate("xyz"):
                ax.plot(t, 1e3 * (tgt[:, i] - p0[i]), "--", color=f"C{i}", lw=0.8,
                        label=f"{c} hand target")
        ax.set_ylabel("mm from the start\n" + ", ".join(f"{1e3 * c:.1f}" for c in p0))
        ax.legend(fontsize=7, ncol=2)
        ax.set_title(f"{s.name}: true endpoint (hand {s.hand.kind}, env {s.env.kind})")
        row += 1
    if "q" in a:
        ax = axs[row, 0]
        q = np.rad2deg(np.asarray(a["q"]))
        q0 = q[0] if len(q) else np.zeros(3)
        for i, c in enumerate(AXIS_NAMES):
            ax.plot(t, q[:, i] - q0[i], label=c)
        ax.set_ylabel("joint angle from the start, deg\n" + ", ".join(f"{c:.1f}" for c in q0))
        ax.legend(fontsize=7)
    for f in s.faults:
        for ax in axs[:, 0]:
            ax.axvline(f.at_s, color="r", lw=0.8, ls=":")
    axs[-1, 0].set_xlabel("simulated time, s")
    fig.tight_layout()
    return fig


def _plot_force_depth(plt, r: RunResult):  # noqa: ANN001, ANN202
    a, e = r.arrays, r.scene.env
    p, f = np.asarray(a["p"]), np.asarray(a["f_hand"])
    fig, ax = plt.subplots(figsize=(7, 5))
    if e.kind == "wall":
        n, p0 = np.asarray(e.normal), np.asarray(e.point)
        depth = (p0 - p) @ n
        fn = f @ n
        after = _after_fault(r, len(depth))
        ax.plot(1e3 * depth[~after], fn[~after], ".", ms=2, label="force on the hand along n")
        dev = _device_force(r)
        if dev is not None:
            ax.plot(1e3 * depth[~after], (dev @ n)[~after], ".", ms=2, color="C2",
                    label="device force J^-T tau along n")
        if after.any():
            ax.plot(1e3 * depth[after], fn[after], ".", ms=2, color="r", label="after a fault")
        d = np.linspace(min(0.0, depth.min()), max(depth.max(), 1e-4), 50)
        ax.plot(1e3 * d, e.k * np.maximum(d, 0.0), "k--", label=f"wall law k = {e.k:g} N/m")
        ax.set_xlabel("depth into the wall, mm")
        ax.set_ylabel("N")
    else:
        err = np.linalg.norm(p - np.asarray(e.point), axis=1)
        after = _after_fault(r, len(err))
        fm = np.linalg.norm(f, axis=1)
        ax.plot(1e3 * err[~after], fm[~after], ".", ms=2, label="|force on the hand|")
        if after.any():
            ax.plot(1e3 * err[after], fm[after], ".", ms=2, color="r", label="after a fault")
        d = np.linspace(0, max(err.max(), 1e-4), 50)
        ax.plot(1e3 * d, e.k * d, "k--", label=f"spring law k = {e.k:g} N/m")
        ax.set_xlabel("distance from the anchor, mm")
        ax.set_ylabel("N")
    ax.legend()
    ax.set_title(f"{r.scene.name}: force against depth")
    fig.tight_layout()
    return fig


def _device_force(r: RunResult) -> np.ndarray | None:
    """The endpoint force the motor torques produce, F = J(q)^-T tau (N, (N, 3)), when q and
    tau are recorded: the force law the device renders, apart from the hand's dynamics."""
    a = r.arrays
    if "q" not in a or "tau" not in a:
        return None
    jt = np.swapaxes(kinematics.jacobian(np.asarray(a["q"])), -1, -2)
    return np.linalg.solve(jt, np.asarray(a["tau"])[..., None])[..., 0]


def _after_fault(r: RunResult, n: int) -> np.ndarray:
    """Samples at or after the first fault (False everywhere without t or faults)."""
    t = r.arrays.get("t")
    if t is None or not r.scene.faults or len(t) != n:
        return np.zeros(n, dtype=bool)
    return np.asarray(t) >= r.scene.faults[0].at_s


def _plot_dac(plt, r: RunResult):  # noqa: ANN001, ANN202
    a = r.arrays
    t, codes = np.asarray(a["dac_t"]), np.asarray(a["dac"])
    fig, axs = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    for m in range(3):
        for j in range(2):
            axs[m].step(t, codes[:, 2 * m + j], where="post", lw=0.8, label=f"phase {'ab'[j]}")
        axs[m].set_ylabel(f"motor {m} code")
        axs[m].legend(fontsize=7, loc="upper right")
    axs[0].set_title(f"{r.scene.name}: DAC codes per frame")
    axs[-1].set_xlabel("simulated time, s")
    fig.tight_layout()
    return fig


def _plot_torque(plt, r: RunResult):  # noqa: ANN001, ANN202
    a = r.arrays
    t, tau = np.asarray(a["t"]), np.asarray(a["tau"])
    fig, axs = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    # ripple: torque minus its moving mean over one servo period (the command is held there)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    w = max(1, int(round(1.0 / (r.scene.run.servo_hz * dt))))
    for i in range(3):
        axs[0].plot(t, 1e3 * tau[:, i], lw=0.8, label=f"motor {i}")
        if len(t) >= w:
            c = np.cumsum(np.concatenate([[0.0], tau[:, i]]))
            mean = (c[w:] - c[:-w]) / w
            axs[1].plot(t[w - 1:], 1e3 * (tau[w - 1:, i] - mean), lw=0.6, label=f"motor {i}")
    axs[0].set_ylabel("torque, mN m")
    axs[1].set_ylabel("ripple, mN m\n(minus 1-tick mean)")
    axs[0].legend(fontsize=7)
    axs[0].set_title(f"{r.scene.name}: motor torque and ripple")
    axs[-1].set_xlabel("simulated time, s")
    fig.tight_layout()
    return fig
