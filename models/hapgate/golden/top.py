"""The whole FPGA (rtl/top/hapgate_top.v) as a chain of the golden models, clock-exact.

ADC samples -> hapgate.golden.interp.run (per axis) -> positions and faults, visible from a known
clock
edge -> at each commutation frame start the latest visible pos_homed (low COUNT_BITS bits) and
the register state -> hapgate.golden.commutation.commutate -> DAC words -> the top's output stage,
which
replaces a channel's word by zero torque if, at that channel's presentation edge, the watchdog
has expired, drive is disabled (globally or for that axis) or the axis has a fault.

Clock edges are counted from the last edge that samples rst high (edge 0):

- sample n is captured at edge (n + 1) * DIV + 1 (DIV = CLK_HZ / SAMPLE_HZ) and its results are
  in the interpolator's output registers from edge (n + 1) * DIV + LATENCY on (LATENCY =
  InterpConfig.latency: 5 for the paper's path, 6 with CAL, 16 + HARM with the ratio stage):
  an edge e sees sample n iff (n + 1) * DIV + LATENCY < e;
- frame k >= 1 starts (its inputs are latched) at edge k * FRAME_CLOCKS; frame 0 (from reset) is
  zero torque;
- channel c of frame k: its word is presented on the pins at edge
  k * FRAME + c * SKEW + LOAD - WR_CYCLES (LOAD = the commutator's load latency, 8 clocks), and
  the DAC loads it (dac_wr_n rises) at k * FRAME + c * SKEW + LOAD + 1: one clock after the
  commutator's own load (the output stage's register);
- a register written by a bus access committed at edge C is seen by edges > C; a control pulse
  (home arm, fault clear) leaves the register file at C + 1 and applies to the first sample
  captured at or after edge C + 1.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field, replace

import numpy as np

from ..base.block import Params
from . import commutation, interp
from .commutation import CommutationConfig, Frames
from .interp import InterpConfig

LATENCY = 5             # the paper's interpolator: capture-strobe cycle to output registers
OFF = commutation.OFF
DAC_TWR_NS = 50         # DAC7624/7625 t_WCS, CS low for write >= 50 ns (rtl/top/README.md)


def dac_wr_clocks(clk_hz: int, twr_ns: int = DAC_TWR_NS) -> int:
    """Clocks the DAC write strobe must stay low at clk_hz to last twr_ns (at least 1):
    ceil(twr_ns * CLK_KHZ / 10**6), as hapgate_top.v derives WR_MIN."""
    return max(1, -(-twr_ns * (clk_hz // 1000) // 1_000_000))


@dataclass(frozen=True)
class TopConfig:
    """The golden model's view of the whole FPGA. Made by hapgate.golden.configs (a named
    configuration's `top()`), which checks the parameters once (`configs.problems`)."""

    clk_hz: int = 48_000_000
    sample_hz: int = 1_000_000
    interp: InterpConfig = field(default_factory=InterpConfig)
    comm: CommutationConfig = field(default_factory=CommutationConfig)
    lines_log2: int = 10
    dac_twr_ns: int = DAC_TWR_NS   # the DAC's minimum write pulse: sets the strobe's clocks
    vel_obs_sel: bool = False    # VEL_CTRL.SEL resets to 7: every axis reports the observer

    def __post_init__(self) -> None:
        if self.comm.clk_hz != self.clk_hz:
            object.__setattr__(self, "comm", replace(self.comm, clk_hz=self.clk_hz))
        wr = max(self.comm.wr_cycles, dac_wr_clocks(self.clk_hz, self.dac_twr_ns))
        if wr != self.comm.wr_cycles:  # as hapgate_top.v: never shorter than the DAC's t_WCS
            object.__setattr__(self, "comm", replace(self.comm, wr_cycles=wr))
        if self.comm.count_bits != self.count_bits:
            raise ValueError("commutation count_bits must be lut_bits + 3 + lines_log2")

    @property
    def count_bits(self) -> int:
        return self.interp.lut_bits + 3 + self.lines_log2

    @property
    def div(self) -> int:
        return self.clk_hz // self.sample_hz

    @property
    def zero_word(self) -> int:
        return int(commutation.encode(np.zeros(1, dtype=np.int64), self.comm)[0])

    def rtl_params(self) -> Params:
        c, i = self.comm, self.interp
        return {"CLK_HZ": self.clk_hz, "SAMPLE_HZ": self.sample_hz, "LUT_BITS": i.lut_bits,
                "ASIN_FILE": i.lut_file(), "VEL_LOG2W": i.vel_log2w,
                "AMP_MIN": i.amp_min, "AMP_MAX": i.amp_max, "LOSS_SAMPLES": i.loss_samples,
                "LINES_LOG2": self.lines_log2, "POLE_PAIRS": c.pole_pairs,
                "SKEW_NS": c.skew_ns, "FRAME_NS": c.frame_ns, "SETTLE_NS": c.settle_ns,
                "WR_CYCLES": c.wr_cycles, "DAC_TWR_NS": self.dac_twr_ns,
                **{k: v for k, v in c.rtl_params().items() if k in ("ADDR_BITS", "MAG_BITS", "FS")},
                "SINE_FILE": c.rtl_params()["LUT_FILE"], "DAC_BITS": c.dac_bits,
                "OFFSET_BINARY": int(c.offset_binary), "SERIAL_MUL": int(c.serial_mul),
                "BUS_ADDR_BITS": 8,
                **({"CAL": 1, "CAL_LUT_FILE": i.cal_lut_file(),
                    "CAL_LINES_LOG2": i.cal_lines_log2, "CAL_NLOG": i.cal_nlog} if i.cal else {}),
                **({"COARSE": 1} if i.coarse else {}),
                **({"VEL_OBS": 1} if i.vel_obs else {}),
                **{k: v for k, v in i.rtl_params().items()
                   if k in ("ANGLE", "RATIO_BITS", "RATIO_FILE", "ANGLE_REG", "HARM",
                            "HARM_LOG2")},
                **({"VEL_OBS_SEL": 1} if self.vel_obs_sel else {})}


# the whole FPGA's sources, relative to rtl/ (its blocks, one per named configuration:
# hapgate.golden.configs.blocks)
SOURCES = ("interp/enc_calib.v", "interp/ratio_div.v", "interp/vel_observer.v",
           "interp/enc_interp.v", "interp/sample_strobe.v", "interp/enc_interp3.v",
           "commutation/sine_lut.v", "dac_sched/dac_sched.v", "commutation/commutator.v",
           "bus/emif_slave.v", "bus/hg_regfile.v", "bus/hg_bus.v", "capture/hg_capture.v",
           "top/hapgate_top.v")


# ---------------------------------------------------------------------------- register timeline

@dataclass
class Controls:
    """The register-file outputs that drive the motors (what a frame latch or the output stage
    sees)."""
    global_en: int = 0
    axis_en: tuple[int, int, int] = (0, 0, 0)
    torque: tuple[int, int, int] = (0, 0, 0)      # signed 16-bit
    offset: tuple[int, int, int] = (0, 0, 0)
    mode: tuple[int, int, int] = (OFF, OFF, OFF)
    tq_limit: tuple[int, int, int] = (0, 0, 0)
    wdog_expired: int = 0


@dataclass
class Timeline:
    """Piecewise-constant controls: entry (edge C, controls) holds for edges > C."""
    edges: list[int] = field(default_factory=lambda: [-(10**9)])
    values: list[Controls] = field(default_factory=lambda: [Controls()])

    def set(self, edge: int, c: Controls) -> None:
        if edge < self.edges[-1]:
            raise ValueError("timeline edges must not decrease")
        self.edges.append(edge)
        self.values.append(c)

    def at(self, edge: int) -> Controls:
        """The controls an edge sees (set at an edge strictly before it)."""
        return self.values[bisect.bisect_left(self.edges, edge) - 1]


def pulse_samples(pulse_commit_edges: list[int], cfg: TopConfig) -> list[int]:
    """Sample indices a control pulse applies to: the first sample captured at or after C + 1."""
    out = []
    for c in pulse_commit_edges:
        # capture edge of sample n = (n + 1) * DIV + 1 >= c + 1
        out.append(max(0, -(-c // cfg.div) - 1))
    return out


@dataclass
class TopResult:
    load_edge: np.ndarray      # (frames*6,) edge of each pin load (rising dac_wr_n)
    addr: np.ndarray
    word: np.ndarray
    codes: np.ndarray          # (frames, 6) signed commutator codes before the output stage
    frame_samples: np.ndarray  # (frames,) sample index latched by each frame (-1: none)
    axes: list[interp.InterpOut]


def simulate(a: np.ndarray, b: np.ndarray, index: np.ndarray, timeline: Timeline,
             cfg: TopConfig, frames: int, arm_edges: list[list[int]] | None = None,
             clear_edges: list[int] | None = None) -> TopResult:
    """Expected DAC loads of frames 0..frames-1 for ADC samples a, b, index (shape (n, 3))."""
    c = cfg.comm
    n = a.shape[0]
    arm_edges = arm_edges or [[], [], []]
    clear_at = pulse_samples(clear_edges or [], cfg)
    axes = [interp.run(a[:, i], b[:, i], index[:, i], cfg.interp, clear_at=clear_at,
                       arm_at=pulse_samples(arm_edges[i], cfg)) for i in range(3)]
    pos_homed = np.stack([ax.pos_homed for ax in axes], 1).astype(np.int64)
    fault = np.stack([ax.faults != 0 for ax in axes], 1)

    def sample_seen(edge: np.ndarray) -> np.ndarray:
        """Latest sample whose results an edge sees: (n + 1) * DIV + LATENCY < edge."""
        s = (np.asarray(edge) - cfg.interp.latency - 1) // cfg.div - 1
        if np.any(s >= n):
            raise ValueError("the run needs more ADC samples than given")
        return s

    k = np.arange(frames)
    latch = k * c.frame_clocks
    smp = sample_seen(latch)
    ctl = [timeline.at(int(e)) for e in latch]
    sidx = np.maximum(smp, 0)
    mask = (1 << cfg.count_bits) - 1
    pos = pos_homed[sidx] & mask
    tq = np.array([x.torque for x in ctl], dtype=np.int64)
    lim = np.array([x.tq_limit for x in ctl], dtype=np.int64)
    tq = commutation.clamp_torque(tq, lim)
    mode = np.array([[m if e else OFF for m, e in zip(x.mode, x.axis_en)] for x in ctl])
    enable = np.array([int(x.global_en and not x.wdog_expired) for x in ctl])
    flt = fault[sidx].astype(np.int64)
    fr = Frames.make(pos, tq, offset=np.array([x.offset for x in ctl]), mode=mode,
                     enable=enable, fault=flt, limit=65535)
    codes = commutation.commutate(fr, c)
    codes[k == 0] = 0                       # frame 0: the commutator's reset frame
    codes[smp < 0] = 0                      # (no sample yet: never in a real run)
    words = commutation.encode(codes, c)

    # output stage: each channel's word is zeroed by the controls/faults at its presentation edge
    ch = np.arange(6)
    present = latch[:, None] + ch[None, :] * c.skew_clocks + c.load_clocks - c.wr_cycles
    seen = sample_seen(present)
    out = words.copy()
    for f in range(frames):
        for j in range(6):
            e = int(present[f, j])
            x = timeline.at(e)
            m = j // 2
            faulted = seen[f, j] >= 0 and bool(fault[seen[f, j], m])
            if x.wdog_expired or not x.global_en or not x.axis_en[m] or faulted:
                out[f, j] = cfg.zero_word
    load = present + c.wr_cycles + 1
    return TopResult(load.ravel(), np.tile(ch, frames), out.ravel(), codes, smp, axes)
