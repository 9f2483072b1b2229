"""cocotb tests of rtl/commutation/commutator.v against models/hapgate/golden/commutation.py:
bit-exact codes on all six channels, the DAC port's timing from simulation time, saturation, the
safety paths, the paper's figures from the RTL's own codes, and the replay engine."""

from __future__ import annotations

import os

import cocotb
import numpy as np
from hapgate.golden import commutation as cm
from hapgate.golden.dacsched import check_schedule, random_frames
from hapgate.runners import tbutil
from hapgate.runners.cocotb_dac import Bench


def config() -> cm.CommutationConfig:
    return cm.CommutationConfig.from_json(tbutil.model_config())


def codes_of(words: np.ndarray, cfg: cm.CommutationConfig) -> np.ndarray:
    return cm.decode(words, cfg)


async def run_rows(dut, cfg: cm.CommutationConfig, frames: cm.Frames, change_at: np.ndarray
                   ) -> tuple[Bench, np.ndarray]:
    """Reset, run every row (row i latched at frame start i + 1 after reset), check the schedule
    (including frame 0's zeros) and return the signed codes the DAC received, shape (n, 6)."""
    bench = Bench(dut, cfg)
    t0 = await bench.start(frames)
    latches = await bench.run(frames, change_at)
    words = check_schedule(bench.dac.loads, latches, cfg, t0_ps=t0)
    assert not bench.dac.violations, "DAC model: " + "; ".join(bench.dac.violations[:5])
    return bench, codes_of(words[: len(frames)], cfg)


def assert_codes(got: np.ndarray, want: np.ndarray, frames: cm.Frames) -> None:
    bad = np.argwhere(got != want)
    if bad.size:
        i, k = bad[0]
        raise AssertionError(
            f"{len(bad)} mismatching codes; first: frame {i} channel {cm.CHANNELS[k]} got "
            f"{got[i, k]} want {want[i, k]} (pos {frames.pos[i].tolist()} torque "
            f"{frames.torque[i].tolist()} offset {frames.offset[i].tolist()} mode "
            f"{frames.mode[i].tolist()} enable {frames.enable[i]} fault {frames.fault[i].tolist()} "
            f"limit {frames.limit[i]})")


@cocotb.test()
async def random_bit_exact(dut):
    """Random positions, offsets, torques (with the extremes), modes, enable, faults and limits;
    each row is driven in the MIDDLE of the previous frame (anywhere from before its first load
    to after its last), so a change must take effect at the next frame, never mid-frame."""
    cfg = config()
    n = int(os.environ.get("HG_FRAMES", "300"))
    rng = np.random.default_rng(int(os.environ.get("HG_SEED", "4")))
    frames = random_frames(rng, n, cfg)
    change_at = rng.integers(1, cfg.frame_clocks - 1, n)
    _, got = await run_rows(dut, cfg, frames, change_at)
    assert_codes(got, cm.commutate(frames, cfg), frames)
    dut._log.info("%d frames x 6 channels bit-exact", n)


@cocotb.test()
async def saturation_extremes(dut):
    """-32768 x (-1) and the other extremes land exactly on +-(2**(DAC_BITS-1) - 1) (the spec's
    symmetric +-8191), in SINE and SIX_STEP, with and without the torque limit."""
    cfg = config()
    lut = cm.unfold(np.arange(cfg.codes), cm.quarter_table(cfg.rom), cfg.rom.addr_bits)
    k_pos, k_neg = int(np.argmax(lut)), int(np.argmin(lut))  # sin = +1 and -1 on the ROM grid
    assert lut[k_pos] == cfg.rom.fs and lut[k_neg] == -cfg.rom.fs
    rows = []  # (offset = angle code of channel a, torque, mode, limit, expected code on a)
    top = cfg.max_code if cfg.rom.fs == (1 << cfg.rom.mag_bits) - 1 else None
    for mode in (cm.SINE, cm.SIX_STEP):
        for k, sgn in ((k_pos, 1), (k_neg, -1)):
            for t in (-32768, 32767, -32767):
                for lim in (65535, 32767):
                    rows.append((k, t, mode, lim, sgn * (1 if t > 0 else -1)))
    n = len(rows)
    off = np.array([r[0] for r in rows])
    frames = cm.Frames.make(np.zeros((n, 3), dtype=np.int64),
                            np.array([r[1] for r in rows])[:, None] * np.ones(3, dtype=np.int64),
                            offset=off[:, None] * np.ones(3, dtype=np.int64),
                            mode=np.array([r[2] for r in rows])[:, None]
                            * np.ones(3, dtype=np.int64),
                            limit=np.array([r[3] for r in rows]))
    _, got = await run_rows(dut, cfg, frames, np.full(n, 3))
    assert_codes(got, cm.commutate(frames, cfg), frames)
    sign = np.array([r[4] for r in rows])
    assert np.all(np.sign(got[:, 0]) == sign), f"sign of channel a: {got[:, 0].tolist()}"
    if top is not None:  # full-scale ROM: the extremes are the DAC's symmetric limits, exactly
        assert np.all(np.abs(got[:, ::2]) == top), f"channel a codes {got[:, 0].tolist()}"
    assert np.all(np.abs(got) <= cfg.max_code)


@cocotb.test()
async def safety_paths(dut):
    """Zero torque (code 0 in the DAC's coding) in frame 0 after reset with the inputs already
    enabled at full torque; while disabled; on an axis fault (that motor only); in OFF mode; and
    again in the first frame after a reset in mid-operation."""
    cfg = config()
    n = 8
    pos = np.zeros((n, 3), dtype=np.int64)
    # channel a at 45 deg electrical, b at -75 deg: both clearly non-zero when driven
    off = np.full((n, 3), cfg.codes // 8)
    enable = np.array([1, 0, 1, 1, 1, 1, 1, 1])
    fault = np.zeros((n, 3), dtype=np.int64)
    fault[2, 1] = 1
    fault[3] = 1
    mode = np.zeros((n, 3), dtype=np.int64)
    mode[4, 2] = cm.OFF
    mode[5] = [cm.SIX_STEP, cm.ALIGN, cm.SINE]
    frames = cm.Frames.make(pos, 30000, offset=off, mode=mode, enable=enable, fault=fault)
    bench, got = await run_rows(dut, cfg, frames, np.full(n, 5))
    assert_codes(got, cm.commutate(frames, cfg), frames)
    zero = np.zeros((n, 6), dtype=bool)
    zero[1] = True
    zero[2, 2:4] = True
    zero[3] = True
    zero[4, 4:6] = True
    assert np.all(got[zero] == 0), f"not zero where the safety paths say so: {got.tolist()}"
    assert np.all(np.abs(got[~zero]) > 1000), f"a driven channel is (near) zero: {got.tolist()}"

    # reset in mid-operation: the frame that starts at the reset writes zero to all six channels
    full = cm.Frames.make(pos[:1], 30000, offset=off[:1])
    bench.drive(full, 0)
    await bench.latch()
    await bench.latch()
    await cocotb.triggers.Timer(3 * cfg.skew_ns * 1000 + 500, unit="ps")
    bench.dac.loads.clear()
    t_rst = await bench.reset()
    latches = [await bench.latch()]
    await cocotb.triggers.Timer(cfg.frame_ns * 1000, unit="ps")
    words = check_schedule(bench.dac.loads, latches, cfg, t0_ps=t_rst)
    assert np.array_equal(codes_of(words[0], cfg), cm.commutate(full, cfg)[0])
    assert not bench.dac.violations, "; ".join(bench.dac.violations[:5])


@cocotb.test()
async def paper_figures(dut):
    """The paper's Figs. 8/9 numbers from the RTL's own DAC codes through the motor model:
    one electrical cycle at every position where a code can change, SINE then SIX_STEP."""
    cfg = config()
    sweeps, frames = {}, []
    for mode in (cm.SINE, cm.SIX_STEP):
        sw, fr = cm.sweep_frames(cfg, mode)
        sweeps[mode] = sw
        frames.append(fr)
    both = cm.Frames(*(np.concatenate([getattr(f, k) for f in frames])
                       for k in cm.Frames.__dataclass_fields__))
    _, got = await run_rows(dut, cfg, both, np.full(len(both), 2))
    assert_codes(got, cm.commutate(both, cfg), both)
    n0 = len(frames[0])
    codes = {cm.SINE: got[:n0], cm.SIX_STEP: got[n0:]}
    fig = cm.figures(cfg, codes, sweeps)
    dut._log.info("figures from the RTL: %s", fig)
    if os.environ.get("HG_DUMP"):
        np.savez(os.environ["HG_DUMP"], sine=codes[cm.SINE], six_step=codes[cm.SIX_STEP],
                 sine_pos=sweeps[cm.SINE].pos, six_pos=sweeps[cm.SIX_STEP].pos)
    # six-step: (max - min)/max = 1 - cos 30deg, mean 3 sqrt(3)/pi (the edges are exact to a count)
    assert abs(fig["six_step_ripple"] - (1 - np.cos(np.pi / 6))) < 2e-4, fig
    assert abs(fig["six_step_mean"] - 3 * np.sqrt(3) / np.pi) < 1e-3, fig
    # sine: ripple within the 0.3 % p-p budget; mean 1.5; ratio 0.907 (pi / (2 sqrt 3))
    assert fig["sine_ripple"] <= 0.003, fig
    assert abs(fig["sine_mean"] - 1.5) < 1e-3, fig
    assert abs(fig["mean_ratio"] - np.pi / (2 * np.sqrt(3))) < 1e-3, fig


@cocotb.test()
async def replay(dut):
    """The replay engine: frames from HG_REPLAY_IN (npz), words and load times to HG_REPLAY_OUT.
    Run by `hapgate replay commutation --engine rtl` (the pytest files select the checks above)."""
    cfg = config()
    src = os.environ.get("HG_REPLAY_IN")
    assert src, "the replay test needs HG_REPLAY_IN and HG_REPLAY_OUT (hapgate replay sets them)"
    z = np.load(src)
    frames = cm.Frames(*(z[k] for k in cm.Frames.__dataclass_fields__))
    bench = Bench(dut, cfg)
    t0 = await bench.start(frames)
    latches = await bench.run(frames, np.full(len(frames), 2))
    words = check_schedule(bench.dac.loads, latches, cfg, t0_ps=t0)
    t = np.array([ld.t_ps for ld in bench.dac.loads], dtype=np.int64)
    lat = np.array([t[(t >= ts) & (t < ts + cfg.frame_ns * 1000)] - ts for ts in latches])
    np.savez(os.environ["HG_REPLAY_OUT"], codes=codes_of(words[: len(frames)], cfg),
             load_ps=lat[: len(frames)], violations=np.array(bench.dac.violations, dtype=str))
