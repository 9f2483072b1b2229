"""`hapgate scene run|check` plumbing and the [expect] rules (hapgate.device.result).

The closed-loop runner is replaced by a stand-in module that returns a synthetic RunResult: these
tests check exit codes, what is written and printed, and the expect rules — not physics (the
stand-in's numbers mean nothing)."""

from __future__ import annotations

import dataclasses
import io
import json
import re
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest
from hapgate.base.paths import ROOT
from hapgate.base.progress import Progress
from hapgate.commands import cli
from hapgate.commands import scene as scene_cmd
from hapgate.device import result as res
from hapgate.device.scene import ExpectCfg, Scene, SceneError, load

WALL = ROOT / "scenes" / "wall.toml"


def synthetic(scene: Scene, metrics: dict, arrays: bool = True) -> res.RunResult:
    """A RunResult with the documented shapes (arbitrary values)."""
    n, f = 200, 40
    t = np.arange(n) * 1e-4
    rng = np.random.default_rng(0)
    a: dict[str, np.ndarray] = {}
    if arrays:
        want = {"q": (n, 3), "p": (n, 3), "f_hand": (n, 3), "tau": (n, 3)}
        a["t"] = t
        for k, shape in want.items():
            if k in scene.run.record:
                a[k] = rng.normal(size=shape) * 1e-3 + (0.07 if k == "p" else 0.0)
        if "dac" in scene.run.record:
            a["dac"] = rng.integers(-8000, 8000, size=(f, 6)).astype(np.int16)
            a["dac_t"] = np.arange(f) * 16e-6
    return res.RunResult(
        scene=scene, sim_s=scene.run.duration_s, wall_s=0.25, rtf=scene.run.duration_s / 0.25,
        fidelity=scene.run.fidelity, clk_hz=8_000_000, axes=scene.run.axes,
        built=["interp x3 (rtl)", "firmware"], skipped=["trace"], arrays=a,
        events=[{"kind": "dropout", "axis": 1, "cause_s": 0.3, "zero_torque_s": 0.300017,
                 "reaction_us": 17.0}],
        metrics=metrics,
        per_axis={"pos_err_rms_counts": [1.0, 2.0, 3.0][:len(scene.run.axes)]})


class DeviceError(RuntimeError):
    """Stands for the runner's own error class (a clear message, no traceback)."""


class FakeRunner:
    def __init__(self, metrics: dict | None = None, exc: Exception | None = None,
                 arrays: bool = True) -> None:
        self.metrics = metrics if metrics is not None else {}
        self.exc, self.arrays = exc, arrays
        self.calls: list[Scene] = []

    def run(self, scene: Scene, progress, out_dir=None) -> res.RunResult:  # noqa: ANN001
        self.calls.append(scene)
        progress(scene.run.duration_s / 2)
        progress(scene.run.duration_s, scene.run.duration_s)   # (done, total) also accepted
        if self.exc is not None:
            raise self.exc
        return synthetic(scene, self.metrics, self.arrays)


@pytest.fixture
def fake(monkeypatch: pytest.MonkeyPatch):  # noqa: ANN201
    """Install a stand-in hapgate.device.runner; returns a setter for its behaviour."""
    def install(**kw: object) -> FakeRunner:
        fr = FakeRunner(**kw)  # type: ignore[arg-type]
        mod = types.ModuleType("hapgate.device.runner")
        mod.run = fr.run  # type: ignore[attr-defined]
        mod.DeviceError = DeviceError  # type: ignore[attr-defined]
        monkeypatch.setattr(scene_cmd, "runner", mod)   # the name `hapgate scene` runs
        return fr
    return install


def run_cli(*argv: str) -> int:
    return cli.main(["scene", *map(str, argv)])


# --------------------------------------------------------------------------- expect rules

def test_expect_rules_pass_fail_and_not_measured() -> None:
    e = ExpectCfg(max_force_error_n=0.05, zero_torque_within_us=20.0, min_torque_ratio=0.97,
                  max_slips=0, fw_error="AXIS_FAULT")
    ok = {"force_error_n": 0.05, "zero_torque_us": 19.9, "torque_ratio": 0.97, "slips": 0,
          "fw_error": "AXIS_FAULT"}
    got = res.evaluate(e, ok)
    assert [o.key for o in got] == ["max_force_error_n", "zero_torque_within_us",
                                    "min_torque_ratio", "max_slips", "fw_error"]
    assert all(o.passed for o in got) and res.verdict(got) == "PASS"   # limits are inclusive
    for metric, bad in (("force_error_n", 0.0501), ("zero_torque_us", 20.1),
                        ("torque_ratio", 0.969), ("slips", 1), ("fw_error", "NONE")):
        out = res.evaluate(e, {**ok, metric: bad})
        failed = [o for o in out if not o.passed]
        assert [o.metric for o in failed] == [metric] and failed[0].reason
        assert res.verdict(out) == "FAIL"
    for metric in ok:                       # a metric the run did not compute fails
        out = res.evaluate(e, {k: v for k, v in ok.items() if k != metric})
        failed = [o for o in out if not o.passed]
        assert [(o.metric, o.reason, o.measured) for o in failed] == [(metric, "not measured",
                                                                       None)]
    nan = res.evaluate(e, {**ok, "force_error_n": float("nan")})
    assert [o.reason for o in nan if not o.passed] == ["not finite"]
    wrong = res.evaluate(e, {**ok, "slips": "many"})
    assert [o.reason for o in wrong if not o.passed] == ["not a number"]
    assert res.verdict(res.evaluate(ExpectCfg(), {})) == "PASS"      # no checks: nothing fails


def test_max_torque_ratio_is_an_upper_bound() -> None:
    e = ExpectCfg(min_torque_ratio=0.97, max_torque_ratio=0.99)
    assert res.verdict(res.evaluate(e, {"torque_ratio": 0.98})) == "PASS"
    assert res.verdict(res.evaluate(e, {"torque_ratio": 0.995})) == "FAIL"
    assert res.verdict(res.evaluate(e, {"torque_ratio": 0.965})) == "FAIL"


def test_every_expect_key_has_a_rule() -> None:
    assert set(res.METRIC_OF) == {f.name for f in dataclasses.fields(ExpectCfg)}


# --------------------------------------------------------------------------- the command

GOOD = {"force_error_n": 0.01, "zero_torque_us": 17.0}


def test_run_writes_outputs_and_exits_0(fake, tmp_path: Path, capsys) -> None:  # noqa: ANN001
    fr = fake(metrics=GOOD)
    out = tmp_path / "out"
    assert run_cli("run", WALL, "--out", out) == 0
    assert len(fr.calls) == 1 and fr.calls[0] == load(WALL)
    printed = capsys.readouterr().out
    for needle in ("built:   interp x3 (rtl); firmware", "skipped: trace", "real-time x",
                   "pos_err_rms_counts", "force_error_n", "safety events", "reaction_us",
                   "max_force_error_n", "PASS", "result: PASS (2/2 expects hold"):
        assert needle in printed, needle
    names = sorted(p.name for p in out.iterdir())
    assert names == ["dac.png", "force_depth.png", "position.png", "run.npz", "summary.json",
                     "torque.png"]
    s = json.loads((out / "summary.json").read_text())
    for k in ("sim_s", "wall_s", "rtf", "fidelity", "clk_hz", "axes", "built", "result",
              "expects", "metrics"):
        assert k in s, k
    assert s["result"] == "PASS" and s["axes"] == [0, 1, 2] and s["clk_hz"] == 8_000_000
    assert [e["result"] for e in s["expects"]] == ["PASS", "PASS"]
    assert s["scene"]["env"]["k"] == 2000.0
    ref = synthetic(load(WALL), GOOD).arrays
    with np.load(out / "run.npz") as z:
        assert sorted(z.files) == sorted(ref)
        for k in ref:
            assert np.array_equal(z[k], ref[k]) and z[k].dtype == ref[k].dtype


def test_failed_expect_exits_1(fake, tmp_path: Path, capsys) -> None:  # noqa: ANN001
    fake(metrics={"force_error_n": 0.2, "zero_torque_us": 17.0})
    assert run_cli("run", WALL, "--out", tmp_path) == 1
    assert "result: FAIL (1/2 expects hold" in capsys.readouterr().out
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["result"] == "FAIL" and s["expects"][0]["result"] == "FAIL"


def test_unmeasured_expect_exits_1(fake, tmp_path: Path) -> None:  # noqa: ANN001
    fake(metrics={"force_error_n": 0.01})
    assert run_cli("run", WALL, "--out", tmp_path) == 1
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["expects"][1] == {"key": "zero_torque_within_us", "limit": 20.0,
                               "metric": "zero_torque_us", "measured": None, "result": "FAIL",
                               "reason": "not measured"}


def test_plots_only_for_recorded_data(fake, tmp_path: Path) -> None:  # noqa: ANN001
    scene = tmp_path / "s.toml"
    scene.write_text('[run]\nrecord = ["q", "dac"]\n[env]\nkind = "viscous"\nb = 1.0\n')
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "torque.png").write_bytes(b"stale")   # from an earlier run
    fake()
    assert run_cli("run", scene, "--out", tmp_path / "out") == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "dac.png", "position.png", "run.npz", "summary.json"]


def test_a_recorded_name_the_run_did_not_produce_is_reported(fake, tmp_path: Path,  # noqa: ANN001
                                                             capsys) -> None:
    scene = tmp_path / "s.toml"
    scene.write_text('[run]\nrecord = ["q", "pos", "adc"]\n')
    fake()                                  # the stand-in produces q but neither pos nor adc
    assert run_cli("run", scene, "--out", tmp_path / "o") == 0
    assert "WARNING: recorded but not produced by the run: pos, adc" in capsys.readouterr().out
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["missing_records"] == ["pos", "adc"]


def test_default_out_is_build_scenes_name(fake, tmp_path: Path, monkeypatch) -> None:  # noqa: ANN001
    monkeypatch.setattr(scene_cmd, "BUILD", tmp_path / "build")
    fake(arrays=False)
    src = tmp_path / "my_run.toml"
    src.write_text("[run]\nduration_s = 0.01\n")
    assert run_cli("run", src) == 0
    assert sorted(p.name for p in (tmp_path / "build" / "scenes" / "my_run").iterdir()) == [
        "run.npz", "summary.json"]


@pytest.mark.parametrize("text", ["[run]\nduration_s = -1\n", "[run\n", b"# \xff\n"],
                         ids=["bad_value", "bad_toml", "not_utf8"])
def test_malformed_scene_exits_2_and_writes_nothing(fake, tmp_path: Path, capsys,  # noqa: ANN001
                                                    text: str | bytes) -> None:
    fr = fake(metrics=GOOD)
    src = tmp_path / "bad.toml"
    src.write_bytes(text if isinstance(text, bytes) else text.encode())
    out = tmp_path / "out"
    assert run_cli("run", src, "--out", out) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {src}") and not out.exists() and fr.calls == []


def test_missing_scene_exits_2(fake, tmp_path: Path, capsys) -> None:  # noqa: ANN001
    fake()
    assert run_cli("run", tmp_path / "nope.toml", "--out", tmp_path / "o") == 2
    assert "nope.toml: cannot read" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_bad_out_exits_2_before_running(fake, tmp_path: Path, capsys) -> None:  # noqa: ANN001
    fr = fake(metrics=GOOD)
    afile = tmp_path / "afile"
    afile.write_text("x")
    assert run_cli("run", WALL, "--out", afile) == 2
    assert "exists and is not a folder" in capsys.readouterr().err
    assert run_cli("run", WALL, "--out", afile / "sub") == 2
    assert "cannot create" in capsys.readouterr().err
    assert fr.calls == [] and afile.read_text() == "x"


def test_runner_refusal_exits_2_and_failure_exits_3(fake, tmp_path: Path, capsys) -> None:  # noqa: ANN001
    fake(exc=SceneError("scenes/wall.toml: run.fidelity: not built here"))
    assert run_cli("run", WALL, "--out", tmp_path) == 2
    assert "run.fidelity: not built here" in capsys.readouterr().err
    fake(exc=RuntimeError("harness died"))
    assert run_cli("run", WALL, "--out", tmp_path) == 3
    err = capsys.readouterr().err
    assert "the run failed: harness died" in err and "Traceback" in err   # a bug: traceback
    fake(exc=DeviceError("fidelity 'model': not implemented"))
    assert run_cli("run", WALL, "--out", tmp_path) == 3
    err = capsys.readouterr().err
    assert err == f"error: {WALL}: the run failed: fidelity 'model': not implemented\n"
    assert list(tmp_path.iterdir()) == []


def test_per_axis_rows_per_simulated_axis_or_per_motor() -> None:
    s = load(ROOT / "scenes" / "short.toml")          # axes = [1]
    r = synthetic(s, {})
    r.per_axis = {"pos_err_rms_counts": [5.5], "torque_ratio": [0.9, 0.8, float("nan")]}
    r.events = [{"kind": "dropout", "axis": 1, "cause_s": 0.01, "zero_torque_s": float("nan"),
                 "reaction_us": float("inf")}]
    text = res.summary_text(r, [])
    assert re.search(r"^1 beta +5\.5 +0\.8$", text, re.M), text
    assert re.search(r"^dropout +1 +0\.010000 +nan +inf$", text, re.M), text
    s3 = synthetic(load(WALL), {})
    s3.per_axis = {"torque_ratio": [0.9, 0.8, float("nan")]}
    assert re.search(r"^2 gamma +nan$", res.summary_text(s3, []), re.M)


def test_check_subcommand(tmp_path: Path, capsys) -> None:  # noqa: ANN001
    scenes = sorted((ROOT / "scenes").glob("*.toml"))
    assert run_cli("check", *scenes) == 0
    assert capsys.readouterr().out.count(": ok: ") == len(scenes)
    bad = tmp_path / "bad.toml"
    bad.write_text('[hand]\nkind = "spring"\npath = [[0.1, 0, 0.07, 0], [0.1, 0, 0.071, 0]]\n')
    assert run_cli("check", WALL, bad) == 2
    assert "hand.path[1][0]: time must increase" in capsys.readouterr().err


def test_installed_command_exit_code(tmp_path: Path) -> None:
    """Through the real entry point (a process): exit 2 and the message on stderr."""
    bad = tmp_path / "bad.toml"
    bad.write_text("[env]\nkind = \"wall\"\nk = nan\n")
    hg = Path(sys.executable).parent / "hapgate"
    p = subprocess.run([str(hg), "scene", "run", str(bad), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True)
    assert p.returncode == 2, p.stderr
    assert p.stderr.strip() == f"error: {bad}: env.k: must be finite, got nan"
    assert p.stdout == "" and not (tmp_path / "o").exists()


# --------------------------------------------------------------------------- progress bar

class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_progress_quiet_for_short_runs_then_quarters() -> None:
    clk, buf = Clock(), io.StringIO()
    bar = Progress(total=1.0, label="x", unit="s", stream=buf, clock=clk)
    for i in range(1, 11):            # 1 s of wall time: under the 2 s delay, nothing
        clk.now = 0.1 * i
        bar(0.05 * i)
    assert buf.getvalue() == ""
    for i in range(11, 21):           # then one line per quarter reached (not a terminal)
        clk.now = 0.3 * i
        bar(0.05 * i)
    lines = buf.getvalue().splitlines()
    assert len(lines) == 3 and lines[-1].startswith("x [") and "100.0 %" in lines[-1]
    bar.close()
    assert len(buf.getvalue().splitlines()) == 3
    with pytest.raises(ValueError):
        Progress(total=0.0)


def test_progress_takes_the_total_from_the_caller() -> None:
    clk, buf = Clock(), io.StringIO()
    bar = Progress(total=1.0, label="y", stream=buf, clock=clk)
    clk.now = 2.5          # e.g. a build: 2.5 s before the first report
    bar(0.0, 4.0)
    clk.now = 3.5
    bar(2.0, 4.0)          # half of a 4 s run, 2 s simulated in 1 s: 1 s left
    assert "50.0 %" in buf.getvalue() and "2/4" in buf.getvalue()
    assert "3.5 s elapsed,    1.0 s left" in buf.getvalue(), buf.getvalue()
