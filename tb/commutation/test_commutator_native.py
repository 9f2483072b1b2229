"""The commutator and its DAC scheduler on the native Verilator harness (tb/native/commutation/,
the `replay commutation --engine rtl` engine): 10^5 random frames bit-exact against the model at
the 48 MHz default, the board's 12 MHz and the slowest clock the RTL accepts, every load on the
documented clock (order, skew, latency, frame, strobe, setup/hold, settling checked per clock by
the harness); the idle-clock skip (dac_sched.v's HG_SIM_SKIP hook) leaves every DAC word and load
clock as evaluating every clock does, and a skip over a load is caught; the harness's own checks
fail on a wrong schedule; refused clocks are a clear ValueError."""

from __future__ import annotations

import dataclasses
import functools
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hapgate.golden import commutation as cm
from hapgate.golden.dacsched import random_frames
from hapgate.runners import native_comm

N = 100_000


@functools.cache
def _skipping_run(clk_hz: int) -> tuple[cm.CommutationConfig, cm.Frames, np.ndarray,
                                        native_comm.CommRun]:
    """N random frames, the model's codes and the (default, skipping) harness run, once."""
    cfg = cm.CommutationConfig(clk_hz=clk_hz)
    frames = random_frames(np.random.default_rng(clk_hz // 1000), N, cfg)
    return cfg, frames, cm.commutate(frames, cfg), native_comm.run_commutation(frames, cfg)


@pytest.mark.parametrize("clk_hz", [48_000_000, 12_000_000, 2_000_000])
def test_random_frames_bit_exact(clk_hz: int) -> None:
    cfg, frames, want, run = _skipping_run(clk_hz)
    bad = np.argwhere(run.codes != want)
    assert bad.size == 0, (f"{len(bad)} codes differ; first frame {bad[0][0]} channel "
                           f"{cm.CHANNELS[bad[0][1]]}: RTL {run.codes[tuple(bad[0])]} model "
                           f"{want[tuple(bad[0])]}")
    assert run.violations == 0
    assert np.array_equal(run.load_clocks, np.broadcast_to(cm.load_clocks(cfg), (N, 6)))
    assert native_comm.schedule_errors(run, cfg) == 0
    assert run.clocks == (N + 1) * cfg.frame_clocks
    # real time: 2 us apart, the first load LOAD_CLOCKS after the latch, exactly
    ns = run.load_ns(cfg)[0]
    assert np.allclose(np.diff(ns), cfg.skew_ns, rtol=0, atol=1e-6)
    print(f"{clk_hz / 1e6:g} MHz: {N} frames bit-exact in {run.cpu_seconds:.2f} CPU s "
          f"({N / run.cpu_seconds:.3g} frames/s, {cfg.frame_clocks} clocks per frame, "
          f"{run.edges / (N + 1):.0f} evaluated)")
    # the run must exercise what it claims: drive, saturation, the zeroing paths
    assert np.count_nonzero(want) > 0.4 * want.size
    assert (np.abs(want) == cfg.max_code).any() and (want == 0).any()
    if cfg.skew_clocks > cfg.load_clocks + 2:   # an idle stretch in every slot: skipped
        assert run.skips >= 8 * N and run.edges < run.clocks // 2


@pytest.mark.parametrize("clk_hz", [48_000_000, 12_000_000])
def test_skipping_changes_nothing(clk_hz: int) -> None:
    """The same 10^5 frames with every clock evaluated: every DAC word, every load clock, the
    reset frame and the clock count identical, both runs free of port violations (the skipping
    run's checks include the quiet checks of every skip edge)."""
    cfg, frames, _, skipped = _skipping_run(clk_hz)
    full = native_comm.run_commutation(frames, cfg, skip=False)
    assert full.skips == 0 and full.edges == full.clocks
    assert skipped.skips > 0 and skipped.edges < full.edges
    assert full.violations == 0 and skipped.violations == 0
    assert np.array_equal(full.codes, skipped.codes)
    assert np.array_equal(full.load_clocks, skipped.load_clocks)
    assert np.array_equal(full.reset_words, skipped.reset_words)
    assert full.clocks == skipped.clocks
    print(f"{clk_hz / 1e6:g} MHz: {full.edges} edges every clock ({full.cpu_seconds:.2f} CPU s), "
          f"{skipped.edges} skipping ({skipped.cpu_seconds:.2f} CPU s): identical")


def test_a_skip_over_a_load_is_caught() -> None:
    """The harness's force mode also skips one clock at each load edge (the hook's room is 0
    there): the quiet checks, the strobe check and the schedule all see it."""
    cfg = cm.CommutationConfig(clk_hz=12_000_000)
    frames = random_frames(np.random.default_rng(4), 50, cfg)
    run = native_comm.run_commutation(frames, cfg, skip="force")
    assert run.violations > 0
    assert native_comm.schedule_errors(run, cfg) > 0
    assert np.array_equal(run.load_clocks[:, 0], np.full(50, cfg.load_clocks + 1))


def test_short_frame_parameters() -> None:
    """A faster frame (1 us skew, 8 us frame at 25 MHz): the harness follows the parameters."""
    cfg = cm.CommutationConfig(clk_hz=25_000_000, skew_ns=1000, frame_ns=8000, settle_ns=8000)
    frames = random_frames(np.random.default_rng(3), 5000, cfg)
    run = native_comm.run_commutation(frames, cfg)
    assert np.array_equal(run.codes, cm.commutate(frames, cfg))
    assert native_comm.schedule_errors(run, cfg) == 0
    assert np.array_equal(run.load_clocks[0], np.arange(6) * 25 + 8)


def test_harness_checks_fail_on_a_wrong_schedule() -> None:
    """The harness built for a 2-clock strobe counts a violation at every load of the 1-clock
    RTL; a shifted documented latency or a non-zero reset frame makes schedule_errors count."""
    cfg = cm.CommutationConfig(clk_hz=2_000_000)
    wrong = dataclasses.replace(cfg, wr_cycles=2)
    exe = native_comm.build_commutation(cfg, checks=wrong)
    frames = random_frames(np.random.default_rng(8), 50, cfg)
    rec = native_comm.pack_frames(frames, cfg)
    with tempfile.TemporaryDirectory() as tmp:
        fin, fout = Path(tmp) / "in.bin", Path(tmp) / "out.bin"
        rec.tofile(fin)
        out = subprocess.run([str(exe), str(fin), str(fout), "50"], capture_output=True,
                             text=True, check=True)
    stats = dict(kv.split("=") for kv in out.stdout.split())
    assert int(stats["violations"]) == 51 * 6, stats
    assert "strobe low clocks" in out.stderr
    # the Python side of the schedule check
    good = native_comm.run_commutation(frames, cfg)
    assert native_comm.schedule_errors(good, cfg) == 0
    late = dataclasses.replace(good, load_clocks=good.load_clocks + (np.arange(50) == 7)[:, None])
    assert native_comm.schedule_errors(late, cfg) == 1
    dirty = dataclasses.replace(good, reset_words=good.reset_words + 1)
    assert native_comm.schedule_errors(dirty, cfg) == 1


@pytest.mark.parametrize("clk_hz, words", [
    (1_000_000, "skew"), (48_001_000, "whole clocks"), (0, "positive multiple of 1 kHz"),
    (-5, "positive multiple of 1 kHz"), (1, "positive multiple of 1 kHz")])
def test_refused_clock_is_a_value_error(clk_hz: int, words: str) -> None:
    with pytest.raises(ValueError, match=words):
        native_comm.build_commutation(cm.CommutationConfig(clk_hz=clk_hz))


def test_check_config_agrees_with_the_rtl() -> None:
    """A clock the Python pre-check passes but the RTL refuses would show the reason only in a
    build log: at the edge of the accepted range both agree (2 MHz builds, 1.5 MHz does not)."""
    native_comm.check_config(cm.CommutationConfig(clk_hz=2_000_000))
    with pytest.raises(ValueError):
        native_comm.check_config(cm.CommutationConfig(clk_hz=1_500_000))
