"""What bring-up must find (issue 26), on the virtual device: the plant's keys
comm_offset_elec_deg, phases_swapped, encoder_dir and index_q_deg, the scene's
[firmware] calibration ("none", "truth" or a calibration.toml), and what the firmware does with
each: torque gated off without a calibration, every commanded torque delivered with the
plant's own ("truth"), not with a wrong one (the miscommutation metric, torque_ratio)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hapgate.base.paths import ROOT
from hapgate.device import harness, runner
from hapgate.device import scene as sc
from hapgate.flows import regmap
from hapgate.golden import calib

SCENES = ROOT / "scenes"
BRINGUP = sorted((SCENES / "bringup").glob("*.toml")) + [SCENES / "unaligned.toml"]

# scenes/grip.toml: a rigid grip holds the start pose while a spring scene loads every motor
GRIP = SCENES / "grip.toml"
# The delivered/commanded torque of a correctly commutated motor at a fixed pose: the sine
# ROM's channel b sits 341/1024 of a cycle after a, 1/3 code short of 120 deg, which makes the
# torque per command swing over 0.99941 .. 1.00177 with the field angle (docs/blocks/
# commutator.md's 0.25 % p-p ripple; the same for swapped phases), plus the torque code's and
# the DAC's rounding (1/8191 of full scale on ~0.1 N m of 0.48: 6e-4) and the angle's
# quantisation (half a code: cos(0.18 deg) = 0.999995). Issue 26 asks >= 0.999.
RATIO_LO, RATIO_HI = 0.999, 1.00177 + 6e-4


def delivered(r: list[float]) -> bool:
    return all(RATIO_LO <= x <= RATIO_HI for x in r)


def grip(plant: dict[str, object] | None = None, calibration: str | None = None,
         fidelity: str = "model") -> sc.Scene:
    """scenes/grip.toml with these [plant] keys and this [firmware] calibration."""
    changes: dict[str, object] = {"run.fidelity": fidelity}
    changes.update({f"plant.{k}": v for k, v in (plant or {}).items()})
    if calibration is not None:
        changes["firmware.calibration"] = calibration
    return sc.load(GRIP).override(changes)


def refused(tmp_path: Path, text: str) -> str:
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(sc.SceneError) as exc:
        sc.load(p)
    assert str(exc.value).startswith(f"{p}: "), exc.value
    return str(exc.value)


# --------------------------------------------------------------------------- the schema
@pytest.mark.parametrize("path", BRINGUP, ids=[p.stem for p in BRINGUP])
def test_bringup_scenes_load_uncalibrated(path: Path) -> None:
    s = sc.load(path)
    assert s.calibration == "none" and s.calib() == calib.NONE
    assert any(getattr(s.plant, k) != getattr(sc.PlantCfg(), k) for k in sc.BRINGUP_KEYS)


def test_unaligned_has_three_different_errors() -> None:
    p = sc.load(SCENES / "unaligned.toml").plant
    wrong = [(p.comm_offset_elec_deg[i] != 0, p.phases_swapped[i], p.encoder_dir[i] == -1)
             for i in range(3)]
    assert wrong[0][0] and wrong[1][1] and wrong[2][2]
    assert len(set(wrong)) == 3


def test_defaults_and_the_calibration_default(tmp_path: Path) -> None:
    d = sc.PlantCfg()
    assert (d.comm_offset_elec_deg, d.phases_swapped, d.encoder_dir, d.index_q_deg) == \
        ((0.0, 0.0, 0.0), (False, False, False), (1, 1, 1), None)
    wall = sc.load(SCENES / "wall.toml")
    assert wall.firmware.calibration is None and wall.calibration == "truth"
    # truth of today's device: homed and aligned, offset 0, index_to_zero from the index at
    # q0 - 0.25 deg (the harness's former arithmetic)
    for i, a in enumerate(wall.calib()):
        qi = math.radians(wall.run.q0_deg[i]) - math.radians(0.5) / 2
        assert a.words() == (3, 1, 0, 2, round(-qi / (2 * math.pi) * 2**20), 0)
    # any bring-up key switches the default to "none"; an explicit value wins
    p = tmp_path / "s.toml"
    p.write_text("[plant]\nencoder_dir = [1, 1, 1]\n")
    assert sc.load(p).calibration == "none"
    p.write_text("[plant]\nencoder_dir = [1, 1, 1]\n[firmware]\ncalibration = \"truth\"\n")
    plain = tmp_path / "plain.toml"
    plain.write_text("")
    assert sc.load(p).calib() == sc.load(plain).calib() != calib.NONE
    # a calibration file, relative to the scene's folder
    (tmp_path / "cal").mkdir()
    (tmp_path / "cal" / "c.toml").write_text(calib.dumps(
        [calib.AxisCalib(10 * i - 7, 30.0 * i, i == 1, 1 - 2 * (i == 2), 2) for i in range(3)]))
    p.write_text("[firmware]\ncalibration = \"cal/c.toml\"\n")
    got = sc.load(p).calib()
    assert [a.index_to_zero_counts for a in got] == [-7, 3, 13]
    assert [a.phases_swapped for a in got] == [False, True, False]
    assert [a.encoder_dir for a in got] == [1, 1, -1] and got[1].comm_offset_elec_deg == 30.0


@pytest.mark.parametrize("text, want", [
    ("[plant]\ncomm_offset_elec_deg = [0, 400, 0]\n",
     r"plant.comm_offset_elec_deg[1]: 400 out of range"),
    ("[plant]\ncomm_offset_elec_deg = [0, 0]\n", "plant.comm_offset_elec_deg: must have 3"),
    ("[plant]\nphases_swapped = [true, 1, false]\n",
     "plant.phases_swapped[1]: must be true or false"),
    ("[plant]\nencoder_dir = [1, 0, 1]\n", "plant.encoder_dir[1]: 0 out of range: +1 or -1"),
    ("[plant]\nencoder_dir = [1, -1.0, 1]\n", "plant.encoder_dir[1]: must be an integer"),
    ("[plant]\nindex_q_deg = [0, 0, 270]\n", "plant.index_q_deg[2]: 270 out of range"),
    ("[firmware]\ncalibration = \"maybe\"\n", "firmware.calibration: 'maybe': \"none\""),
    ("[firmware]\ncalibration = 1\n", "firmware.calibration: must be a string"),
    ("[firmware]\ncalibration = \"missing.toml\"\n",
     "firmware.calibration: {dir}/missing.toml: cannot read"),
    ("[run]\nfidelity = \"model\"\n[plant]\nencoder_dir = [1, -1, 1]\n",
     "plant.encoder_dir: a reversed encoder needs the gateware"),
], ids=["offset_range", "offset_len", "swapped_type", "dir_zero", "dir_float", "index_range",
        "calibration_word", "calibration_type", "calibration_missing",
        "dir_model"])
def test_bad_values_are_refused_naming_the_key(tmp_path: Path, text: str, want: str) -> None:
    assert want.format(dir=tmp_path) in refused(tmp_path, text)


OK_AXIS = ("[[axis]]\nindex_to_zero_counts = 0\ncomm_offset_elec_deg = 0.0\n"
           "phases_swapped = false\nencoder_dir = 1\npole_pairs = 2\n")


@pytest.mark.parametrize("body, want", [
    ("[[axis]]\n", "axis: needs exactly three [[axis]] tables"),
    (OK_AXIS * 2 + OK_AXIS.replace("pole_pairs = 2\n", ""), "axis[2].pole_pairs: missing"),
    (OK_AXIS.replace("encoder_dir = 1", "encoder_dir = 2") + OK_AXIS * 2,
     "axis[0].encoder_dir: 2 out of range"),
    (OK_AXIS * 2 + OK_AXIS.replace("phases_swapped = false", "phases_swapped = 0"),
     "axis[2].phases_swapped: must be true or false"),
    (OK_AXIS.replace("comm_offset_elec_deg = 0.0", "comm_offset_elec_deg = nan") + OK_AXIS * 2,
     "axis[0].comm_offset_elec_deg: must be a number"),
    (OK_AXIS + OK_AXIS.replace("pole_pairs = 2", "pole_pairs = 2\nwhat = 1") + OK_AXIS,
     "axis[1].what: unknown key"),
    ("offset = 3\n" + OK_AXIS * 3, "offset: unknown key"),
], ids=["count", "missing", "dir", "swapped", "nan", "unknown", "top_unknown"])
def test_bad_calibration_files_are_refused_naming_file_and_key(tmp_path: Path, body: str,
                                                               want: str) -> None:
    c = tmp_path / "calibration.toml"
    c.write_text(body)
    msg = refused(tmp_path, "[firmware]\ncalibration = \"calibration.toml\"\n")
    assert f"firmware.calibration: {c}: {want}" in msg, msg


def test_calibration_file_round_trip() -> None:
    axes = (calib.AxisCalib(-5, 12.5, True, -1, 2, dir_confirmed=True),
            calib.AxisCalib(2**31 - 1, -180.0, False, 1, 2), calib.AxisCalib())
    assert calib.loads(calib.dumps(axes)) == axes


# --------------------------------------------------------------------------- the device
def _records(raw: runner.Raw) -> list[bytes]:
    """The named fields of every record (the structs' padding is not written)."""
    return [a[n].tobytes() for a in (raw.frames, raw.ticks, raw.loads)
            for n in a.dtype.names if not n.startswith("pad")]


def test_default_keys_are_bit_identical() -> None:
    """The four keys at their defaults and calibration "truth" given explicitly: every frame,
    tick and DAC load as without them (today's device)."""
    base = grip()
    explicit = base.override({"plant.comm_offset_elec_deg": [0.0, 0.0, 0.0],
                              "plant.phases_swapped": [False] * 3,
                              "plant.encoder_dir": [1, 1, 1],
                              "firmware.calibration": "truth"})
    assert explicit.calibration == "truth" and explicit.calib() == base.calib()
    a, b = runner.simulate(base), runner.simulate(explicit)
    assert _records(a) == _records(b)
    assert a.frames.size > 3000 and np.abs(a.frames["tau"]).max() > 0.05


def _ratios(s: sc.Scene) -> list[float]:
    return runner.run(s).per_axis["torque_ratio"]


def test_truth_delivers_the_commanded_torque_and_a_wrong_calibration_does_not(
        tmp_path: Path) -> None:
    """Known offsets of several sizes, swapped phases (with and without an offset): with the
    plant's own calibration every motor delivers the commanded torque; with a calibration
    whose motor-0 offset is 90 deg off, motor 0 delivers none of it (cos 90 deg), and one
    180 deg off on motor 2 pushes backwards (cos 180 deg)."""
    plant = {"comm_offset_elec_deg": [90.0, -35.0, -150.0],
             "phases_swapped": [False, True, True]}
    truth = grip(plant, "truth")
    r = _ratios(truth)
    assert delivered(r), r
    wrong = [calib.AxisCalib(a.index_to_zero_counts, a.comm_offset_elec_deg + d,
                             a.phases_swapped, a.encoder_dir, a.pole_pairs)
             for a, d in zip(truth.calib(), (90.0, 0.0, 180.0), strict=True)]
    (tmp_path / "wrong.toml").write_text(calib.dumps(wrong))
    r = _ratios(grip(plant, str(tmp_path / "wrong.toml")))
    assert abs(r[0]) < 0.02 and delivered(r[1:2]) and r[2] < -0.99, r
    # no calibration at all: the firmware never drives (and latches nothing)
    none = runner.simulate(grip(plant, "none"))
    assert none.ticks.size > 40 and not none.ticks["drive"].any()
    assert not none.loads["code"].any() and not none.frames["tau"].any()
    assert none.summary["fw_err"] == "0"


def test_reversed_encoder_with_truth_on_the_gateware() -> None:
    """A reversed encoder (A and B swapped: the gateware's interpolator counts backwards) on
    axis 1, an offset on axis 2: with "truth" the firmware's joint angles are the true ones
    (index_to_zero of the reversed count) and every motor delivers its torque; without a
    calibration no torque reaches any motor."""
    plant = {"encoder_dir": [1, -1, -1], "comm_offset_elec_deg": [0.0, 0.0, 45.0],
             "phases_swapped": [False, False, True]}
    s = grip(plant, "truth", fidelity="rtl") \
        .override({"run.duration_s": 0.02})
    r = runner.run(s)
    assert r.metrics["fw_error"] == "NONE"
    # the interpolator's error on these signals: <= 25 counts (test_closed_loop._wall_budget)
    assert r.metrics["position_error_counts"] <= 25, r.metrics
    assert delivered(r.per_axis["torque_ratio"]), r.per_axis
    raw = runner.simulate(s.override({"firmware.calibration": "none"}))
    assert not raw.ticks["drive"].any() and not raw.loads["code"].any()


def test_harness_gets_the_calibration_words() -> None:
    s = sc.load(SCENES / "unaligned.toml").override({"firmware.calibration": "truth"})
    words = [int(w) for w in harness.calib_line(s).split("=")[1].split()]
    assert words == [w for a in s.calib() for w in a.words()] and len(words) == 18
    assert words[6 * 2 + 1] == -1 and words[6 * 1 + 2] == 1 and words[5] == round(
        120 / 360 * 1024)


def test_a_far_index_on_a_held_axis_runs_uncalibrated() -> None:
    """bringup/index.toml with one axis built: the held bank presents its axes at rest in the
    start pose since reset, unhomed (their registers: the golden interpolator on that constant
    signal, no index latched), and the uncalibrated firmware never drives."""
    s = sc.load(SCENES / "bringup" / "index.toml").override(
        {"run.axes": [1], "run.duration_s": 0.01, "run.fidelity": "model"})
    held = harness.hold_values(s, s.q0_rad)
    assert held["hold_index_count"] == [0, 0, 0] and held["hold_index_pos"] == [0, 0, 0], held
    raw = runner.simulate(s)
    assert raw.summary["fw_err"] == "0" and not raw.ticks["drive"].any()
    f = regmap.load().by_name()["STATUS"].field("HOMED")
    assert not ((raw.ticks["status"] >> f.lsb) & ((1 << f.width) - 1)).any()


@pytest.mark.parametrize("shift_deg", [(-24.0, -16.0, 27.0), (40.0, -60.0, 5.0)],
                         ids=["index_toml", "both_sides"])
def test_a_stored_calibration_restarts_with_the_index_anywhere(shift_deg: tuple[float, ...]
                                                               ) -> None:
    """The paper's power-up: with a stored calibration ("truth") the firmware RESTARTs in the
    start pose, with no motion and no index crossed, wherever the indexes lie (here tens of
    degrees from the start pose, on both sides, different on each axis). Its joint angles are
    the true ones within the interpolator's error on these signals (<= 25 counts), every motor
    delivers its torque, and the FPGA never homed an axis (STATUS.HOMED stays 0)."""
    s = grip()
    q0 = np.asarray(s.run.q0_deg)
    far = s.override({"plant.index_q_deg": list(q0 + np.asarray(shift_deg)),
                      "firmware.calibration": "truth"})
    r = runner.run(far)
    assert r.metrics["position_error_counts"] <= 25, r.metrics
    assert delivered(r.per_axis["torque_ratio"]), r.per_axis
    raw = runner.simulate(far)
    f = regmap.load().by_name()["STATUS"].field("HOMED")
    homed = (raw.ticks["status"] >> f.lsb) & ((1 << f.width) - 1)
    assert raw.ticks["drive"].any() and not homed.any()


def test_an_index_moved_near_the_start_pose_with_truth(tmp_path: Path) -> None:
    """index_q_deg given (0.1 and 0.4 deg before the start pose, not 0.25): "truth" restarts
    the firmware there, so its joint angles are the true ones (within the interpolator's error
    on these signals, <= 25 counts) and every motor delivers its torque. A calibration that
    keeps the old index_to_zero does too: RESTART takes the angles from the reference pose, not
    from the index; the old index moves only the commutation's virtual home, by 0.15 deg
    (0.3 deg electrical: a torque loss of 1.4e-5, far inside the delivered-torque band)."""
    s = grip()
    q0 = np.asarray(s.run.q0_deg)
    moved = s.override({"plant.index_q_deg": list(q0 - [0.1, 0.4, 0.1]),
                        "firmware.calibration": "truth"})
    r = runner.run(moved)
    assert r.metrics["position_error_counts"] <= 25, r.metrics
    assert delivered(r.per_axis["torque_ratio"]), r.per_axis
    (tmp_path / "old.toml").write_text(calib.dumps(s.calib()))
    r = runner.run(moved.override({"firmware.calibration": str(tmp_path / "old.toml")}))
    assert r.metrics["position_error_counts"] <= 25, r.metrics
    assert delivered(r.per_axis["torque_ratio"]), r.per_axis
