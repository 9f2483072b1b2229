"""The native Verilator harness of the three-axis interpolator (tb/native/interp/).

`build_interp()` Verilates rtl/interp/enc_interp3.v with a C++ main that streams samples from a
file (one build per parameter set, cached under build/native/), `run_interp()` feeds it numpy
arrays and returns the per-sample outputs as numpy arrays. A scene builds what it asks for:
only AXES axes, only the output columns requested, at the clock it names (CLK_HZ = SAMPLE_HZ, one
clock per sample, is the fastest; a board clock gives identical outputs, more slowly).
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..base import toolenv
from ..base.block import Params
from ..base.paths import BUILD, RTL, TB, ensure
from ..base.tables import write_tables
from ..flows.flow import param_text
from ..golden import enccal, interp
from ..golden.interp import InterpConfig
from .sim import _locked

HARNESS = TB / "native" / "interp" / "interp_harness.cpp"
SOURCES = [RTL / "interp" / "enc_calib.v", RTL / "interp" / "ratio_div.v",
           RTL / "interp" / "vel_observer.v",
           RTL / "interp" / "enc_interp.v",
           RTL / "interp" / "sample_strobe.v",
           RTL / "interp" / "enc_interp3.v"]
COLUMNS = ("pos", "pos_homed", "vel", "index_pos", "index_count", "homed", "faults",
           "overspeed_count")
# the calibration state (CAL = 1 builds; the identity constants otherwise), see cal_columns()
CAL_COLUMNS = ("cal_ofs_a", "cal_ofs_b", "cal_gain_a", "cal_gain_b", "cal_phase", "cal_gear",
               "cal_updates")
ALL_COLUMNS = COLUMNS + CAL_COLUMNS
# every column of the harness, in its order: + the velocity observer's (VEL_OBS = 1 builds)
HARNESS_COLUMNS = ALL_COLUMNS + ("vel_obs",)
COLUMN_DTYPES = {"pos": "<i4", "pos_homed": "<i4", "vel": "<i4", "index_pos": "<i4",
                 "index_count": "<u2", "homed": "u1", "faults": "u1", "overspeed_count": "<u2",
                 "cal_ofs_a": "<i2", "cal_ofs_b": "<i2", "cal_gain_a": "<u2", "cal_gain_b": "<u2",
                 "cal_phase": "<i2", "cal_gear": "u1", "cal_updates": "<u2", "vel_obs": "<i4"}
FLAG_INDEX, FLAG_CLEAR, FLAG_ARM, FLAG_CAL_EN, FLAG_CAL_FREEZE, FLAG_HARM_EN = 1, 2, 4, 8, 16, 32


def verilate_harness(name: str, top: str, sources: Sequence[Path], params: Params,
                     harness: Sequence[Path], cflags: str = "", ldflags: str = "",
                     inputs: Sequence[Path] = (),
                     prepare: Callable[[Path], None] | None = None,
                     vflags: Sequence[str] = (),
                     train: Callable[[Path], None] | None = None) -> Path:
    """Verilate `top` with a C++ harness into build/native/<name>-<hash>/ and return the
    executable. The hash covers the parameters, flags and the bytes of every source, harness and
    extra input, so a change rebuilds and an unchanged scene is reused (parallel callers wait on a
    lock). `prepare(build_dir)` runs before Verilator (e.g. to build a library to link);
    `vflags` are extra Verilator options (defines, tracing). With `train`, the executable is
    compiled twice (profile-guided optimisation, `_pgo_build`): instrumented, `train(exe)` runs
    it on a representative input, then optimised with that profile. The compiler flags keep the
    IEEE semantics (no fast-math), so the optimised executable computes the same results bit for
    bit (tb/device/test_closed_loop.py checks it), only faster."""
    toolenv.apply()
    write_tables(params)
    key = json.dumps({k: param_text(v) for k, v in sorted(params.items())} |
                     {"_cflags": cflags, "_ldflags": ldflags} |
                     ({"_vflags": list(vflags)} if vflags else {}) |
                     ({"_pgo": PGO_FLAGS} if train is not None else {}))
    digest = hashlib.sha1(key.encode())
    for src in [*sources, *harness, *inputs]:
        digest.update(src.read_bytes())
    bdir = ensure(BUILD / "native" / f"{name}-{digest.hexdigest()[:12]}")
    exe = bdir / name
    with _locked(bdir):
        if exe.exists():
            return exe
        if prepare is not None:
            prepare(bdir)
        cmd = ["verilator", "--cc", "--exe"] + ([] if train else ["--build", "-j", "2"]) + ["-O3",
               "--x-assign", "fast", "--x-initial", "fast", "-Wno-fatal",
               "--top-module", top, "-Mdir", str(bdir), "-o", name,
               "-CFLAGS", f"-O2 {cflags}".strip(),
               "-MAKEFLAGS", "OPT_FAST=-O2 OPT_SLOW=-O2 OPT_GLOBAL=-O2"]
        if ldflags:
            cmd += ["-LDFLAGS", ldflags]
        cmd += list(vflags)
        cmd += [f"-G{k}={param_text(v)}" for k, v in params.items()]
        cmd += [str(s) for s in [*sources, *harness]]
        out = subprocess.run(cmd, capture_output=True, text=True)
        log = out.stdout + out.stderr
        if out.returncode == 0 and train is not None:
            log += _pgo_build(bdir, f"V{top}.mk", exe, train)
        (bdir / "build.log").write_text(log)
        if out.returncode != 0 or not exe.exists():
            raise RuntimeError(f"native harness {name} failed to build; see {bdir / 'build.log'}")
    return exe


# Profile-guided optimisation of a Verilated harness (verilate_harness(train=...)): gcc's
# -fprofile-generate / -fprofile-use on every object of the executable (the generated model, the
# Verilator runtime, the harness; a `prepare`d library keeps its own flags), and the optimised
# build linked with link-time optimisation (the plant's and the model's calls from the clock loop
# inline across files). Partial training: code the training run never reached is optimised as
# usual, not for size. Profile and LTO change only the code's layout, inlining and branch order;
# without -ffast-math (and without an FMA target) the results are the same.
PGO_FLAGS = {"generate": "-O2 -fprofile-generate -fprofile-update=single",
             "use": "-O2 -flto=2 -fprofile-use -fprofile-partial-training -Wno-missing-profile"}


def _pgo_build(bdir: Path, makefile: str, exe: Path, train: Callable[[Path], None]) -> str:
    """Compile the generated model twice around a training run; returns the log. A failed
    training run costs only the speed: the second compile then has no profile to use."""
    def make(stage: str) -> str:
        for f in [exe, *bdir.glob("*.o"), *bdir.glob("*.a")]:
            f.unlink(missing_ok=True)
        flags = PGO_FLAGS[stage]
        link = "-fprofile-generate" if stage == "generate" else flags
        out = subprocess.run(["make", "-C", str(bdir), "-f", makefile, "-j", "2", exe.name,
                              f"OPT_FAST={flags}", f"OPT_SLOW={flags}", f"OPT_GLOBAL={flags}",
                              f"USER_LDFLAGS={link}"], capture_output=True, text=True)
        return f"== pgo: {stage} ==\n" + out.stdout + out.stderr

    for f in bdir.glob("*.gcda"):
        f.unlink()
    log = make("generate")
    if exe.exists():
        try:
            train(exe)
            log += "== pgo: trained ==\n"
        except Exception as e:   # noqa: BLE001 -- any failure only loses the profile
            log += f"== pgo: training failed ({e}); compiled without a profile ==\n"
    return log + make("use")


def build_interp(cfg: InterpConfig = InterpConfig(), clk_hz: int = interp.MIN_CLK_HZ,
                 axes: int = 3, sample_hz: int = 1_000_000) -> Path:
    """Verilate and compile the interpolator harness for this parameter set (cached)."""
    params = interp.interp3_params(cfg, clk_hz=clk_hz, sample_hz=sample_hz, axes=axes)
    return verilate_harness("interp_harness", "enc_interp3", SOURCES, params, [HARNESS],
                            cflags=f"-DAXES={axes}")


@dataclass
class NativeRun:
    outputs: list[dict[str, np.ndarray]]   # per axis: column name -> array (row k = sample k)
    seconds: float                         # harness wall time (simulation only)
    clocks: int
    stats: dict[str, str] = field(default_factory=dict)  # everything the harness printed

    def axis(self, i: int) -> dict[str, np.ndarray]:
        return self.outputs[i]


def _as_2d(x: np.ndarray | None, n: int, axes: int, dtype: str) -> np.ndarray:
    if x is None:
        return np.zeros((n, axes), dtype=dtype)
    arr = np.asarray(x)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.shape != (n, axes):
        raise ValueError(f"expected shape ({n}, {axes}), got {arr.shape}")
    return arr.astype(dtype)


def _levels(v: np.ndarray | bool, n: int, axes: int) -> np.ndarray:
    arr = np.asarray(v, dtype=bool)
    if arr.ndim == 1:
        arr = arr[:, None]
    return np.broadcast_to(arr, (n, axes)).astype(np.uint8)


def cal_columns(out: interp.InterpOut) -> dict[str, np.ndarray]:
    """The model's calibration state (cfg.cal runs) in the harness's cal_* column form."""
    c = enccal.applied(out.extra["cal_state_after"])
    return {"cal_ofs_a": c[0], "cal_ofs_b": c[1], "cal_gain_a": c[2], "cal_gain_b": c[3],
            "cal_phase": c[4], "cal_gear": np.asarray(out.extra["cal_gear"]),
            "cal_updates": np.asarray(out.extra["cal_updates"])}


def _events_to_mask(events: Sequence[Sequence[int]] | None, n: int, axes: int) -> np.ndarray:
    m = np.zeros((n, axes), dtype=bool)
    if events is not None:
        for ax, ev in enumerate(events):
            ev = np.asarray(ev, dtype=np.int64)
            m[ev[(ev >= 0) & (ev < n)], ax] = True
    return m


def run_interp(a: np.ndarray, b: np.ndarray, index: np.ndarray | None = None,
               cfg: InterpConfig = InterpConfig(), clk_hz: int = interp.MIN_CLK_HZ,
               columns: Sequence[str] = COLUMNS, clear_at: Sequence[Sequence[int]] | None = None,
               arm_at: Sequence[Sequence[int]] | None = None,
               cal_en: np.ndarray | bool = False, cal_freeze: np.ndarray | bool = False,
               cal_mu: int = 6, harm_table: np.ndarray | None = None,
               harm_en: np.ndarray | bool = False, obs_bw: int = 6,
               obs_type3: bool = True) -> NativeRun:
    """Run samples (arrays of shape (n,) for one axis or (n, axes)) through the Verilated RTL.

    clear_at / arm_at: per axis, the sample numbers at which a fault clear / home arm pulse is
    applied (the same convention as hapgate.golden.interp.run). cal_en / cal_freeze: the
    calibration levels per sample (shape (n,), (n, axes) or a constant), cal_mu for every axis
    (cfg.cal builds). harm_table: the harmonic correction table (cfg.harm builds; shape (HN,)
    for every axis or (axes, HN), signed 1/4 counts), written through the table port and read
    back before the run (`stats["harm_readback_bad"]` counts the entries that differed);
    harm_en: its enable level per sample or constant. obs_bw, obs_type3: the velocity observer's
    settings for every axis (cfg.vel_obs builds: the vel_obs column)."""
    a = np.asarray(a)
    axes = 1 if a.ndim == 1 else a.shape[1]
    n = a.shape[0]
    if n == 0:
        raise ValueError("no samples")
    unknown = set(columns) - set(HARNESS_COLUMNS)
    if unknown:
        raise ValueError(f"unknown columns {sorted(unknown)}; known: {', '.join(HARNESS_COLUMNS)}")
    cols = [c for c in HARNESS_COLUMNS if c in columns]
    exe = build_interp(cfg, clk_hz=clk_hz, axes=axes)
    rec = np.zeros((n, axes, 3), dtype=np.uint8)
    rec[:, :, 0] = _as_2d(a, n, axes, "int8").view(np.uint8)
    rec[:, :, 1] = _as_2d(b, n, axes, "int8").view(np.uint8)
    flags = _as_2d(index, n, axes, "bool").astype(np.uint8) * FLAG_INDEX
    flags |= _events_to_mask(clear_at, n, axes).astype(np.uint8) * FLAG_CLEAR
    flags |= _events_to_mask(arm_at, n, axes).astype(np.uint8) * FLAG_ARM
    flags |= _levels(cal_en, n, axes) * FLAG_CAL_EN
    flags |= _levels(cal_freeze, n, axes) * FLAG_CAL_FREEZE
    flags |= _levels(harm_en, n, axes) * FLAG_HARM_EN
    rec[:, :, 2] = flags
    mask = sum(1 << HARNESS_COLUMNS.index(c) for c in cols)
    dtype = np.dtype([(f"{c}{ax}", COLUMN_DTYPES[c]) for ax in range(axes) for c in cols])
    with tempfile.TemporaryDirectory(dir=ensure(BUILD / "native" / "runs")) as tmp:
        fin, fout = Path(tmp) / "in.bin", Path(tmp) / "out.bin"
        rec.tofile(fin)
        # CAL_MU carries the observer's settings in bits 13:8 (bit 13: present)
        obs_cfg = (obs_bw & 15) | (int(obs_type3) << 4)
        argv = [str(exe), str(fin), str(fout), str(n), str(mask),
                str((cal_mu & 15) | obs_cfg << 8 | 1 << 13)]
        if harm_table is not None:
            h2 = np.atleast_2d(np.asarray(harm_table, dtype=np.int64))
            ht = np.broadcast_to(h2, (axes, h2.shape[1]))
            hn = ht.shape[1]
            full = ht[:, np.arange(256) % hn]          # the 8-bit address aliases mod HN
            ftab = Path(tmp) / "harm.bin"
            full.astype(np.int8).tofile(ftab)
            argv.append(str(ftab))
        t0 = time.perf_counter()
        out = subprocess.run(argv, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if out.returncode != 0:
            raise RuntimeError(f"native harness failed ({out.returncode}): {out.stderr.strip()}")
        stats = dict(kv.split("=") for kv in out.stdout.split())
        data = np.fromfile(fout, dtype=dtype)
    if data.size != n:
        raise RuntimeError(f"native harness wrote {data.size} of {n} samples")
    outputs = [{c: data[f"{c}{ax}"].astype(np.int64) for c in cols} for ax in range(axes)]
    return NativeRun(outputs=outputs, seconds=float(stats.get("seconds", wall)),
                     clocks=int(stats.get("clocks", 0)), stats=stats)


def model_matrix(out: interp.InterpOut, columns: Sequence[str] = COLUMNS) -> dict[str, np.ndarray]:
    """The model's outputs in the harness's column form (for bit-exact comparison)."""
    res = {}
    for c in columns:
        v = np.asarray(getattr(out, c))
        res[c] = v.astype(np.int64)
    return res


def first_mismatch(rtl: dict[str, np.ndarray], model: dict[str, np.ndarray]
                   ) -> tuple[int, str, int, int] | None:
    """(sample, column, rtl value, model value) of the first difference, or None."""
    first: tuple[int, str, int, int] | None = None
    for c, r in rtl.items():
        m = model[c]
        bad = np.flatnonzero(r != m)
        if bad.size and (first is None or bad[0] < first[0]):
            k = int(bad[0])
            first = (k, c, int(r[k]), int(m[k]))
    return first


