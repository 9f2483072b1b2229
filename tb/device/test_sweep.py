"""The sweep runner on Dask (hapgate.device.sweep) and the Z-width physics check.

Runner: a tiny sweep of cheap pure jobs gives complete results identical to the jobs run one by
one; a worker killed mid-job has its job rerun; a second run comes from the cache. A malformed
spec exits 2 naming the file and key, writing nothing. Z-width: the idealised sampled wall
follows the passivity bound 2b/T and scales with 1/T; the device (rtl gateware + firmware) at
B = 0 is stable at half and unstable at twice the latency-corrected bound (b - |B|)/(T/2 + tau).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest
from hapgate.commands import sweep as sweep_cmd
from hapgate.device import sweep, zwidth
from hapgate.device.scene import load as load_scene

SCENES = Path(__file__).resolve().parents[2] / "scenes" / "sweeps"


def _spec(tmp: Path, extra: str = "") -> Path:
    f = tmp / "tiny.toml"
    f.write_text(f"""[sweep]
name = "tiny"
job = "selftest"
seed = 5
samples = 2
[fixed]
n = 2000
{extra}
[grid]
mu = [0.0, 1.0, 2.0]
[random]
scale = {{ uniform = [1.0, 2.0] }}
""", encoding="utf-8")
    return f


def test_tiny_sweep_complete_identical_and_cached(tmp_path: Path) -> None:
    spec = sweep.load(_spec(tmp_path))
    jobs = spec.jobs()
    assert len(jobs) == 6 and len({j["seed"] for j in jobs}) == 6
    cache = tmp_path / "cache"
    res = sweep.run(spec, workers=2, cache=cache, progress=False)
    assert len(res.records) == 6 and all("mean" in r for r in res.records)
    assert not any(res.cached)
    one_by_one = [sweep.run_job("selftest", p) for p in jobs]
    assert sweep.same_records(res.records, one_by_one)
    assert len({r["pid"] for r in res.records}) >= 1
    # the means follow each job's own mu (results are in job order, not completion order)
    for p, r in zip(jobs, res.records):
        assert abs(r["mean"] - p["mu"]) < 0.1
    again = sweep.run(spec, workers=2, cache=cache, progress=False)
    assert all(again.cached)
    assert sweep.same_records(again.records, res.records)
    out = tmp_path / "out"
    files = sweep.write(again, out)
    assert all(f.exists() for f in files)
    assert (out / "results.csv").read_text().count("\n") == 7


def test_killed_worker_job_is_rerun(tmp_path: Path) -> None:
    marker = tmp_path / "died"
    spec = sweep.load(_spec(tmp_path, f'die_once = "{marker}"'))
    res = sweep.run(spec, workers=2, cache=None, progress=False)
    assert marker.exists(), "no worker died: the test did not test the rerun"
    dead_pid = int(marker.read_text())
    assert len(res.records) == 6 and all("mean" in r for r in res.records)
    assert dead_pid not in {r["pid"] for r in res.records}
    assert res.retried >= 1
    clean = [sweep.run_job("selftest", {**p, "die_once": ""}) for p in spec.jobs()]
    assert sweep.same_records(res.records, clean)


def test_cache_key_covers_parameters_and_sources() -> None:
    p = {"seed": 1, "mu": 0.0}
    k = sweep.job_key("selftest", p, "src-a")
    assert k == sweep.job_key("selftest", dict(p), "src-a")
    assert k != sweep.job_key("selftest", {**p, "mu": 0.5}, "src-a")
    assert k != sweep.job_key("selftest", p, "src-b")


def test_kind_sources_narrow_the_key(tmp_path: Path) -> None:
    """The soak's and the Monte-Carlo's cache keys cover the interpolator's sources and not the
    firmware's or another kind's module; the full set covers everything; every listed path
    exists in the checkout (a rename cannot silently drop a dependency)."""
    root = sweep.ROOT
    for paths in sweep.KIND_SOURCES.values():
        for d in paths:
            assert (root / d).exists(), d
    for d in ("rtl/interp", "dsp-fw/src", "models/hapgate/device"):
        (tmp_path / d).mkdir(parents=True)
    (tmp_path / "models/hapgate/device/soak.py").write_text("x = 1\n")
    (tmp_path / "models/hapgate/device/zwidth.py").write_text("x = 1\n")
    (tmp_path / "rtl/interp/a.v").write_text("module a; endmodule\n")
    (tmp_path / "dsp-fw/src/f.c").write_text("int f;\n")

    def digests() -> tuple[str, str, str]:
        return (sweep.sources_digest(tmp_path, "soak"), sweep.sources_digest(tmp_path),
                sweep.sources_digest(tmp_path, "calib_mc"))
    soak0, all0, mc0 = digests()
    (tmp_path / "dsp-fw/src/f.c").write_text("int g;\n")
    (tmp_path / "models/hapgate/device/zwidth.py").write_text("x = 2\n")
    soak1, all1, mc1 = digests()
    assert soak1 == soak0 and mc1 == mc0 and all1 != all0
    (tmp_path / "models/hapgate/device/soak.py").write_text("x = 2\n")
    soak2, _, mc2 = digests()
    assert soak2 != soak1 and mc2 == mc1
    (tmp_path / "rtl/interp/a.v").write_text("module b; endmodule\n")
    soak3, _, mc3 = digests()
    assert soak3 != soak2 and mc3 != mc2


@pytest.mark.parametrize("text, key", [
    ("[sweep]\njob = 'nope'\n", "sweep.job"),
    ("[sweep]\njob = 'selftest'\nbase = 'missing.toml'\n", "sweep.base"),
    ("[sweep]\njob = 'selftest'\n[grid]\nk = []\n", "grid.k"),
    ("[sweep]\njob = 'selftest'\n[grid]\nk = { logspace = [0, 1, 3] }\n", "grid.k"),
    ("[sweep]\njob = 'selftest'\n[random]\nk = { uniform = [0, 1] }\n", "sweep.samples"),
    ("[sweep]\njob = 'selftest'\nfoo = 1\n", "sweep.foo"),
    ("[sweep]\njob = 'zwidth'\nbase = 'b.toml'\n[fixed]\n'run.position' = 'coarse'\n",
     "run.position"),
    ("[sweep]\njob = 'zwidth'\nbase = 'b.toml'\n[fixed]\nvelocity = 'kalman'\n", "velocity"),
    ("[sweep]\njob = 'calib_mc'\n[fixed]\nengine = 'spice'\n", "fixed.engine"),
    ("[sweep]\njob = 'calib_mc'\n[fixed]\ntravel_lines = 300\n", "fixed.travel_lines"),
    ("[sweep\n", "line 1"),
    # a value the job refuses in a later grid point or random draw, not only in job 0
    ("[sweep]\njob = 'zwidth'\nbase = 'b.toml'\n[grid]\n'env.k' = [200.0, 500.0, -40.0]\n",
     "grid env.k = -40.0"),
    ("[sweep]\njob = 'zwidth'\nbase = 'b.toml'\nsamples = 40\n[fixed]\n'env.b' = 0.0\n"
     "[random]\n'env.k' = { uniform = [-2000.0, 30000.0] }\n", "random env.k = -"),
])
def test_bad_spec_exit_2_names_file_and_key(tmp_path: Path, text: str, key: str,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "b.toml").write_text((SCENES / "zwidth_base.toml").read_text())
    f = tmp_path / "bad.toml"
    f.write_text(text)
    out = tmp_path / "out"
    args = argparse.Namespace(spec=f, scheduler=None, workers=1, out=out, no_cache=True,
                              limit=0)
    assert sweep_cmd.main(args) == 2
    err = capsys.readouterr().err
    assert str(f) in err and key in err
    assert not out.exists()


def test_every_shipped_spec_loads() -> None:
    for f in sorted(SCENES.glob("*.toml")):
        if f.name.endswith("_base.toml"):
            load_scene(f)
        else:
            assert sweep.load(f).jobs()


# ---------------------------------------------------------------------------------- Z-width
def test_ideal_sampled_wall_follows_passivity_bound() -> None:
    m, b = 0.0364, 1.08
    k1 = zwidth.ideal_kmax(m, b, 1e-3)
    k10 = zwidth.ideal_kmax(m, b, 1e-4)
    assert k1 == pytest.approx(2 * b / 1e-3, rel=0.02)
    assert k10 == pytest.approx(2 * b / 1e-4, rel=0.02)
    assert k10 / k1 == pytest.approx(10.0, rel=0.02)


@pytest.mark.parametrize("servo_hz", [1000, 10000])
def test_device_zwidth_at_b0_brackets_the_bound(servo_hz: int) -> None:
    base = str(SCENES / "zwidth_base.toml")
    g = zwidth.geometry(load_scene(base))
    k_pred = zwidth.latency_bound(g["b_nsm"], 0.0, 1.0 / servo_hz)
    assert k_pred < 2 * g["b_nsm"] * servo_hz          # the latency only lowers it
    low = zwidth.job({"base": base, "env.k": 0.5 * k_pred, "run.servo_hz": servo_hz})
    high = zwidth.job({"base": base, "env.k": 2.0 * k_pred, "run.servo_hz": servo_hz})
    assert low["stable"], low
    assert not high["stable"], high
    assert high["a_late_um"] > 4 * low["a_late_um"]
    # with wall damping B the bound (b - |B|)/(T/2 + tau) shrinks; inside it the wall is stable
    bw = 0.5 * g["b_nsm"]
    damped = zwidth.job({"base": base, "env.k": 0.5 * zwidth.latency_bound(g["b_nsm"], bw,
                                                                          1.0 / servo_hz),
                         "env.b": bw, "run.servo_hz": servo_hz})
    assert damped["stable"], damped


def test_scene_k_beyond_safety_limit_only_with_test_limits() -> None:
    base = load_scene(SCENES / "zwidth_base.toml")
    assert base.override({"env.k": 50_000.0}).env.k == 50_000.0
    off = base.override({"firmware.test_limits": False, "env.k": 3500.0})
    with pytest.raises(ValueError, match=r"env\.k.*HG_SCENE_K_MAX\)"):
        off.override({"env.k": 3600.0})
    with pytest.raises(ValueError, match=r"env\.k.*HG_SCENE_K_MAX_TEST"):
        base.override({"env.k": 50_001.0})
