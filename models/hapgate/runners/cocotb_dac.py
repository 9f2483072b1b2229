"""cocotb harness for rtl/commutation/commutator.v and the top's DAC port (imported inside the
simulator process): a frame driver that changes the inputs at chosen points inside frames, and a
DAC model that records every load and checks the port's timing (setup, hold, strobe width,
settling) from simulation time. The schedule's checks are hapgate.golden.dacsched.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.simtime import get_sim_time
from cocotb.triggers import FallingEdge, First, RisingEdge, Timer

from ..golden.commutation import CommutationConfig, Frames, encode
from ..golden.dacsched import Load, pack, period_ps
from . import funcov


def now_ps() -> int:
    return int(round(get_sim_time(unit="ps")))


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
        if funcov.active():   # (the simulator process: write its database now)
            funcov.sample_dac([ld.addr for ld in self.dac.loads], self.cfg.clk_hz)
            funcov.sample_commutation(frames.mode, frames.torque, frames.limit)
            funcov.flush()
        return latches
