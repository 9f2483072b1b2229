"""Scene schema and loader (hapgate.device.scene): every example loads; every rule refuses.

Each malformed case is a minimal TOML file; the loader must raise SceneError whose message
starts with the file's path and names the dotted key (or the line, for TOML syntax/encoding)."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest
from hapgate.base.paths import ROOT
from hapgate.device import scene as sc
from hapgate.golden import encsig, kinematics

SCENES = sorted((ROOT / "scenes").glob("*.toml"))
WALL_HAND = ('[hand]\nkind = "spring"\npath = [[0.0, -0.0050, 0.0712, -0.0019], '
             '[0.2, -0.0040, 0.0754, -0.0013]]\n')


def write(tmp_path: Path, text: str | bytes, name: str = "x.toml") -> Path:
    p = tmp_path / name
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text)
    return p


def refused(tmp_path: Path, text: str | bytes) -> str:
    p = write(tmp_path, text)
    with pytest.raises(sc.SceneError) as exc:
        sc.load(p)
    msg = str(exc.value)
    assert msg.startswith(f"{p}:"), msg
    return msg


# --------------------------------------------------------------------------- the examples

@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_every_example_scene_loads(path: Path) -> None:
    s = sc.load(path)
    assert s.name == path.stem
    assert s.run.q0_deg is not None and len(s.run.q0_deg) == 3
    assert s == sc.load(path) and hash(s) == hash(sc.load(path))   # cacheable by value


def test_the_examples_listed_in_the_task_exist() -> None:
    need = {"wall", "wall_10k", "free_fast", "dropout", "hang", "watchdog", "miscommutation",
            "pc_force", "short", "link_garbage"}
    assert need <= {p.stem for p in SCENES}
    short = sc.load(ROOT / "scenes" / "short.toml")
    assert short.run.duration_s <= 0.02 and len(short.run.axes) == 1
    assert sc.load(ROOT / "scenes" / "miscommutation.toml").firmware \
        .comm_offset_error_counts == (32, 0, 0)
    assert sc.load(ROOT / "scenes" / "pc_force.toml").env.kind == "pc"
    assert sc.load(ROOT / "scenes" / "wall_10k.toml").run.servo_hz == 10_000


def test_wall_example_has_the_issue_values() -> None:
    s = sc.load(ROOT / "scenes" / "wall.toml")
    assert s.run == dataclasses.replace(s.run, duration_s=0.5, fidelity="rtl", axes=(0, 1, 2),
                                        servo_hz=1000, clk_hz=0, trace=False, seed=1,
                                        record=("q", "p", "f_hand", "tau", "dac"))
    assert (s.env.kind, s.env.point, s.env.normal, s.env.k, s.env.b, s.env.ki) == \
        ("wall", (0.0, 0.073, 0.0), (0.0, -1.0, 0.0), 2000.0, 0.0, 0.0)
    assert (s.hand.kind, s.hand.k, s.hand.b) == ("spring", 500.0, 2.0)
    assert s.hand.path == ((0.0, -0.005, 0.0712, -0.0019), (0.2, -0.004, 0.0754, -0.0013))
    assert all(e.amplitude == 110.0 for e in s.encoders)
    assert s.faults == (sc.FaultCfg(0.3, "dropout", 1),)
    assert s.expect.items() == [("max_force_error_n", 0.05), ("zero_torque_within_us", 20.0)]


def test_every_key_is_documented_in_the_scene_readme() -> None:
    doc = (ROOT / "scenes" / "README.md").read_text()
    missing = [k for k, _, _ in sc.keys() if f"`{k.split('.')[-1]}`" not in doc]
    assert not missing, f"scenes/README.md lacks: {missing}"
    for words in (sc.RECORDABLE, sc.ENV_KINDS, sc.HAND_KINDS, sc.FAULT_KINDS, sc.FW_ERRORS):
        assert all(f"`{w}`" in doc or f'"{w}"' in doc for w in words), words


# --------------------------------------------------------------------------- accepted forms

def test_empty_file_is_the_defaults(tmp_path: Path) -> None:
    s = sc.load(write(tmp_path, "", "my_scene.toml"))
    assert s == sc.Scene(run=dataclasses.replace(sc.RunCfg(), q0_deg=sc.DEFAULT_Q0_DEG,
                                                 name="my_scene"))
    assert s.name == "my_scene" and s.faults == () and s.expect.items() == []


def test_int_for_float_axes_sorted_normal_normalised(tmp_path: Path) -> None:
    s = sc.load(write(tmp_path, '[run]\nduration_s = 1\naxes = [2, 0]\n'
                                '[env]\nkind = "wall"\nk = 2000\nnormal = [0, -2, 0]\n'))
    assert s.run.duration_s == 1.0 and isinstance(s.run.duration_s, float)
    assert s.env.k == 2000.0 and isinstance(s.env.k, float)
    assert s.run.axes == (0, 2)
    assert s.env.normal == (0.0, -1.0, 0.0)


def test_encoder_overrides_per_axis_and_match_encsig(tmp_path: Path) -> None:
    s = sc.load(write(tmp_path, "[run]\nseed = 5\n[encoder]\namplitude = 100\nh2 = 0.01\n"
                                "[encoder.2]\namplitude = 90\nnoise_lsb = 0.5\n"))
    assert [e.amplitude for e in s.encoders] == [100.0, 100.0, 90.0]
    assert [e.h2 for e in s.encoders] == [0.01] * 3
    assert [e.noise_lsb for e in s.encoders] == [0.0, 0.0, 0.5]
    # same names and units as the signal model; distinct seeds per axis
    names = {f.name for f in dataclasses.fields(encsig.SignalSpec)} - {"seed"}
    assert {f.name for f in dataclasses.fields(sc.EncoderCfg)} == names
    specs = [s.signal_spec(a) for a in range(3)]
    assert specs[2] == encsig.SignalSpec(amplitude=90.0, h2=0.01, noise_lsb=0.5,
                                         seed=specs[2].seed)
    assert len({p.seed for p in specs}) == 3


def test_q0_is_the_inverse_kinematics_of_the_path_start(tmp_path: Path) -> None:
    s = sc.load(write(tmp_path, WALL_HAND))
    p = kinematics.fk(s.q0_rad)
    assert np.abs(p - np.array(s.hand.path[0][1:])).max() < 1e-12
    given = sc.load(write(tmp_path, "[run]\nq0_deg = [1, 40, 40]\n" + WALL_HAND))
    assert given.run.q0_deg == (1.0, 40.0, 40.0)


def test_hand_target_is_smooth_and_holds(tmp_path: Path) -> None:
    h = sc.load(write(tmp_path, WALL_HAND)).hand
    pts = np.array(h.path)
    t = np.array([-1.0, 0.0, 0.1, 0.2, 5.0])
    got = h.target(t, np.zeros(3))
    assert np.allclose(got[[0, 1]], pts[0, 1:]) and np.allclose(got[[3, 4]], pts[1, 1:])
    assert np.allclose(got[2], pts[:, 1:].mean(axis=0))
    eps = 1e-7   # zero velocity at the path points (no step in the hand's speed)
    v = (h.target(np.array([eps, 0.2]), np.zeros(3)) - h.target(np.array([0.0, 0.2 - eps]),
                                                                 np.zeros(3))) / eps
    assert np.abs(v).max() < 1e-4
    empty = sc.HandCfg(kind="spring")
    assert np.allclose(empty.target(np.array([0.0, 1.0]), np.array([1.0, 2, 3])), [1, 2, 3])


def test_digest_is_content_only(tmp_path: Path) -> None:
    text = (ROOT / "scenes" / "wall.toml").read_text()
    a, b = sc.load(write(tmp_path, text, "a.toml")), sc.load(write(tmp_path, text, "b.toml"))
    assert a.name != b.name and a.digest() == b.digest()
    assert a.override({"env.k": 2001.0}).digest() != a.digest()
    assert a.override({"encoder.2.noise_lsb": 0.1}).digest() != a.digest()


def test_override_revalidates(tmp_path: Path) -> None:
    s = sc.load(ROOT / "scenes" / "wall.toml")
    t = s.override({"env.k": 3000, "run.record": ("q", "dac"), "encoder.1.h3": 0.02})
    assert t.env.k == 3000.0 and t.run.record == ("q", "dac") and t.encoders[1].h3 == 0.02
    assert t.encoders[0].h3 == 0.0 and s.env.k == 2000.0
    with pytest.raises(sc.SceneError, match=r"wall\.toml: env\.k: 5000 out of range"):
        s.override({"env.k": 5000})
    with pytest.raises(sc.SceneError, match=r"run\.record\[0\]"):
        s.override({"run.record": ["speed"]})


# --------------------------------------------------------------------------- refused: one per rule

BAD = [
    # unknown keys, at each level
    ("top", "[bogus]\nx = 1\n", r": bogus: unknown key"),
    ("run", "[run]\nduraton_s = 1.0\n", r": run\.duraton_s: unknown key"),
    ("env", '[env]\nkind = "wall"\nstiffness = 1.0\n', r": env\.stiffness: unknown key"),
    ("hand", '[hand]\nkind = "spring"\nmass = 1.0\n', r": hand\.mass: unknown key"),
    ("encoder", "[encoder]\namp = 100\n", r": encoder\.amp: unknown key"),
    ("encoder.1", "[encoder.1]\nphase = 1.0\n", r": encoder\.1\.phase: unknown key"),
    ("encoder.3", "[encoder.3]\nh2 = 0.1\n", r": encoder\.3: unknown key"),
    ("fault", '[[fault]]\nat_s = 0.1\nkind = "hang"\nwhen = 1\n', r": fault\[0\]\.when: unknown"),
    ("firmware", "[firmware]\ncomm_offset = [1, 2, 3]\n", r": firmware\.comm_offset: unknown"),
    ("plant", "[plant]\nkt = 0.06\n", r": plant\.kt: unknown key"),
    ("expect", "[expect]\nmax_force_n = 1.0\n", r": expect\.max_force_n: unknown key"),
    # wrong types
    ("float_for_int", "[run]\nservo_hz = 1000.0\n", r": run\.servo_hz: must be an integer"),
    ("bool_for_int", "[run]\nseed = true\n", r": run\.seed: must be an integer, got a bool"),
    ("bool_for_float", '[env]\nkind = "wall"\nk = true\n', r": env\.k: must be a number"),
    ("str_for_float", '[env]\nkind = "wall"\nk = "2000"\n', r": env\.k: must be a number"),
    ("int_for_bool", "[run]\ntrace = 1\n", r": run\.trace: must be true or false"),
    ("scalar_for_array", "[run]\naxes = 0\n", r": run\.axes: must be an array"),
    ("table_for_value", "[run.duration_s]\nx = 1\n", r": run\.duration_s: must be a number"),
    ("array_for_table", "run = [1]\n", r": run: must be a table"),
    ("short_point", '[hand]\nkind = "spring"\npath = [[0.0, 0.0, 0.07]]\n',
     r": hand\.path\[0\]: must have 4 elements"),
    ("fault_table", '[fault]\nat_s = 0.1\n', r": fault: must be an array of tables"),
    # NaN / inf
    ("nan", '[env]\nkind = "wall"\nk = nan\n', r": env\.k: must be finite"),
    ("inf_in_path", '[hand]\nkind = "spring"\npath = [[0.0, inf, 0.07, 0.0]]\n',
     r": hand\.path\[0\]\[1\]: must be finite"),
    # impossible values
    ("duration_zero", "[run]\nduration_s = 0\n", r": run\.duration_s: 0 out of range"),
    ("duration_long", "[run]\nduration_s = 601\n", r": run\.duration_s: 601 out of range"),
    ("fidelity", '[run]\nfidelity = "gates"\n', r": run\.fidelity: 'gates' is not one of"),
    ("axes_empty", "[run]\naxes = []\n", r": run\.axes: must list at least one axis"),
    ("axes_dup", "[run]\naxes = [0, 0]\n", r": run\.axes: axes must be unique"),
    ("axes_3", "[run]\naxes = [3]\n", r": run\.axes\[0\]: 3 out of range"),
    ("servo_low", "[run]\nservo_hz = 50\n", r": run\.servo_hz: 50 out of range"),
    ("servo_divide", "[run]\nservo_hz = 3000\n", r": run\.servo_hz: 3000 Hz does not divide"),
    ("clk_low", "[run]\nclk_hz = 500000\n", r": run\.clk_hz: 500000 out of range"),
    ("clk_strobe", "[run]\nclk_hz = 48500000\n", r": run\.clk_hz: .*not a whole multiple"),
    ("record_unknown", '[run]\nrecord = ["q", "speed"]\n', r": run\.record\[1\]: 'speed' is not"),
    ("record_dup", '[run]\nrecord = ["q", "q"]\n', r": run\.record: names must be unique"),
    ("seed_negative", "[run]\nseed = -1\n", r": run\.seed: -1 out of range"),
    ("name_path", '[run]\nname = "../x"\n', r": run\.name: '\.\./x'"),
    ("q0_range", "[run]\nq0_deg = [0, 0, 270]\n", r": run\.q0_deg\[2\]: 270 out of range"),
    ("q0_singular", "[run]\nq0_deg = [0, 0, 0]\n", r": run\.q0_deg: .*singular"),
    ("qd0_held_axis", "[run]\naxes = [0]\nqd0_deg_s = [0, 10, 0]\n",
     r": run\.qd0_deg_s\[1\]: axis 1 is not simulated"),
    ("env_kind", '[env]\nkind = "floor"\n', r": env\.kind: 'floor' is not one of"),
    ("env_k", '[env]\nkind = "wall"\nk = 4000.0\n', r": env\.k: 4000.0 out of range"),
    ("env_b", '[env]\nkind = "viscous"\nb = -1.0\n', r": env\.b: -1.0 out of range"),
    ("env_ki", '[env]\nkind = "spring"\nki = 2e5\n', r": env\.ki: 200000.0 out of range"),
    ("env_normal_norm", '[env]\nkind = "wall"\nnormal = [0, -0.1, 0]\n',
     r": env\.normal: norm 0\.1 out of range"),
    ("env_point_far", '[env]\nkind = "wall"\npoint = [0, 0.3, 0]\n', r": env\.point: \|p\|"),
    ("env_normal_spring", '[env]\nkind = "spring"\nnormal = [0, -1, 0]\n',
     r": env\.normal: does not apply to env kind 'spring'"),
    ("env_k_none", "[env]\nk = 100.0\n", r": env\.k: does not apply to env kind 'none'"),
    ("env_point_pc", '[env]\nkind = "pc"\npoint = [0, 0.07, 0]\n', r": env\.point: does not"),
    ("hand_kind", '[hand]\nkind = "glove"\n', r": hand\.kind: 'glove' is not one of"),
    ("hand_k_zero", '[hand]\nkind = "spring"\nk = 0.0\n', r": hand\.k: 0\.0 out of range"),
    ("hand_k_none", "[hand]\nk = 100.0\n", r": hand\.k: does not apply to hand kind 'none'"),
    ("hand_path_none", '[hand]\npath = [[0.0, 0.0, 0.07, 0.0]]\n', r": hand\.path: does not"),
    ("hand_k_fixed", '[hand]\nkind = "fixed"\nb = 1.0\n', r": hand\.b: does not apply"),
    ("path_time_order", '[hand]\nkind = "spring"\npath = [[0.1, -0.005, 0.0712, -0.0019], '
     '[0.1, -0.004, 0.0754, -0.0013]]\n', r": hand\.path\[1\]\[0\]: time must increase"),
    ("path_time_negative", '[hand]\nkind = "spring"\npath = [[-0.1, -0.005, 0.0712, 0.0]]\n',
     r": hand\.path\[0\]\[0\]: -0\.1 out of range"),
    ("path_far", '[hand]\nkind = "spring"\npath = [[0.0, 0.0, 0.25, 0.0]]\n',
     r": hand\.path\[0\]: \|p\| = 0\.25"),
    ("path_unreachable", '[hand]\nkind = "spring"\npath = [[0.0, 0.0, 0.15, 0.0]]\n',
     r": hand\.path\[0\]: the start point is outside the workspace"),
    ("grip_unreachable", '[hand]\nkind = "fixed"\npath = [[0.0, -0.005, 0.0712, -0.0019], '
     '[0.1, 0.0, 0.15, 0.0]]\n', r": hand\.path\[1\]: outside the workspace"),
    ("grip_jumps", '[run]\nq0_deg = [10, 40, 40]\n[hand]\nkind = "fixed"\n'
     'path = [[0.0, -0.005, 0.0712, -0.0019]]\n', r": hand\.path\[0\]: the rigid grip starts"),
    ("encoder_amplitude", "[encoder]\namplitude = 128\n", r": encoder\.amplitude: 128 out of"),
    ("encoder_axis_gain", "[encoder.2]\ngain_a = 2.0\n", r": encoder\.2\.gain_a: 2\.0 out of"),
    ("encoder_h3", "[encoder]\nh3 = 0.5\n", r": encoder\.h3: 0\.5 out of range"),
    ("fault_kind", '[[fault]]\nat_s = 0.1\nkind = "meteor"\n', r": fault\[0\]\.kind: 'meteor'"),
    ("fault_needs", '[[fault]]\nkind = "hang"\n', r": fault\[0\]: needs at_s and kind"),
    ("fault_late", '[run]\nduration_s = 0.2\n[[fault]]\nat_s = 0.2\nkind = "hang"\n',
     r": fault\[0\]\.at_s: 0\.2 out of range"),
    ("fault_axis_not_dropout", '[[fault]]\nat_s = 0.1\nkind = "hang"\naxis = 1\n',
     r": fault\[0\]\.axis: applies to dropout only"),
    ("dropout_no_axis", '[[fault]]\nat_s = 0.1\nkind = "dropout"\n',
     r": fault\[0\]\.axis: required for a dropout"),
    ("dropout_unsimulated", '[run]\naxes = [0]\n[[fault]]\nat_s = 0.1\nkind = "dropout"\n'
     'axis = 1\n', r": fault\[0\]\.axis: 1 out of range: must be a simulated axis"),
    ("comm_range", "[firmware]\ncomm_offset_error_counts = [600, 0, 0]\n",
     r": firmware\.comm_offset_error_counts\[0\]: 600 out of range"),
    ("comm_len", "[firmware]\ncomm_offset_error_counts = [1, 2]\n",
     r": firmware\.comm_offset_error_counts: must have 3 elements"),
    ("comm_float", "[firmware]\ncomm_offset_error_counts = [1.5, 0, 0]\n",
     r": firmware\.comm_offset_error_counts\[0\]: must be an integer"),
    ("pc_timeout_ticks", "[firmware]\npc_force_timeout_ms = 0.5\n",
     r": firmware\.pc_force_timeout_ms: 0\.5 ms is not a whole number"),
    ("plant_dt", "[plant]\ndt_s = 3e-7\n", r": plant\.dt_s: 3e-07 s must be 1e-6 s / n"),
    ("plant_dt_big", "[plant]\ndt_s = 2e-6\n", r": plant\.dt_s: 2e-06 out of range"),
    ("plant_gravity_len", "[plant]\ngravity_k = [0.1, 0.2]\n", r": plant\.gravity_k: must be "),
    ("plant_kt", "[plant]\nkt_nm_per_a = 0.0\n", r": plant\.kt_nm_per_a: 0\.0 out of range"),
    ("plant_pole_pairs", "[plant]\npole_pairs = 2.0\n", r": plant\.pole_pairs: must be an int"),
    ("plant_visc", "[plant]\nb_visc_nms = [0.0, -1e-4, 0.0]\n", r": plant\.b_visc_nms\[1\]"),
    ("plant_link_k", "[plant]\nlink_k_nm_per_rad = [0.0, 1e5, 0.0]\n",
     r": plant\.link_k_nm_per_rad\[1\]: 100000\.0 out of range: 0\.\.62500"),
    ("plant_link_damper_alone", "[plant]\nlink_b_nms_per_rad = [0.0, 0.0, 0.01]\n",
     r": plant\.link_b_nms_per_rad\[2\]: a link damper needs its spring"),
    ("expect_fw_error", '[expect]\nfw_error = "OOPS"\n', r": expect\.fw_error: 'OOPS' is not"),
    ("expect_negative", "[expect]\nmax_force_error_n = -1.0\n", r": expect\.max_force_error_n"),
    ("expect_slips_float", "[expect]\nmax_slips = 0.5\n", r": expect\.max_slips: must be an"),
    ("trace_model", '[run]\nfidelity = "model"\ntrace = true\n', r": run\.trace: a waveform"),
    ("zero_torque_no_fault", "[expect]\nzero_torque_within_us = 20.0\n",
     r": expect\.zero_torque_within_us: the scene injects no"),
    ("garbage_needs_pc", '[[fault]]\nat_s = 0.0\nkind = "link_garbage"\n',
     r": fault\[0\]\.kind: link_garbage needs the PC link: env kind \"pc\", not 'none'"),
    ("garbage_bytes_range", '[env]\nkind = "pc"\n[[fault]]\nat_s = 0.0\nkind = "link_garbage"\n'
     'bytes = 0\n', r": fault\[0\]\.bytes: 0 out of range: 1\.\.65536"),
    ("bytes_not_garbage", '[[fault]]\nat_s = 0.0\nkind = "hang"\nbytes = 4\n',
     r": fault\[0\]\.bytes: applies to link_garbage only, not 'hang'"),
    ("pc_needs_pc_env", '[env]\nkind = "wall"\n[pc]\nforce_n = [0.0, 1.0, 0.0]\n',
     r": pc: a scripted PC needs env kind \"pc\", not 'wall'"),
    ("pc_force_limit", '[env]\nkind = "pc"\n[pc]\nforce_n = [0.0, 11.0, 0.0]\n',
     r": pc\.force_n: \|f\| = 11 N out of range: <= 10 N"),
    ("pc_unknown", '[env]\nkind = "pc"\n[pc]\nforce = [0.0, 1.0, 0.0]\n',
     r": pc\.force: unknown key"),
    ("pc_period", '[env]\nkind = "pc"\n[pc]\nperiod_ms = 0.5\n', r": pc\.period_ms: 0\.5 out of"),
    ("expect_ratio_order", "[expect]\nmin_torque_ratio = 0.9\nmax_torque_ratio = 0.8\n",
     r": expect\.min_torque_ratio: exceeds"),
]


@pytest.mark.parametrize("text,pattern", [(t, p) for _, t, p in BAD], ids=[i for i, _, _ in BAD])
def test_malformed_scene_is_refused_naming_file_and_key(tmp_path: Path, text: str,
                                                        pattern: str) -> None:
    msg = refused(tmp_path, text)
    assert re.search(pattern, msg), msg


def test_invalid_toml_names_its_line(tmp_path: Path) -> None:
    msg = refused(tmp_path, '[run]\nduration_s = 0.5\naxes = [0, 1,\nseed = 1\n')
    assert re.search(r"x\.toml:4:\d+: invalid TOML", msg), msg
    msg = refused(tmp_path, '[run]\nseed = 1\nseed = 2\n')   # duplicate key
    assert re.search(r"x\.toml:3:\d+: invalid TOML", msg), msg


def test_non_utf8_file_names_its_line(tmp_path: Path) -> None:
    msg = refused(tmp_path, b"[run]\n# caf\xe9\nseed = 1\n")
    assert re.search(r"x\.toml:2: not UTF-8 \(byte 0xe9", msg), msg


def test_missing_file_and_folder(tmp_path: Path) -> None:
    with pytest.raises(sc.SceneError, match=r"nope\.toml: cannot read: No such file"):
        sc.load(tmp_path / "nope.toml")
    with pytest.raises(sc.SceneError, match=r": cannot read: Is a directory"):
        sc.load(tmp_path)


def test_limits_follow_the_firmware_header() -> None:
    """The env ranges are dsp-fw's hg_scene_check() ranges, read from its header."""
    hdr = (ROOT / "dsp-fw" / "include" / "hg_scene.h").read_text()
    pat = r"#define HG_SCENE_(\w+)_MAX\s+HG_C\(([\d.e+]+)\)"
    got = {m[1]: float(m[2]) for m in re.finditer(pat, hdr)}
    assert got == {"K": sc.K_MAX, "B": sc.B_MAX, "KI": sc.KI_MAX, "P": sc.P_MAX_M}
    servo = (ROOT / "dsp-fw" / "include" / "hg_servo.h").read_text()
    errs = re.findall(r"HG_ERR_(\w+) = \d+", servo)
    assert tuple(errs) == sc.FW_ERRORS
    assert math.isclose(sc.QD_MAX_DEG_S, math.degrees(100.0))
