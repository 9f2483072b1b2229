"""Sweeps at scale: a TOML sweep specification expanded into independent jobs, run on Dask.

A spec (`scenes/sweeps/*.toml`, format in scenes/sweeps/README.md) names a job kind, an optional
base scene, fixed parameters, a grid (cross product) and/or random draws (seeded). Each job is a
pure function of its parameters (`JOBS[kind](params) -> record`, a flat dict of scalars): no
shared state, nothing written by the job. The client (this process) submits them as Dask futures
(`Client.submit(..., retries=)`; a job whose worker dies is rescheduled by the scheduler, up to
`distributed.scheduler.allowed-failures` times), streams results back with a progress bar, and
caches each finished record under build/sweeps/cache/<kind>/<key>.json, the key a sha256 of the
job kind, its parameters, the base scene's digest and the bytes of every source the jobs run
(rtl/, dsp-fw/, tb/native/, the model layers): an interrupted sweep resumes, a changed source
reruns. Results: results.csv, results.npz, summary.json and the kind's plots in --out.
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import math
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import tomllib

from ..base import cache
from ..base.atomic import write_bytes
from ..base.paths import BUILD, ROOT, ensure
from ..base.progress import Progress
from ..base.report import npz_bytes
from .scene import load as load_scene

Record = dict[str, Any]
# what a job runs (the commands' reporting is not part of a job's result)
SOURCE_DIRS = ("rtl", "dsp-fw", "tb/native", "models/hapgate/base", "models/hapgate/golden",
               "models/hapgate/flows", "models/hapgate/runners", "models/hapgate/device")
SOURCE_EXT = {".v", ".sv", ".vlt", ".c", ".h", ".cpp", ".py", ".hex", ".toml", ".rdl"}
# kinds that run less than all of SOURCE_DIRS (folders or files): the interpolator alone. A
# change elsewhere (the firmware, the device runner, another kind's module) keeps their cache,
# so a 10^9-sample soak resumes across unrelated edits.
_INTERP_ONLY = ("rtl/interp", "tb/native/interp", "models/hapgate/base", "models/hapgate/golden",
                "models/hapgate/flows", "models/hapgate/runners",
                "models/hapgate/device/__init__.py", "models/hapgate/device/sweep.py")
# The fault-injection campaign (seu) runs the virtual device's gateware, firmware and harness
# and the Python they are built and classified with, named file by file where a folder also
# holds other work (the SoC, the board tops, other harnesses): a campaign of hours resumes
# across edits there.
_DEVICE = ("rtl/interp", "rtl/commutation", "rtl/dac_sched", "rtl/bus", "rtl/capture",
           "rtl/top", "rtl/include", "rtl/regs", "dsp-fw/src", "dsp-fw/include",
           "tb/native/device", "tb/native/vl_internals.h", "models/hapgate/base",
           *(f"models/hapgate/golden/{m}.py" for m in (
               "__init__", "angle", "calib", "commutation", "configs", "enccal", "encsig",
               "interp", "interpcfg", "kinematics", "pclink", "regmap", "sine", "top")),
           "models/hapgate/configs.toml",
           *(f"models/hapgate/flows/{m}.py" for m in ("__init__", "flow", "regmap", "saboteur")),
           *(f"models/hapgate/runners/{m}.py" for m in (
               "__init__", "cosim", "covbuild", "funcov", "native", "records")),
           "models/hapgate/device")
KIND_SOURCES: dict[str, tuple[str, ...]] = {
    "soak": (*_INTERP_ONLY, "models/hapgate/device/soak.py"),
    "calib_mc": (*_INTERP_ONLY, "models/hapgate/device/calib_mc.py"),
    "seu": _DEVICE}
CACHE = BUILD / "sweeps" / "cache"


class SweepError(ValueError):
    """A malformed sweep specification (the message names the file and the key)."""


# ---------------------------------------------------------------------------------- the spec
@dataclass(frozen=True)
class Spec:
    name: str
    kind: str
    path: Path
    base: Path | None = None
    seed: int = 1
    fixed: Mapping[str, Any] = field(default_factory=dict)
    grid: Mapping[str, tuple[Any, ...]] = field(default_factory=dict)
    random: Mapping[str, tuple[str, tuple[float, ...]]] = field(default_factory=dict)
    samples: int = 0                         # random draws (0: grid only)
    retries: int = 2

    def jobs(self) -> list[Record]:
        """The job parameter sets: grid cross product (x random draws), each with its seed."""
        keys = list(self.grid)
        combos = list(itertools.product(*(self.grid[k] for k in keys))) or [()]
        n_rand = max(self.samples, 1) if self.random else 1
        rng = np.random.default_rng(self.seed)
        draws: dict[str, np.ndarray] = {}
        for k, (dist, a) in self.random.items():
            size = len(combos) * n_rand
            if dist == "uniform":
                draws[k] = rng.uniform(a[0], a[1], size)
            elif dist == "normal":
                draws[k] = rng.normal(a[0], a[1], size)
            else:                                         # loguniform
                draws[k] = np.exp(rng.uniform(math.log(a[0]), math.log(a[1]), size))
        out: list[Record] = []
        for i, (c, _r) in enumerate(itertools.product(range(len(combos)), range(n_rand))):
            p: Record = dict(self.fixed)
            p.update(dict(zip(keys, combos[c])))
            for k in draws:
                p[k] = float(draws[k][i])
            p.setdefault("seed", self.seed * 1_000_003 + i)
            if self.base is not None:
                p["base"] = str(self.base)
            out.append(p)
        return out


def _values(v: object, key: str, src: str) -> tuple[Any, ...]:
    if isinstance(v, list) and v:
        return tuple(v)
    if isinstance(v, dict) and len(v) == 1:
        (how, a), = v.items()
        if how in ("logspace", "linspace") and isinstance(a, list) and len(a) == 3 \
                and isinstance(a[2], int) and a[2] >= 1:
            if how == "logspace":
                if not (a[0] > 0 and a[1] > 0):
                    raise SweepError(f"{src}: grid.{key}: logspace bounds must be > 0")
                xs = np.geomspace(float(a[0]), float(a[1]), a[2])
            else:
                xs = np.linspace(float(a[0]), float(a[1]), a[2])
            return tuple(float(f"{x:.6g}") for x in xs)
    raise SweepError(f"{src}: grid.{key}: a non-empty array, or {{logspace = [lo, hi, n]}} / "
                     "{linspace = [lo, hi, n]}")


def load(path: str | Path) -> Spec:
    """Read and validate a sweep spec (SweepError names the file and the key)."""
    path = Path(path)
    src = str(path)
    try:
        d = tomllib.loads(path.read_text())
    except OSError as exc:
        raise SweepError(f"{src}: cannot read: {exc.strerror}") from exc
    except tomllib.TOMLDecodeError as exc:
        raise SweepError(f"{src}: {exc}") from exc
    unknown = set(d) - {"sweep", "fixed", "grid", "random"}
    if unknown:
        raise SweepError(f"{src}: {sorted(unknown)[0]}: unknown table (sweep, fixed, grid, "
                         "random)")
    sw = d.get("sweep")
    if not isinstance(sw, dict):
        raise SweepError(f"{src}: sweep: missing table [sweep]")
    bad = set(sw) - {"name", "job", "base", "seed", "samples", "retries"}
    if bad:
        raise SweepError(f"{src}: sweep.{sorted(bad)[0]}: unknown key")
    kind = sw.get("job")
    if kind not in JOBS:
        raise SweepError(f"{src}: sweep.job: {kind!r} is not a job kind ({', '.join(JOBS)})")
    for key, lo in (("seed", 0), ("samples", 0), ("retries", 0)):
        v = sw.get(key, 0)
        if not isinstance(v, int) or isinstance(v, bool) or v < lo:
            raise SweepError(f"{src}: sweep.{key}: an integer >= {lo}")
    base = None
    if "base" in sw:
        base = (path.parent / str(sw["base"])).resolve()
        if not base.is_file():
            raise SweepError(f"{src}: sweep.base: {sw['base']!r} not found beside the spec")
    grid = {k: _values(v, k, src) for k, v in (d.get("grid") or {}).items()}
    rand: dict[str, tuple[str, tuple[float, ...]]] = {}
    for k, v in (d.get("random") or {}).items():
        if not (isinstance(v, dict) and len(v) == 1):
            raise SweepError(f"{src}: random.{k}: {{uniform|normal|loguniform = [a, b]}}")
        (dist, a), = v.items()
        if dist not in ("uniform", "normal", "loguniform") or not isinstance(a, list) \
                or len(a) != 2 or not all(isinstance(x, int | float) for x in a):
            raise SweepError(f"{src}: random.{k}: {{uniform|normal|loguniform = [a, b]}}")
        rand[k] = (dist, (float(a[0]), float(a[1])))
    if rand and int(sw.get("samples", 0)) < 1:
        raise SweepError(f"{src}: sweep.samples: random parameters need samples >= 1")
    spec = Spec(name=str(sw.get("name", path.stem)), kind=str(kind), path=path, base=base,
                seed=int(sw.get("seed", 1)), fixed=dict(d.get("fixed") or {}), grid=grid,
                random=rand, samples=int(sw.get("samples", 0)),
                retries=int(sw.get("retries", 2)))
    check = job_function(spec.kind, "check")
    if check is not None:
        jobs = spec.jobs()
        for i, why in _representatives(spec, jobs):
            try:
                check(jobs[i])
            except (ValueError, KeyError) as exc:
                raise SweepError(f"{src}: {exc}{why}") from exc
    return spec


def _representatives(spec: Spec, jobs: list[Record]) -> list[tuple[int, str]]:
    """Jobs that together carry every grid value and each random parameter's extremes (with the
    reason, for the message): a value the job refuses is found before anything runs."""
    reps: dict[int, str] = {0: ""}
    for k, values in spec.grid.items():
        col = [j[k] for j in jobs]
        for v in values:
            i = col.index(v)
            reps.setdefault(i, f" (job {i}: grid {k} = {v!r})")
    for k in spec.random:
        col = np.asarray([float(j[k]) for j in jobs])
        for i in (int(col.argmin()), int(col.argmax())):
            reps.setdefault(i, f" (job {i}: random {k} = {col[i]:.6g})")
    return sorted(reps.items())


# ---------------------------------------------------------------------------------- the jobs
def selftest_job(p: Mapping[str, Any]) -> Record:
    """A cheap pure job for the runner's own tests: seeded numbers, and (die_once = a marker
    path) a worker that kills itself the first time, to prove the job is retried."""
    import os
    marker = p.get("die_once")
    if marker and not Path(str(marker)).exists():
        Path(str(marker)).write_text(str(os.getpid()))
        os._exit(1)                                   # the worker process dies mid-job
    rng = np.random.default_rng(int(p["seed"]))
    x = rng.normal(float(p.get("mu", 0.0)), 1.0, int(p.get("n", 1000)))
    return {"mean": float(x.mean()), "sum_sq": float((x * x).sum()), "pid": os.getpid()}


# job kind -> the module of hapgate.device that holds `job(params) -> record` (and optionally
# `check(params)`, run at load on the first job to refuse a bad spec before any worker starts)
JOBS: dict[str, str] = {"selftest": "sweep", "zwidth": "zwidth", "soak": "soak",
                        "calib_mc": "calib_mc", "seu": "seu"}


def job_function(kind: str, name: str = "job") -> Callable[[Mapping[str, Any]], Record] | None:
    from importlib import import_module
    if kind == "selftest":
        return selftest_job if name == "job" else None
    mod = import_module(f"hapgate.device.{JOBS[kind]}")
    return getattr(mod, name, None)


# columns a job adds that vary between identical runs (excluded from reproducibility checks)
VOLATILE = ("pid", "wall_s", "cached", "samples_per_s", "cpu_s", "harness_s", "gen_s",
            "harness_cpu_s")


def run_job(kind: str, params: Mapping[str, Any]) -> Record:
    """What a worker runs: the job, timed (the wall time is reported, never part of the key)."""
    t0 = time.perf_counter()
    fn = job_function(kind)
    assert fn is not None
    rec = dict(fn(params))
    rec["wall_s"] = time.perf_counter() - t0
    return rec


# ---------------------------------------------------------------------------------- the cache
def sources_digest(root: Path = ROOT, kind: str | None = None) -> str:
    """sha256 over the bytes (and relative paths) of every source a job (of this kind) may
    run: SOURCE_DIRS, or the kind's narrower KIND_SOURCES."""
    files = []
    for d in KIND_SOURCES.get(kind or "", SOURCE_DIRS):
        top = root / d
        files += [f for f in ([top] if top.is_file() else sorted(top.rglob("*")))
                  if f.is_file() and f.suffix in SOURCE_EXT and "__pycache__" not in f.parts]
    return cache.digest(files=files, data=[(str(f.relative_to(root)), f.stat().st_size)
                                           for f in files],
                        length=None, algorithm="sha256")


def job_key(kind: str, params: Mapping[str, Any], sources: str) -> str:
    p = dict(params)
    if "base" in p:                       # the base scene by content, not by path
        p["base"] = load_scene(p["base"]).digest()
    return cache.digest(data={"kind": kind, "params": p, "sources": sources}, length=None,
                        algorithm="sha256")


# ---------------------------------------------------------------------------------- the run
@dataclass
class SweepResult:
    spec: Spec
    params: list[Record]
    records: list[Record]
    cached: list[bool]
    wall_s: float
    workers: int
    scheduler: str
    out: Path | None = None
    retried: int = 0

    def rows(self) -> list[Record]:
        return [{**p, **r, "cached": c} for p, r, c in zip(self.params, self.records,
                                                           self.cached)]


def _client(scheduler: str | None, workers: int) -> Any:
    import dask
    from distributed import Client, LocalCluster
    dask.config.set({"distributed.scheduler.allowed-failures": 3,
                     "distributed.worker.daemon": False})
    if scheduler:
        return Client(scheduler, timeout="20s")
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                           dashboard_address=":0", silence_logs=40)
    return Client(cluster)


def run(spec: Spec, workers: int = 2, scheduler: str | None = None,
        cache: Path | None = CACHE, progress: bool = True,
        jobs: Iterable[Record] | None = None) -> SweepResult:
    """Run every job of the spec (those not cached) on Dask and collect the records in job
    order. `cache=None` disables the cache."""
    from distributed import as_completed
    params = list(spec.jobs() if jobs is None else jobs)
    srcs = sources_digest(kind=spec.kind)
    keys = [job_key(spec.kind, p, srcs) for p in params]
    cdir = ensure(cache / spec.kind) if cache is not None else None
    records: list[Record | None] = [None] * len(params)
    cached = [False] * len(params)
    if cdir is not None:
        for i, k in enumerate(keys):
            f = cdir / f"{k}.json"
            if f.exists():
                records[i] = json.loads(f.read_text())
                cached[i] = True
    todo = [i for i, r in enumerate(records) if r is None]
    t0 = time.perf_counter()
    bar = Progress(total=max(len(params), 1), label=f"sweep {spec.name}", unit="jobs",
                   delay_s=0.0 if progress else math.inf)
    bar(len(params) - len(todo))
    retried = 0
    used = workers
    if todo:
        client = _client(scheduler, workers)
        try:
            used = len(client.scheduler_info().get("workers", {})) or workers
            futs = {client.submit(run_job, spec.kind, params[i], key=f"{spec.kind}-{keys[i]}",
                                  retries=spec.retries, pure=False): i for i in todo}
            done = len(params) - len(todo)
            for fut in as_completed(futs):
                i = futs[fut]
                rec = fut.result()
                records[i] = rec
                if cdir is not None:
                    tmp = cdir / f".{keys[i]}.tmp"
                    tmp.write_text(json.dumps(rec, default=_json_default))
                    tmp.replace(cdir / f"{keys[i]}.json")
                done += 1
                bar(done)
            retried = _retries_seen(client, [f"{spec.kind}-{keys[i]}" for i in todo],
                                    spec.retries)
        finally:
            cluster = client.cluster if scheduler is None else None
            client.close()
            if cluster is not None:                 # ours: shut the workers down cleanly
                cluster.close()
    bar.close()
    return SweepResult(spec, params, [r or {} for r in records], cached,
                       time.perf_counter() - t0, used, scheduler or f"LocalCluster({workers})",
                       retried=retried)


def _retries_seen(client: Any, keys: list[str], budget: int) -> int:
    """How many of these jobs the scheduler ran more than once (a lost worker, a retry)."""
    def count(dask_scheduler: Any, keys: list[str], budget: int) -> int:   # on the scheduler
        n = 0
        for k in keys:
            ts = dask_scheduler.tasks.get(k)
            if ts is not None and (getattr(ts, "suspicious", 0) or
                                   getattr(ts, "retries", budget) < budget):
                n += 1
        return n
    try:
        return int(client.run_on_scheduler(count, keys=keys, budget=budget))
    except Exception:                                   # noqa: BLE001 - informative only
        return -1


def _json_default(x: object) -> object:
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, Path):
        return str(x)
    raise TypeError(f"not JSON-able: {type(x).__name__}")


# ---------------------------------------------------------------------------------- outputs
def write(res: SweepResult, out: Path) -> list[Path]:
    """results.csv, results.npz, summary.json (and the kind's plots via REPORTS)."""
    out = ensure(out)
    rows = res.rows()
    cols: list[str] = []
    for r in rows:
        cols += [k for k in r if k not in cols]
    fh = io.StringIO(newline="")
    w = csv.DictWriter(fh, fieldnames=cols)
    w.writeheader()
    for r in rows:
        w.writerow({k: r.get(k, "") for k in cols})
    write_bytes(out / "results.csv", fh.getvalue())
    arrays: dict[str, np.ndarray] = {}
    for c in cols:
        vals = [r.get(c) for r in rows]
        if all(isinstance(v, bool | int | float | np.generic) for v in vals):
            arrays[c] = np.asarray(vals)
        else:
            arrays[c] = np.asarray(["" if v is None else str(v) for v in vals])
    write_bytes(out / "results.npz", npz_bytes(arrays))
    summary = {"name": res.spec.name, "job": res.spec.kind, "spec": str(res.spec.path),
               "jobs": len(rows), "cached": int(sum(res.cached)), "wall_s": res.wall_s,
               "workers": res.workers, "scheduler": res.scheduler, "retried": res.retried}
    write_bytes(out / "summary.json", json.dumps(summary, indent=2))
    res.out = out
    return [out / "results.csv", out / "results.npz", out / "summary.json"]


def same_records(a: list[Record], b: list[Record]) -> bool:
    """Equal records, the volatile columns (pids, timings) aside."""
    strip = [{k: v for k, v in r.items() if k not in VOLATILE} for r in a]
    strip_b = [{k: v for k, v in r.items() if k not in VOLATILE} for r in b]
    return strip == strip_b
