"""cocotb harness for rtl/commutation/commutator.v (imported inside the simulator process): a frame
driver that changes the inputs at chosen points inside frames, and a DAC model that records every
load and checks the port's timing (setup, hold, strobe width, settling) from simulation time.

The checks on the recorded schedule (`check_schedule`) are plain Python, so a test can show that
they fail on a wrong schedule.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.simtime import get_sim_time
from cocotb.triggers import FallingEdge, First, RisingEdge, Timer

from .commutation import CommutationConfig, Frames, encode, load_clocks


def period_ps(cfg: CommutationConfig) -> int:
    """The simulated clock period, ps (the simulators run at 1 ps precision; cocotb's Clock
    needs an even number of steps). Exact when 10**12 / CLK_HZ is a whole even number of ps
    (50, 25, 12.5 MHz); otherwise the nearest even number of ps: 20834 ps for the 48 MHz default
    (exact 20833.33), 83334 ps for the board's 12 MHz (exact 83333.33).

    The RTL is synchronous, so every event it makes falls on a clock edge. `check_schedule`
    therefore (1) requires every time difference to be a whole number of simulated periods,
    (2) compares the clock counts with the spec (the documented latencies), and (3) asserts the
    simulated times against the spec's real times (2 us skew, 16 us frame) with the tolerance
    this rounding implies and nothing more: N clocks of simulated period p differ from N clocks
    of the exact period by N * |p - 10**12 / CLK_HZ| (64 ps over a 96-clock skew at 48 MHz,
    512 ps over a frame), less than one clock, so a schedule one clock off still fails."""
    if cfg.clk_hz <= 0:
        raise ValueError(f"CLK_HZ {cfg.clk_hz} must be positive")
    p = round(10**12 / cfg.clk_hz / 2) * 2
    if p < 2:
        raise ValueError(f"CLK_HZ {cfg.clk_hz}: the period is below 2 ps")
    return p


def period_error_ps(cfg: CommutationConfig) -> Fraction:
    """|simulated period - exact period|, ps (0 where the period is exact)."""
    return abs(Fraction(period_ps(cfg)) - Fraction(10**12, cfg.clk_hz))


def spec_tolerance_ps(cfg: CommutationConfig, spec_ps: int) -> Fraction:
    """The largest difference between a simulated and a real time of `spec_ps` (a whole number
    of exact clock periods): its clock count times the period error."""
    n = Fraction(spec_ps) / Fraction(10**12, cfg.clk_hz)
    if n.denominator != 1:
        raise ValueError(f"{spec_ps} ps is not a whole number of clocks at {cfg.clk_hz} Hz")
    return n * period_error_ps(cfg)


def now_ps() -> int:
    return int(round(get_sim_time(unit="ps")))


@dataclass
class Load:
    t_ps: int
    addr: int
    word: int


@dataclass
class DacModel:
    """The DAC as the board has it: loads on the rising edge of dac_wr_n; data and address must
    be stable >= 1 clock before the strobe falls and >= 1 clock after it rises; a channel must not
    be rewritten within its settling time (except after a reset: safety comes first)."""
    dut: object
    cfg: CommutationConfig
    loads: list[Load] = field(default_factory=list)
    violations: list[str] = field(default_factory=list)
    powerup: list[Load] = field(default_factory=list)   # a strobe low from time 0, see below
    last_change: int = -(10**15)
    last_rise: int = -(10**15)
    reset_ps: int = 0

    def start(self) -> None:
        cocotb.start_soon(self._watch_data())
        cocotb.start_soon(self._watch_strobe())

    async def _watch_data(self) -> None:
        p = period_ps(self.cfg)
        dut = self.dut
        while True:
            await First(dut.dac_data.value_change, dut.dac_addr.value_change)
            t = now_ps()
            if t > 0 and str(dut.dac_wr_n.value) == "0":  # (t = 0: the pins' power-up values)
                self.violations.append(f"{t} ps: data/address changed while dac_wr_n is low")
            if t - self.last_rise < p:
                self.violations.append(f"{t} ps: hold {t - self.last_rise} ps < one clock")
            self.last_change = t

    async def _watch_strobe(self) -> None:
        p = period_ps(self.cfg)
        settle = self.cfg.clk_hz // 1000 * self.cfg.settle_ns // 1_000_000 * p  # in clocks
        dut = self.dut
        last: dict[int, int] = {}
        while True:
            await FallingEdge(dut.dac_wr_n)
            t_f = now_ps()
            if t_f == 0:
                # low from time 0: the pin register's power-up value (a gate-level iCE40 netlist:
                # every flip-flop configures to 0), raised by the first clock edge in reset. The
                # DAC loads whatever the data pins hold then: that must be zero torque.
                await RisingEdge(dut.dac_wr_n)
                try:
                    a, w = int(dut.dac_addr.value), int(dut.dac_data.value)
                except ValueError:
                    self.violations.append(f"{now_ps()} ps: power-up load of an unknown word")
                    continue
                self.powerup.append(Load(now_ps(), a, w))
                if w != int(encode(np.zeros(1, dtype=np.int64), self.cfg)[0]):
                    self.violations.append(f"{now_ps()} ps: power-up load of word {w} into "
                                           f"channel {a}: not zero torque")
                continue
            if t_f - self.last_change < p:
                self.violations.append(f"{t_f} ps: setup {t_f - self.last_change} ps < one clock")
            await RisingEdge(dut.dac_wr_n)
            t_r = now_ps()
            if t_r - t_f < p:
                self.violations.append(f"{t_r} ps: strobe low {t_r - t_f} ps < one clock")
            a, w = int(dut.dac_addr.value), int(dut.dac_data.value)
            if a in last and last[a] >= self.reset_ps and t_r - last[a] < settle:
                self.violations.append(f"{t_r} ps: channel {a} rewritten after "
                                       f"{t_r - last[a]} ps < settling {settle} ps")
            last[a] = t_r
            self.last_rise = t_r
            self.loads.append(Load(t_r, a, w))


def pack(values: np.ndarray, width: int) -> int:
    out = 0
    for i, v in enumerate(np.asarray(values, dtype=np.int64).tolist()):
        out |= (int(v) & ((1 << width) - 1)) << (i * width)
    return out


class Bench:
    """Clock, reset, input driver and DAC model around a commutator DUT."""

    def __init__(self, dut, cfg: CommutationConfig) -> None:
        self.dut = dut
        self.cfg = cfg
        self.p = period_ps(cfg)
        self.dac = DacModel(dut, cfg)

    def drive(self, f: Frames, i: int) -> None:
        d, c = self.dut, self.cfg
        d.s_pos.value = pack(f.pos[i], c.count_bits)
        d.s_torque.value = pack(f.torque[i], 16)
        d.ctl_offset.value = pack(f.offset[i], c.angle_bits)
        d.ctl_mode.value = pack(f.mode[i], 2)
        d.ctl_enable.value = int(f.enable[i])
        d.ctl_torque_limit.value = int(f.limit[i]) & 0xFFFF
        d.axis_fault.value = pack(f.fault[i], 1)

    async def start(self, first: Frames, reset_clocks: int = 4) -> int:
        """Clock, inputs = first row, reset; returns the time (ps) of frame 0's start."""
        self.drive(first, 0)
        self.dut.rst.value = 1
        cocotb.start_soon(Clock(self.dut.clk, self.p, unit="ps").start())
        self.dac.start()
        for _ in range(reset_clocks):
            await RisingEdge(self.dut.clk)
        t0 = now_ps()  # the last edge that samples rst high: frame 0 starts here
        await FallingEdge(self.dut.clk)
        self.dut.rst.value = 0
        return t0

    async def reset(self, clocks: int = 2) -> int:
        await FallingEdge(self.dut.clk)
        self.dut.rst.value = 1
        for _ in range(clocks):
            await RisingEdge(self.dut.clk)
        t0 = now_ps()
        self.dac.reset_ps = t0
        await FallingEdge(self.dut.clk)
        self.dut.rst.value = 0
        return t0

    async def latch(self) -> int:
        """Wait for the next frame start (the edge that latches the inputs); its time in ps."""
        await RisingEdge(self.dut.m_frame)
        await RisingEdge(self.dut.clk)
        return now_ps()

    async def run(self, frames: Frames, change_at: np.ndarray) -> list[int]:
        """Row i is latched at frame start i (returned); row i+1 is driven change_at[i] clocks
        (1 .. frame_clocks - 2, on a falling edge) after it, i.e. in the middle of frame i."""
        latches = []
        for i in range(len(frames)):
            latches.append(await self.latch())
            if i + 1 < len(frames):
                await Timer(int(change_at[i]) * self.p - self.p // 2, unit="ps")
                self.drive(frames, i + 1)
        await Timer(self.cfg.frame_ns * 1000, unit="ps")  # the last frame's loads
        return latches


def check_schedule(loads: list[Load], latches: list[int], cfg: CommutationConfig,
                   t0_ps: int | None = None) -> np.ndarray:
    """Check the recorded loads against the spec and return the words, shape (frames, 6).

    Frame i = the loads from latches[i] on. Asserted in simulation time: channel order
    0..5 in every frame; every load on a clock edge (a whole number of periods after the frame
    start); latency from the frame start to channel k exactly the model's load clocks; skew
    between successive channels and frame start to frame start of channel 0 equal to skew_ns and
    frame_ns, exactly where the simulated period is exact and otherwise within the rounding
    tolerance of `period_ps` (less than a clock). With t0_ps (the start of frame 0 after reset),
    the six loads before the first latch must be zero torque in the same timing."""
    p = period_ps(cfg)
    skew_ps, frame_ps = cfg.skew_ns * 1000, cfg.frame_ns * 1000
    tol_skew, tol_frame = spec_tolerance_ps(cfg, skew_ps), spec_tolerance_ps(cfg, frame_ps)
    t = np.array([ld.t_ps for ld in loads], dtype=np.int64)
    a = np.array([ld.addr for ld in loads], dtype=np.int64)
    w = np.array([ld.word for ld in loads], dtype=np.int64)
    starts = list(latches)
    if t0_ps is not None:
        starts = [t0_ps] + starts
    want_lat = load_clocks(cfg) * p
    words = []
    prev0 = None
    for ts in starts:
        sel = (t >= ts) & (t < ts + cfg.frame_clocks * p)
        assert np.count_nonzero(sel) == 6, f"frame at {ts} ps: {np.count_nonzero(sel)} loads, not 6"
        tf, af = t[sel], a[sel]
        assert np.array_equal(af, np.arange(6)), f"frame at {ts} ps: channel order {af.tolist()}"
        assert np.all((tf - ts) % p == 0), f"frame at {ts} ps: a load off the clock edges"
        skew = np.diff(tf)
        assert np.all(np.abs(skew - skew_ps) <= tol_skew), (
            f"frame at {ts} ps: skew {skew.tolist()} ps, spec {skew_ps} +- {float(tol_skew):g}")
        assert np.array_equal(tf - ts, want_lat), (
            f"frame at {ts} ps: latency {(tf - ts).tolist()} ps, documented {want_lat.tolist()}")
        if prev0 is not None:
            assert abs(int(tf[0] - prev0) - frame_ps) <= tol_frame, (
                f"frame period {tf[0] - prev0} ps, spec {frame_ps} +- {float(tol_frame):g}")
        prev0 = tf[0]
        words.append(w[sel])
    out = np.array(words, dtype=np.int64).reshape(len(starts), 6)
    if t0_ps is not None:
        zero = encode(np.zeros(6, dtype=np.int64), cfg)
        assert np.array_equal(out[0], zero), (
            f"frame 0 after reset wrote {out[0].tolist()}, not zero")
        out = out[1:]
    return out


def random_frames(rng: np.random.Generator, n: int, cfg: CommutationConfig,
                  modes: tuple[int, ...] = (0, 1, 2, 3)) -> Frames:
    """Random rows: positions, offsets, torques (with extremes), modes, enable, faults, limit."""
    pos = rng.integers(0, 1 << 32, (n, 3), dtype=np.int64)
    torque = rng.integers(-32768, 32768, (n, 3))
    ext = rng.random((n, 3)) < 0.2
    torque = np.where(ext, rng.choice([-32768, -32767, 32767, 0, 1, -1], (n, 3)), torque)
    offset = rng.integers(0, cfg.codes, (n, 3))
    mode = rng.choice(np.array(modes), (n, 3), p=None)
    enable = (rng.random(n) < 0.9).astype(np.int64)
    fault = (rng.random((n, 3)) < 0.1).astype(np.int64)
    limit = np.where(rng.random(n) < 0.5, 65535, rng.integers(0, 65536, n))
    return Frames(pos, torque, offset, mode, enable, fault, limit)
