"""The native Verilator harness of the three-axis interpolator (tb/native/interp/).

`build_interp()` Verilates rtl/interp/enc_interp3.v with a C++ main that streams samples from a
file (one build per parameter set, cached under build/native/), `run_interp()` feeds it numpy
arrays and returns the per-sample outputs as numpy arrays. A scene builds what it asks for:
only AXES axes, only the output columns requested, at the clock it names (CLK_HZ = SAMPLE_HZ, one
clock per sample, is the fastest; a board clock gives identical outputs, more slowly).
"""

from __future__ import annotations

import os
import queue
import shutil
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..base import cache, cbuild, toolenv
from ..base.block import Params
from ..base.paths import BUILD, RTL, RTL_INCLUDE, TB, ensure
from ..base.tables import write_tables
from ..flows.flow import param_text
from ..golden import enccal, interp
from ..golden.interp import InterpConfig
from . import covbuild, funcov

HARNESS = TB / "native" / "interp" / "interp_harness.cpp"
TESTB = TB / "native" / "device" / "testb.h"   # the testbench wrapper of the Verilated harnesses
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
FLAG_RESET = 64   # (axis 0's record) a reset before the sample: samples in flight are lost


def verilate_harness(name: str, top: str, sources: Sequence[Path], params: Params,
                     harness: Sequence[Path], cflags: str = "", ldflags: str = "",
                     inputs: Sequence[Path] = (),
                     prepare: Callable[[Path], None] | None = None,
                     vflags: Sequence[str] = (),
                     train: Callable[[Path], None] | None = None,
                     cov_toggle: bool = False) -> Path:
    """Verilate `top` with a C++ harness into build/native/<name>-<hash>/ and return the
    executable. The hash covers the parameters, flags and the bytes of every source, harness and
    extra input, so a change rebuilds and an unchanged scene is reused (parallel callers wait on a
    lock). `prepare(build_dir)` runs before Verilator (e.g. to build a library to link);
    `vflags` are extra Verilator options (defines, tracing). With `train`, the executable is
    compiled twice (profile-guided optimisation, `_pgo_build`): instrumented, `train(exe)` runs
    it on a representative input, then optimised with that profile. The compiler flags keep the
    IEEE semantics (no fast-math), so the optimised executable computes the same results bit for
    bit (tb/device/test_closed_loop.py checks it), only faster. In a coverage run the build
    counts lines and branches, and with `cov_toggle` port toggles too (runners/covbuild.py)."""
    toolenv.apply()
    write_tables(params)
    cov_flags, cov_sources = covbuild.extra(top, native=not cov_toggle)   # coverage runs
    vflags, sources = [*vflags, *cov_flags], [*sources, *cov_sources]
    if cov_toggle and cov_flags:     # (a toggle build splits its output: a PCH path the wheel
        vflags += ["--output-split", "0"]           # breaks, as runners/sim.py notes)
    key = cache.digest(
        files=[*sources, *harness, *inputs, RTL_INCLUDE / "hg_sim.vh"],
        data={k: param_text(v) for k, v in sorted(params.items())} |
        {"_cflags": cflags, "_ldflags": ldflags} |
        ({"_vflags": list(vflags)} if vflags else {}) |
        ({"_pgo": PGO_FLAGS} if train is not None else {}))
    def build(bdir: Path) -> None:
        log = bdir / "build.log"
        log.write_text("")
        if prepare is not None:
            prepare(bdir)
        cmd = ["verilator", "--cc", "--exe"] + ([] if train else ["--build", "-j", "2"]) + ["-O3",
               "--x-assign", "fast", "--x-initial", "fast", "-Wno-fatal",
               "--top-module", top, "-Mdir", str(bdir), "-o", name, f"-I{RTL_INCLUDE}",
               "-CFLAGS", f"-O2 {cflags}".strip(),
               "-MAKEFLAGS", "OPT_FAST=-O2 OPT_SLOW=-O2 OPT_GLOBAL=-O2"]
        if ldflags:
            cmd += ["-LDFLAGS", ldflags]
        cmd += list(vflags)
        cmd += [f"-G{k}={param_text(v)}" for k, v in params.items()]
        cmd += [str(s) for s in [*sources, *harness]]
        cbuild.run(cmd, log, f"native harness {name}")
        if train is not None:
            _pgo_build(bdir, f"V{top}.mk", bdir / name, train, log)
        if not (bdir / name).exists():
            raise cbuild.failure(f"native harness {name}", log)

    return cache.cached_dir(BUILD / "native", f"{name}-{key}", build, done=name) / name


# Profile-guided optimisation of a Verilated harness (verilate_harness(train=...)): gcc's
# -fprofile-generate / -fprofile-use on every object of the executable (the generated model, the
# Verilator runtime, the harness; a `prepare`d library keeps its own flags), and the optimised
# build linked with link-time optimisation (the plant's and the model's calls from the clock loop
# inline across files). Partial training: code the training run never reached is optimised as
# usual, not for size. Profile and LTO change only the code's layout, inlining and branch order;
# without -ffast-math (and without an FMA target) the results are the same. The last two flags
# place the code: every function on a cache line of its own, each function's rarely run blocks
# kept at its end rather than split into a distant .cold part. The clock loop's hot code nearly
# fills this machine's 32 KiB instruction cache, so placement alone moves its CPU time by about
# 2 % either way; these two were measured the fastest for this source (tb/native/device/README.md
# "Code placement").
PGO_FLAGS = {"generate": "-O2 -fprofile-generate -fprofile-update=single",
             "use": "-O2 -flto=2 -fprofile-use -fprofile-partial-training -Wno-missing-profile "
                    "-falign-functions=64 -fno-reorder-blocks-and-partition"}


def _pgo_build(bdir: Path, makefile: str, exe: Path, train: Callable[[Path], None],
               log: Path) -> None:
    """Compile the generated model twice around a training run (logged to `log`). A failed
    training run costs only the speed: the second compile then has no profile to use."""
    def make(stage: str) -> None:
        for f in [exe, *bdir.glob("*.o"), *bdir.glob("*.a")]:
            f.unlink(missing_ok=True)
        flags = PGO_FLAGS[stage]
        link = "-fprofile-generate" if stage == "generate" else flags
        with open(log, "a") as fh:
            fh.write(f"== pgo: {stage} ==\n")
        cbuild.run(["make", "-C", str(bdir), "-f", makefile, "-j", "2", exe.name,
                    f"OPT_FAST={flags}", f"OPT_SLOW={flags}", f"OPT_GLOBAL={flags}",
                    f"USER_LDFLAGS={link}"], log, f"native harness {exe.name} (pgo {stage})",
                   check=False)

    for f in bdir.glob("*.gcda"):
        f.unlink()
    make("generate")
    note = "== pgo: trained ==\n"
    if exe.exists():
        try:
            train(exe)
        except Exception as e:   # noqa: BLE001 -- any failure only loses the profile
            note = f"== pgo: training failed ({e}); compiled without a profile ==\n"
        with open(log, "a") as fh:
            fh.write(note)
    make("use")


def build_interp(cfg: InterpConfig = InterpConfig(), clk_hz: int = interp.MIN_CLK_HZ,
                 axes: int = 3, sample_hz: int = 1_000_000, cov_toggle: bool = False) -> Path:
    """Verilate and compile the interpolator harness for this parameter set (cached); with
    cov_toggle a coverage run's build counts port toggles too (short runs only)."""
    params = interp.interp3_params(cfg, clk_hz=clk_hz, sample_hz=sample_hz, axes=axes)
    return verilate_harness("interp_harness", "enc_interp3", SOURCES, params, [HARNESS],
                            cflags=f"-DAXES={axes} -I{TESTB.parent}", inputs=[TESTB],
                            cov_toggle=cov_toggle)


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
               harm_en: np.ndarray | bool = False, obs_bw: int | Sequence[int] = 6,
               obs_type3: bool | Sequence[bool] = True,
               schedule: dict[int, Sequence[tuple[int, int, bool]]] | None = None,
               reset_at: Sequence[int] | None = None, cov_toggle: bool = False) -> NativeRun:
    """Run samples (arrays of shape (n,) for one axis or (n, axes)) through the Verilated RTL.

    clear_at / arm_at: per axis, the sample numbers at which a fault clear / home arm pulse is
    applied (the same convention as hapgate.golden.interp.run). cal_en / cal_freeze: the
    calibration levels per sample (shape (n,), (n, axes) or a constant), cal_mu for every axis
    (cfg.cal builds). harm_table: the harmonic correction table (cfg.harm builds; shape (HN,)
    for every axis or (axes, HN), signed 1/4 counts), written through the table port and read
    back before the run (`stats["harm_readback_bad"]` counts the entries that differed);
    harm_en: its enable level per sample or constant. obs_bw, obs_type3: the velocity observer's
    settings (cfg.vel_obs builds: the vel_obs column). cal_mu, obs_bw and obs_type3 are one value
    for every axis or one per axis; schedule changes them during the run: {sample k: per axis
    (mu, bw, type3)}, driven with sample k. reset_at: samples before which the harness resets
    the RTL (two clocks): the samples then in flight are lost, their rows all ones (-1 in
    the signed columns). cov_toggle: build_interp's."""
    a = np.asarray(a)
    axes = 1 if a.ndim == 1 else a.shape[1]
    n = a.shape[0]
    if n == 0:
        raise ValueError("no samples")
    unknown = set(columns) - set(HARNESS_COLUMNS)
    if unknown:
        raise ValueError(f"unknown columns {sorted(unknown)}; known: {', '.join(HARNESS_COLUMNS)}")
    cols = [c for c in HARNESS_COLUMNS if c in columns]
    exe = build_interp(cfg, clk_hz=clk_hz, axes=axes, cov_toggle=cov_toggle)
    rec = pack_interp(a, b, index, axes, clear_at, arm_at, cal_en, cal_freeze, harm_en)
    if reset_at is not None:
        rec[np.asarray(reset_at, dtype=np.int64), 0, 2] |= FLAG_RESET
    mask = sum(1 << HARNESS_COLUMNS.index(c) for c in cols)
    dtype = _out_dtype(cols, axes)
    with tempfile.TemporaryDirectory(dir=ensure(BUILD / "native" / "runs")) as tmp:
        fin, fout = Path(tmp) / "in.bin", Path(tmp) / "out.bin"
        rec.tofile(fin)
        argv = _interp_argv(exe, fin, fout, n, mask, cal_mu, obs_bw, obs_type3, harm_table,
                            axes, Path(tmp), schedule)
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
    if funcov.active() and "pos" in cols and "faults" in cols:
        idx = None if index is None else _as_2d(index, n, axes, "u1")
        for ax in range(axes):
            funcov.sample_interp(outputs[ax]["pos"], outputs[ax]["faults"],
                                 None if idx is None else idx[:, ax],
                                 cfg.counts_per_line // 4, cfg.counts_per_rev, 1_000_000)
    return NativeRun(outputs=outputs, seconds=float(stats.get("seconds", wall)),
                     clocks=int(stats.get("clocks", 0)), stats=stats)


def pack_interp(a: np.ndarray, b: np.ndarray, index: np.ndarray | None, axes: int,
                clear_at: Sequence[Sequence[int]] | None = None,
                arm_at: Sequence[Sequence[int]] | None = None,
                cal_en: np.ndarray | bool = False, cal_freeze: np.ndarray | bool = False,
                harm_en: np.ndarray | bool = False) -> np.ndarray:
    """The harness's input records (n, axes, 3 bytes: a, b, flags) of samples."""
    n = np.asarray(a).shape[0]
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
    return rec


def _out_dtype(cols: Sequence[str], axes: int) -> np.dtype:
    return np.dtype([(f"{c}{ax}", COLUMN_DTYPES[c]) for ax in range(axes) for c in cols])


def _per_axis(v: int | bool | Sequence[int] | Sequence[bool], axes: int, what: str) -> list[int]:
    vals = [int(x) for x in np.atleast_1d(np.asarray(v, dtype=np.int64))]
    if len(vals) == 1:
        return vals * axes
    if len(vals) != axes:
        raise ValueError(f"{what}: one value or {axes} (one per axis), got {len(vals)}")
    return vals


def _interp_argv(exe: Path, fin: Path | str, fout: Path | str, n: int, mask: int,
                 cal_mu: int | Sequence[int], obs_bw: int | Sequence[int],
                 obs_type3: bool | Sequence[bool], harm_table: np.ndarray | None, axes: int,
                 tmp: Path,
                 schedule: dict[int, Sequence[tuple[int, int, bool]]] | None = None
                 ) -> list[str]:
    # CAL_MU carries the observer's settings in bits 13:8 (bit 13: present), a word per axis
    words = [(mu & 15) | ((bw & 15) | t3 << 4) << 8 | 1 << 13 for mu, bw, t3 in
             zip(_per_axis(cal_mu, axes, "cal_mu"), _per_axis(obs_bw, axes, "obs_bw"),
                 _per_axis(obs_type3, axes, "obs_type3"), strict=True)]
    argv = [str(exe), str(fin), str(fout), str(n), str(mask), ",".join(map(str, words))]
    if harm_table is not None:
        h2 = np.atleast_2d(np.asarray(harm_table, dtype=np.int64))
        ht = np.broadcast_to(h2, (axes, h2.shape[1]))
        hn = ht.shape[1]
        full = ht[:, np.arange(256) % hn]          # the 8-bit address aliases mod HN
        ftab = tmp / "harm.bin"
        full.astype(np.int8).tofile(ftab)
        argv.append(str(ftab))
    if schedule:
        argv += [] if harm_table is not None else ["-"]
        rec = np.zeros(len(schedule), dtype=[("k", "<u4"), ("w", "<u2", (axes,))])
        for j, k in enumerate(sorted(schedule)):
            if len(schedule[k]) != axes:
                raise ValueError(f"schedule at sample {k}: {axes} (mu, bw, type3) expected")
            rec[j] = (k, [(mu & 15) | (bw & 15) << 8 | int(t3) << 12
                          for mu, bw, t3 in schedule[k]])
        fs = tmp / "schedule.bin"
        rec.tofile(fs)
        argv.append(str(fs))
    return argv


class Stream:
    """A native harness run through pipes: input records are written to its stdin as they come
    (`feed`), its output records are read from a second pipe by a thread and handed over as they
    come (`take`), so memory is bounded by a chunk and the pipes, not by the run. `finish()`
    closes the input (the harness runs to the end of it, N = 0) and returns the rest and the
    harness's printed stats. The harness's stdout/stderr go to files (a long stderr cannot block
    it)."""

    def __init__(self, argv: Callable[[str, str], list[str]], out_dtype: np.dtype,
                 what: str) -> None:
        self.what = what
        self.dtype = out_dtype
        self._tmp = tempfile.TemporaryDirectory(dir=ensure(BUILD / "native" / "runs"))
        self.tmp = Path(self._tmp.name)
        r, w = os.pipe()
        self._log = [open(self.tmp / n, "w+b") for n in ("stdout", "stderr")]  # noqa: SIM115
        self.t0 = time.perf_counter()
        self.proc = subprocess.Popen(argv("/dev/stdin", f"/dev/fd/{w}"), stdin=subprocess.PIPE,
                                     stdout=self._log[0], stderr=self._log[1], pass_fds=(w,))
        os.close(w)
        self._q: queue.Queue[bytes | None] = queue.Queue()
        self._rd = threading.Thread(target=self._reader, args=(r,), daemon=True)
        self._rd.start()
        self._rest = b""
        self.rows = 0

    def _reader(self, fd: int) -> None:
        with os.fdopen(fd, "rb", buffering=0) as f:
            while data := f.read(1 << 20):
                self._q.put(data)
        self._q.put(None)

    def feed(self, rec: np.ndarray) -> None:
        try:
            assert self.proc.stdin is not None
            self.proc.stdin.write(np.ascontiguousarray(rec).tobytes())
        except BrokenPipeError:
            self._fail()

    def take(self) -> np.ndarray:
        """The output records that arrived so far (possibly none)."""
        chunks = [self._rest]
        while True:
            try:
                data = self._q.get_nowait()
            except queue.Empty:
                break
            if data is None:
                self._q.put(None)
                break
            chunks.append(data)
        buf = b"".join(chunks)
        k = len(buf) // self.dtype.itemsize * self.dtype.itemsize
        self._rest = buf[k:]
        out = np.frombuffer(buf[:k], dtype=self.dtype)
        self.rows += out.size
        return out

    def _stderr(self) -> str:
        self._log[1].seek(0)
        return self._log[1].read().decode(errors="replace").strip()

    def _fail(self) -> None:
        code = self.proc.wait()
        err = self._stderr()
        self.close()
        raise RuntimeError(f"{self.what} failed ({code}): {err}")

    def finish(self) -> tuple[np.ndarray, dict[str, str], str]:
        """Close the input, wait for the end: (the remaining records, the stats the harness
        printed, its stderr)."""
        try:
            assert self.proc.stdin is not None
            self.proc.stdin.close()
        except BrokenPipeError:
            pass
        code = self.proc.wait()
        self._rd.join()
        if code != 0:
            self._fail()
        last = self.take()
        if self._rest:
            raise RuntimeError(f"{self.what}: a partial record at the end of its output")
        self._log[0].seek(0)
        stats = dict(kv.split("=") for kv in self._log[0].read().decode().split())
        stats.setdefault("seconds", f"{time.perf_counter() - self.t0:.6f}")
        err = self._stderr()
        self.close()
        return last, stats, err

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        for f in self._log:
            f.close()
        self._tmp.cleanup()


class InterpStream:
    """`run_interp` chunk by chunk for one axis through one harness process (the replay's rtl
    engine): `feed(a, b, index)` then `take()` for the rows done so far, `finish()` for the rest.
    Constant controls for the whole stream (cal_en, harm_en)."""

    def __init__(self, cfg: InterpConfig = InterpConfig(), clk_hz: int = interp.MIN_CLK_HZ,
                 columns: Sequence[str] = COLUMNS, cal_en: bool = False, cal_mu: int = 6,
                 harm_table: np.ndarray | None = None, harm_en: bool = False) -> None:
        self.cols = [c for c in HARNESS_COLUMNS if c in columns]
        exe = build_interp(cfg, clk_hz=clk_hz, axes=1)
        mask = sum(1 << HARNESS_COLUMNS.index(c) for c in self.cols)
        self.cal_en, self.harm_en = cal_en, harm_en
        tmp = Path(tempfile.mkdtemp(dir=ensure(BUILD / "native" / "runs")))
        self._harm_dir = tmp
        self.stream = Stream(lambda fin, fout: _interp_argv(exe, fin, fout, 0, mask, cal_mu, 6,
                                                            True, harm_table, 1, tmp),
                             _out_dtype(self.cols, 1), "native harness")
        self.stats: dict[str, str] = {}

    def feed(self, a: np.ndarray, b: np.ndarray, index: np.ndarray | None) -> None:
        self.stream.feed(pack_interp(a, b, index, 1, cal_en=self.cal_en, harm_en=self.harm_en))

    def _cols(self, data: np.ndarray) -> dict[str, np.ndarray]:
        return {c: data[f"{c}0"].astype(np.int64) for c in self.cols}

    def take(self) -> dict[str, np.ndarray]:
        return self._cols(self.stream.take())

    def finish(self) -> dict[str, np.ndarray]:
        try:
            last, self.stats, _ = self.stream.finish()
        finally:
            shutil.rmtree(self._harm_dir, ignore_errors=True)
        return self._cols(last)

    def close(self) -> None:
        self.stream.close()
        shutil.rmtree(self._harm_dir, ignore_errors=True)


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


