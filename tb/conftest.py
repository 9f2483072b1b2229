"""pytest setup for every test under tb/: the pinned tool environment first, and the longest
tests scheduled first (with `-n auto` a long test collected last would run alone at the end)."""

from __future__ import annotations

import os
import re

import pytest
from hapgate.base import toolenv

toolenv.apply()
# The device builds' profile-guided optimisation doubles each build's compile time and changes no
# result: the suite builds without it, and test_closed_loop.py::test_pgo_build_changes_nothing
# builds it on purpose (hapgate.device.runner.pgo_enabled).
os.environ.setdefault("HG_PGO", "0")

# Tests of 15 s or more on this machine (`pytest --durations=40`), longest first: collection
# order puts them wherever their file sorts, and xdist hands tests out in that order.
LONG_FIRST = (
    "tb/boards/test_board_tops.py::test_board_netlist_hx8k",
    "tb/bus/test_hg_bus.py::test_random_accesses",
    "tb/bus/test_hg_bus.py::test_directed",
    "tb/bus/test_hg_bus.py::test_random_accesses_16mhz",
    "tb/top/test_top_netlist.py",
    "tb/interp/test_calib_native.py::test_ten_million_samples_disturbed_no_divergence",
    "tb/boards/test_board_tops.py::test_board_top_bit_exact",
    "tb/device/test_soak.py",
    "tb/interp/test_enc_interp_netlist.py",
    "tb/commutation/test_commutator.py::test_commutator_rtl",
    "tb/cosim/test_cosim.py::test_wall_normal_run",
    "tb/dac_sched/test_dac_sched.py::test_schedule_timing_rtl",
)


def _rank(item: pytest.Item) -> int:
    for i, prefix in enumerate(LONG_FIRST):
        if item.nodeid.startswith(prefix):
            return i
    return len(LONG_FIRST)


# The second tier (`make regress`, run by CI after `make test`): tests whose length is their
# point, or that repeat on a second simulator or a netlist what the first tier proves on the
# RTL. Node-id pattern (re.search) -> why it is long and what the first tier keeps. `make test`
# deselects them (-m "not regress"), `make regress` runs only them (-m regress); an entry that
# matches no test fails the collection, so a renamed test cannot drop out of both tiers.
REGRESS: dict[str, str] = {
    r"^tb/seu/test_seu_campaign\.py::":
        "10^3 closed-loop fault injections on the saboteur netlist (minutes on two workers); "
        "tier 1 keeps the sites' completeness, the classification, the netlist's equality to "
        "the RTL, the targeted injections and a 3-job sweep (tb/seu/)",
    r"\[(.*-)?icarus(-.*)?\]$":
        "Icarus, the second simulator: the same bit-exact checks run on Verilator in tier 1",
    r"^tb/top/test_top\.py::test_top_(bit_exact|homed_truth)\[quad-":
        "the whole FPGA in plain quadrature, a sweep configuration no board ships (its own "
        "build); tier 1 keeps the top's bit-exact and truth runs of paper, hx8k, ecp5, hires "
        "and observer, and plain quadrature's interpolator (tb/interp/test_interp_coarse.py)",
    r"^tb/top/test_top_netlist\.py::":
        "the top's post-synthesis netlists beside the RTL; tier 1 keeps the RTL bit-exact runs",
    r"^tb/interp/test_enc_interp_netlist\.py::":
        "the interpolator's netlist; tier 1 keeps the RTL bit-exact runs and lint's synthesis",
    r"^tb/boards/test_board_tops\.py::test_board_netlist_":
        "a board top's netlist; tier 1 keeps the board tops' RTL bit-exact runs",
    r"^tb/device/test_closed_loop\.py::test_pgo_build_changes_nothing":
        "builds the profile-guided device harness (a second, slower build of the same RTL)",
    r"^tb/device/test_closed_loop\.py::test_traced_build_changes_nothing":
        "builds the waveform (--trace) device harness, a second build of the same RTL; tier 1 "
        "keeps the testbench wrapper in every other native harness",
    r"^tb/interp/test_calib_native\.py::test_ten_million_samples":
        "10^7 samples for divergence; tier 1 keeps the calibration's bit-exact and truth tests",
    r"^tb/device/test_soak\.py::test_soak_1e7":
        "a 10^7-sample soak; tier 1 keeps the shorter no-slip runs",
    r"^tb/boards/test_board_tops\.py::test_board_top_bit_exact\[ecp5-evn-":
        "the ECP5 board wrapper (PLL off in simulation); tier 1 keeps the ecp5 configuration "
        "bit-exact in tb/top and the HX8K board top, whose ADC mux is board logic",
    r"^tb/device/test_stage_clocks\.py::test_stage_clocks_equal_the_clk_build_on_random_"
    r"stimulus\[6000000-7\]":
        "a second clock and axis mask of the stage-clock equivalence; tier 1 keeps 24 MHz",
    r"^tb/interp/test_interp3_axes\.py::test_(three_axes_independent|ratio_operands)":
        "native builds of their own (~20 s: three axes with calibration and observer; ~8 s: "
        "calibration + ratio stage) for the wrapper's per-axis independence and the divider's "
        "full-width operands; tier 1 keeps the three-axis calibration run "
        "(test_calib_native.py) and, in this file, the counters' tops on its shared build",
    r"^tb/interp/test_enc_interp\.py::test_other_lut_density":
        "arcsine densities other than the paper's 7 (the bench sweeps them); tier 1 keeps 7",
    r"^tb/commutation/test_commutator\.py::test_commutator_rtl\[(c50_ob|c16_tc)-":
        "DAC codings no board ships (offset binary, 16 bits); tier 1 keeps the shipped 14-bit "
        "two's complement (c12m5_serial here, 12 and 48 MHz in the native tests)",
    r"^tb/dac_sched/test_dac_sched\.py::test_schedule_timing_rtl\[(c25_fast|c50|c12m5)-":
        "DAC timing at clocks no board ships; tier 1 keeps 48 MHz (the paper's) and 12 MHz "
        "(the HX8K's): every shipped clock",
    r"^tb/commutation/test_commutator_native\.py::test_random_frames_bit_exact\[2000000\]":
        "2 MHz, a clock no board ships; tier 1 keeps 12 and 48 MHz",
    r"^tb/commutation/test_commutator_native\.py::test_(harness_checks_fail_on_a_wrong_"
    r"schedule|short_frame_parameters)":
        "the harness's own checks against a wrong schedule, and frame settings no board "
        "ships; tier 1 runs the checks on every shipped clock",
    r"^tb/formal/test_formal\.py::test_broken_copy_fails":
        "the broken copies each proof must reject (also `make formal`); tier 1 keeps every "
        "proof passing",
    r"^tb/device/test_sweep\.py::test_device_zwidth_at_b0_brackets_the_bound\[1000\]":
        "the Z-width bracket at the 1 kHz servo (a Dask sweep of device runs); tier 1 keeps "
        "10 kHz",
    r"^tb/test_native_pgo\.py::test_a_failed_training_run":
        "a profile-guided build's failure path (two device builds); tier 2 beside the PGO build",
    r"^tb/bringup/test_bringup\.py::test_offsets_and_swapped_phases":
        "the single-error bring-up scenes (36 s of device time each); tier 1 keeps "
        "unaligned.toml, which has an offset, swapped phases and a reversed encoder at once",
    r"^tb/bringup/test_bringup\.py::test_(guided_move_that_never_comes|held_handle_no_"
    r"movement|wrong_pole_pairs_refused_with_both_figures)":
        "bring-up's refusals end to end on the virtual device; tier 1 keeps the same refusals "
        "in the firmware's C unit tests (bringup_guided_timeout, bringup_align_held, "
        "bringup_align_pole_pairs) and unaligned.toml end to end",
    r"^tb/bringup/test_bringup\.py::test_encoder_weak_channel_and_h2_end_to_end":
        "a weak channel and a 2nd harmonic through the served device (align, homing and the "
        "encoder step on three axes, 25 s of device time); tier 1 keeps the encoder step "
        "end to end on unaligned.toml's healthy encoders and the same fields and bands on "
        "captures of the same signals (test_encoder_result_fields_and_bands)",
    r"^tb/bringup/test_bringup\.py::test_default_bringup_then_the_same_device_renders_the_wall":
        "the issue's done-when on one served device: every step (65 s of device time) with "
        "--apply, then the wall; tier 1 keeps bring-up with --apply on unaligned.toml "
        "(test_unaligned_finds_every_error) and the wall with the calibration it wrote "
        "(test_after_apply_torque_and_wall)",
    r"^tb/bringup/test_bringup\.py::test_(identified_dynamics_within_budget|encoder_dir_all_"
    r"steps)":
        "bring-up with every step end to end (50-60 s of device time each); tier 1 keeps the "
        "identification and the other joints' hold in the firmware's C unit tests "
        "(bringup_ident, bringup_ident_hold) and the guided move on encoder_dir.toml",
    r"^tb/bringup/test_bringup\.py::test_(index_scene_homes_itself_then_renders_the_wall|"
    r"homing_on_both_sides_and_an_index_out_of_range)":
        "homing served devices from indexes tens of degrees away (align and homing on three "
        "axes, 38-44 s of device time each); tier 1 keeps the unhomed device's link "
        "(test_an_unhomed_device_answers_from_reset), the restart with far indexes "
        "(test_a_stored_calibration_restarts_with_the_index_anywhere) and homing in the "
        "firmware's C unit tests (bringup_home, bringup_power_up)",
    r"^tb/top/test_top_bounds\.py::test_top_fault_kinds_zero_torque\[(hires|observer)\]":
        "the fault kinds' zero torque on two more configurations' builds (15-19 s each, with "
        "the tests below); tier 1 keeps them on paper, and every configuration's safety path "
        "is the same RTL the formal proof of the top covers",
    r"^tb/top/test_top\.py::test_top_(bit_exact|homed_truth)\[(hires|hx8k|observer)-":
        "the top's bit-exact and truth runs of three more named configurations (a build "
        "each, 30-40 s); tier 1 keeps paper (three seeds, both checks) and ecp5, every "
        "configuration's lint and synthesis, the hx8k configuration inside the HX8K board "
        "top's bit-exact run and the observer through the device's velocity tests",
    r"^tb/commutation/test_commutator\.py::test_commutator_rtl\[c12m5_serial-":
        "the serial (shift-add) multiplier at 12.5 MHz, its own build (50 s); tier 1 keeps it "
        "inside the HX8K board top's bit-exact run (SERIAL_MUL = 1) and the other "
        "multiplier's configurations here",
    r"^tb/top/test_top_capture\.py::test_top_capture$":
        "the capture buffer through the top (its own build, 45 s); tier 1 keeps the block's "
        "bit-exact run (tb/capture) and the buffer read end to end by bring-up's encoder step "
        "on unaligned.toml",
    r"^tb/dac_sched/test_dac_sched\.py::test_strobe_high_from_power_up\[verilator\]":
        "the write strobe from power-up on the RTL (45 s); tier 1 keeps the same check on the "
        "iCE40 netlist (test_strobe_high_from_power_up_ice40_netlist) and the schedule's "
        "timing at the shipped clocks",
    r"^tb/commutation/test_sine_lut\.py::test_sine_lut_rtl\[sine_q64_fs2047-":
        "the smaller sine ROM (64 entries a quadrant, 11-bit full scale), its own build; tier "
        "1 keeps the shipped 256-entry ROM bit-exact and against truth",
    r"^tb/bringup/test_bringup\.py::test_every_scene_answers_its_link_from_reset":
        "every shipped scene served once (a device build for each clock, axis set and "
        "gateware option they name); tier 1 keeps the link from reset on an unhomed scene "
        "and a restarted one (test_an_unhomed_device_answers_from_reset)",
    r"^tb/bus/test_hg_bus\.py::test_random_accesses_16mhz":
        "random bus accesses at a second FPGA clock (16 MHz, no board's); tier 1 keeps them at "
        "the bus tests' own clock",
    r"^tb/replay/test_streaming\.py::test_interp_output_does_not_depend_on_the_chunk"
    r"\[rtl-ratio-harm\]":
        "its own ratio+harmonic harness build; tier 1 keeps the chunking test on the other "
        "RTL builds and on every model",
}


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "regress: the second tier (make regress; tb/conftest.py "
                                       "REGRESS says why each test is there)")


@pytest.hookimpl(tryfirst=True)   # before -m deselects by the marker added here
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    used = dict.fromkeys(REGRESS, 0)
    for item in items:
        for pattern in REGRESS:
            if re.search(pattern, item.nodeid):
                item.add_marker(pytest.mark.regress)
                used[pattern] += 1
                break
    whole = not config.args or all(a.rstrip("/") in ("tb", str(config.rootpath / "tb"))
                                   for a in config.args)
    stale = [p for p, n in used.items() if n == 0]
    if whole and stale and not config.getoption("keyword"):
        raise pytest.UsageError("tb/conftest.py REGRESS entries that match no test: "
                                + ", ".join(stale))
    items.sort(key=_rank)   # stable: the rest keep their order
