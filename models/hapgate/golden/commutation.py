"""Sinusoidal commutation and the six-channel DAC scheduler: bit-exact model of
rtl/commutation/commutator.v (+ rtl/dac_sched/dac_sched.v), float truth and a motor model.

Per frame (every input latched at the frame start; a change takes effect at the next frame):

1. Fine electrical angle u = ((pos mod 2**CB) * POLE_PAIRS) mod 2**CB (CB = count_bits = 20,
   2**20 counts per revolution). The angle code (AB = addr_bits + 2 = 10 bits) is u's top AB bits:
   with two pole pairs that is bits 18..9 of the position, i.e. the low 10 of the 11 MSBs 19..9.
   Code k stands for (k + 1/2) * 360deg / 2**AB, the sine ROM's convention (hapgate.golden.sine).
2. Offset (register, 1/2**AB electrical cycle): u_a = u + offset * 2**(CB - AB); ALIGN mode uses
   u = 0, so the current vector stands at the offset's angle (to find the index-to-winding offset).
3. Channel a's code k_a = top AB bits of u_a; channel b's k_b = k_a - round(2**AB / 3) mod 2**AB.
   2**AB / 3 is not an integer (341.33 for 1024): b is placed 341 codes = 119.88deg after a,
   1/3 code (0.117deg electrical) short of 120deg. This is the only systematic error of the scheme:
   the third phase -(a + b) is then 0.06deg off too, and the torque ripple it leaves is
   sqrt(3) * (2pi/3/2**AB) / 1.5 peak-to-peak relative (0.236 % at AB = 10), the sine mode's ripple.
4. Sample v: SINE and ALIGN: the ROM's value at the channel's code (one ROM, time-multiplexed).
   SIX_STEP: the Hall-sector pattern of the paper's Fig. 8, +-FS or 0, from the sector of u_a
   (edges at 30 + 60 s deg, D_j = ceil(j * 2**CB / 12) on the FINE angle, like real Hall sensors:
   exact to one count, not to the ROM grid). Sector n = edges passed (0..6);
   a: + for n in {1, 2}, - for n in {4, 5};
   b (120deg later): + for n in {3, 4}, - for n in {0, 1, 6}.
5. Torque t (signed 16) clamped to +-L with L = min(limit, 32768) (limit register, 16-bit unsigned).
6. Code = round_half_away(v * t / 2**SH), SH = 15 + MAG_BITS + 1 - DAC_BITS (15 by default: 32767 at
   sin = 1 gives 8191), saturated to +-(2**(DAC_BITS-1) - 1) (symmetric: -8191..+8191).
7. Zero (exactly code 0) when disabled, when the motor's axis has a fault, in OFF mode, and in the
   frame that starts at reset (nothing latched yet).
8. DAC word: two's complement, or offset binary (MSB inverted: zero torque = 2**(DAC_BITS-1)).

Timing (dac_sched): frame of FRAME_NS (16 us), channel k = 0..5 (m0a, m0b, m1a, m1b, m2a, m2b)
requested k * SKEW_NS (2 us) after the frame start; its DAC load (rising edge of dac_wr_n) comes
LOAD_CLOCKS = PIPE + 2 + WR_CYCLES = 8 clocks later (PIPE = 5, or 21 with serial_mul: the
shift-add multiplier of the LUT-only boards takes 16 clocks more; the codes are the same).
The frame start is the clock edge at which the inputs are latched; frame 0 starts at the last
clock edge that samples rst high (its six loads are zero torque).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from ..base.block import Block, Params
from ..base.report import figure_path, pyplot, save_figure
from .sine import SineRomConfig, quarter_table, rom_file, unfold

SINE, SIX_STEP, ALIGN, OFF = 0, 1, 2, 3
MODES = {"sine": SINE, "six_step": SIX_STEP, "align": ALIGN, "off": OFF}
CHANNELS = ("m0a", "m0b", "m1a", "m1b", "m2a", "m2b")
PIPE_CLOCKS = 5          # commutator: request clock to result clock (documented in the RTL)
SERIAL_MUL_CLOCKS = 16   # extra pipeline clocks of the shift-add multiplier (SERIAL_MUL=1)
TORQUE_FULL = 32767      # the torque command that maps sin = 1 to the DAC's full scale


@dataclass(frozen=True)
class CommutationConfig:
    clk_hz: int = 48_000_000
    skew_ns: int = 2000
    frame_ns: int = 16000
    settle_ns: int = 16000
    wr_cycles: int = 1
    count_bits: int = 20
    pole_pairs: int = 2
    rom: SineRomConfig = field(default_factory=SineRomConfig)
    dac_bits: int = 14
    offset_binary: bool = False
    serial_mul: bool = False   # one shift-add multiplier (16 clocks per product), no array/DSP

    @property
    def angle_bits(self) -> int:
        return self.rom.angle_bits

    @property
    def codes(self) -> int:
        return 1 << self.angle_bits

    @property
    def phase_b(self) -> int:
        """Channel b's lag in codes: round(2**AB / 3)."""
        return (self.codes + 1) // 3

    @property
    def shift(self) -> int:
        return 15 + self.rom.out_bits - self.dac_bits

    @property
    def max_code(self) -> int:
        return (1 << (self.dac_bits - 1)) - 1

    @property
    def skew_clocks(self) -> int:
        return self.clk_hz // 1000 * self.skew_ns // 1_000_000

    @property
    def frame_clocks(self) -> int:
        return self.clk_hz // 1000 * self.frame_ns // 1_000_000

    @property
    def pipe_clocks(self) -> int:
        """Commutator latency: request clock to result clock."""
        return PIPE_CLOCKS + (SERIAL_MUL_CLOCKS if self.serial_mul else 0)

    @property
    def load_clocks(self) -> int:
        """Clocks from a channel's request to its DAC load (rising dac_wr_n)."""
        return self.pipe_clocks + 2 + self.wr_cycles

    def to_json(self) -> dict[str, object]:
        d = {k: getattr(self, k) for k in self.__dataclass_fields__ if k != "rom"}
        d["rom"] = {"addr_bits": self.rom.addr_bits, "fs": self.rom.fs}
        return d

    @classmethod
    def from_json(cls, d: Mapping[str, object]) -> CommutationConfig:
        d = dict(d)
        rom = SineRomConfig(**d.pop("rom", {}))  # type: ignore[arg-type]
        return cls(rom=rom, **d)  # type: ignore[arg-type]

    def rtl_params(self) -> Params:
        """Parameters of rtl/commutation/commutator.v (pure: the ROM is a TableFile)."""
        return {"CLK_HZ": self.clk_hz, "SKEW_NS": self.skew_ns, "FRAME_NS": self.frame_ns,
                "SETTLE_NS": self.settle_ns, "WR_CYCLES": self.wr_cycles,
                "COUNT_BITS": self.count_bits, "POLE_PAIRS": self.pole_pairs,
                "ADDR_BITS": self.rom.addr_bits, "MAG_BITS": self.rom.mag_bits, "FS": self.rom.fs,
                "LUT_FILE": rom_file(self.rom), "DAC_BITS": self.dac_bits,
                "OFFSET_BINARY": int(self.offset_binary), "SERIAL_MUL": int(self.serial_mul)}

    def with_(self, **kw: object) -> CommutationConfig:
        return replace(self, **kw)  # type: ignore[arg-type]


def dac_sched_params(cfg: CommutationConfig = CommutationConfig()) -> Params:
    """Parameters of rtl/dac_sched/dac_sched.v alone (the commutator's scheduler)."""
    return {"CLK_HZ": cfg.clk_hz, "SKEW_NS": cfg.skew_ns, "FRAME_NS": cfg.frame_ns,
            "SETTLE_NS": cfg.settle_ns, "CHANNELS": 6, "ADDR_BITS": 3,
            "DAC_BITS": cfg.dac_bits, "WR_CYCLES": cfg.wr_cycles, "PIPE_CYCLES": cfg.pipe_clocks}


def blocks() -> list[Block]:
    return [
        Block(name="dac_sched", top="dac_sched", sources=("dac_sched/dac_sched.v",),
              params=dac_sched_params, doc="six-channel DAC scheduler: 2 us skew, 16 us frame"),
        Block(name="commutator", top="commutator",
              sources=("commutation/sine_lut.v", "dac_sched/dac_sched.v",
                       "commutation/commutator.v"),
              params=lambda: CommutationConfig().rtl_params(),
              doc="three-motor sinusoidal commutation through one shared sine ROM"),
    ]


# ---------------------------------------------------------------------------- bit-exact model

@dataclass
class Frames:
    """Per-frame inputs (arrays of shape (n, 3) per motor, or (n,) for the globals)."""
    pos: np.ndarray
    torque: np.ndarray
    offset: np.ndarray
    mode: np.ndarray
    enable: np.ndarray
    fault: np.ndarray
    limit: np.ndarray

    @classmethod
    def make(cls, pos: np.ndarray, torque: np.ndarray, offset: np.ndarray | int = 0,
             mode: np.ndarray | int = SINE, enable: np.ndarray | int = 1,
             fault: np.ndarray | int = 0, limit: np.ndarray | int = 65535) -> Frames:
        pos = np.atleast_2d(np.asarray(pos, dtype=np.int64))
        n = pos.shape[0]

        def per_motor(x: np.ndarray | int) -> np.ndarray:
            return np.broadcast_to(np.asarray(x, dtype=np.int64), (n, 3)).copy()

        def glob(x: np.ndarray | int) -> np.ndarray:
            return np.broadcast_to(np.asarray(x, dtype=np.int64), (n,)).copy()

        return cls(pos, per_motor(torque), per_motor(offset), per_motor(mode), glob(enable),
                   per_motor(fault), glob(limit))

    def __len__(self) -> int:
        return int(self.pos.shape[0])

    def take(self, idx: np.ndarray | slice) -> Frames:
        return Frames(*(getattr(self, f)[idx] for f in self.__dataclass_fields__))


def fine_angle(pos: np.ndarray, cfg: CommutationConfig) -> np.ndarray:
    """u = ((pos mod 2**CB) * POLE_PAIRS) mod 2**CB."""
    mask = (1 << cfg.count_bits) - 1
    return ((np.asarray(pos, dtype=np.int64) & mask) * cfg.pole_pairs) & mask


def sector_edges(cfg: CommutationConfig) -> np.ndarray:
    """Six-step sector edges on the fine angle: ceil(j * 2**CB / 12), j = 1, 3, ..., 11."""
    j = np.arange(1, 12, 2, dtype=np.int64)
    return ((1 << cfg.count_bits) * j + 11) // 12


SIX_A = np.array([0, 1, 1, 0, -1, -1, 0])    # level of channel a by edges passed (0..6)
SIX_B = np.array([-1, -1, 0, 1, 1, 0, -1])   # channel b (120 deg later)


def channel_samples(frames: Frames, cfg: CommutationConfig) -> tuple[np.ndarray, np.ndarray]:
    """(angle codes, ROM/six-step samples v) per channel, shape (n, 6), order m0a, m0b, ..."""
    mask = (1 << cfg.count_bits) - 1
    u = fine_angle(frames.pos, cfg)
    u = np.where(frames.mode == ALIGN, 0, u)
    u_a = (u + (frames.offset.astype(np.int64) << (cfg.count_bits - cfg.angle_bits))) & mask
    k_a = u_a >> (cfg.count_bits - cfg.angle_bits)
    k_b = (k_a - cfg.phase_b) & (cfg.codes - 1)
    n_edges = (u_a[..., None] >= sector_edges(cfg)).sum(axis=-1)
    fs = cfg.rom.fs
    table = quarter_table(cfg.rom)
    six = frames.mode == SIX_STEP
    va = np.where(six, SIX_A[n_edges] * fs, unfold(k_a, table, cfg.rom.addr_bits))
    vb = np.where(six, SIX_B[n_edges] * fs, unfold(k_b, table, cfg.rom.addr_bits))
    codes = np.stack([k_a, k_b], axis=-1).reshape(len(frames), 6)
    v = np.stack([va, vb], axis=-1).reshape(len(frames), 6)
    return codes, v


def clamp_torque(torque: np.ndarray, limit: np.ndarray) -> np.ndarray:
    lim = np.minimum(np.asarray(limit, dtype=np.int64), 32768)
    return np.clip(np.asarray(torque, dtype=np.int64), -lim, lim)


def scale(v: np.ndarray, t: np.ndarray, cfg: CommutationConfig) -> np.ndarray:
    """round_half_away(v * t / 2**SH), saturated symmetrically."""
    p = np.asarray(v, dtype=np.int64) * np.asarray(t, dtype=np.int64)
    q = np.sign(p) * ((np.abs(p) + (1 << (cfg.shift - 1))) >> cfg.shift)
    return np.clip(q, -cfg.max_code, cfg.max_code)


def commutate(frames: Frames, cfg: CommutationConfig = CommutationConfig()) -> np.ndarray:
    """Signed DAC codes per frame, shape (n, 6): what the RTL writes (before the DAC coding)."""
    _, v = channel_samples(frames, cfg)
    t = np.repeat(clamp_torque(frames.torque, frames.limit[:, None]), 2, axis=1)
    code = scale(v, t, cfg)
    zero = (frames.enable[:, None] == 0) | (frames.fault != 0) | (frames.mode == OFF)
    return np.where(np.repeat(zero, 2, axis=1), 0, code)


def encode(codes: np.ndarray, cfg: CommutationConfig) -> np.ndarray:
    """Signed codes -> DAC words (unsigned, dac_bits wide)."""
    c = np.asarray(codes, dtype=np.int64)
    if cfg.offset_binary:
        return c + (1 << (cfg.dac_bits - 1))
    return c & ((1 << cfg.dac_bits) - 1)


def decode(words: np.ndarray, cfg: CommutationConfig) -> np.ndarray:
    w = np.asarray(words, dtype=np.int64)
    if cfg.offset_binary:
        return w - (1 << (cfg.dac_bits - 1))
    half = 1 << (cfg.dac_bits - 1)
    return np.where(w >= half, w - 2 * half, w)


def load_clocks(cfg: CommutationConfig) -> np.ndarray:
    """Clocks from the frame start (input latch edge) to each channel's DAC load."""
    return np.arange(6) * cfg.skew_clocks + cfg.load_clocks


def load_times_ns(cfg: CommutationConfig) -> np.ndarray:
    """Load time of each channel after the frame start, ns (the replay's t0_ns..t5_ns)."""
    return load_clocks(cfg) * 1e9 / cfg.clk_hz


# ---------------------------------------------------------------------------- float truth

def truth(pos: np.ndarray, torque: np.ndarray, offset: np.ndarray | int = 0,
          cfg: CommutationConfig = CommutationConfig(), exact_pos: np.ndarray | None = None
          ) -> np.ndarray:
    """Float truth of SINE mode, shape (n, 6): FS_out * t/32767 * sin(theta + offset - 120deg*b),
    theta the electrical angle of the position (exact_pos: continuous counts; default: pos + 1/2
    count, the middle of the count), 120deg exact, no rounding. Unit: DAC LSB."""
    p = np.asarray(pos if exact_pos is None else exact_pos, dtype=np.float64)
    if exact_pos is None:
        p = np.mod(p, 1 << cfg.count_bits) + 0.5
    theta = 2 * np.pi * (p * cfg.pole_pairs / (1 << cfg.count_bits)
                         + np.asarray(offset, dtype=np.float64) / cfg.codes)
    ang = np.stack([theta, theta - 2 * np.pi / 3], axis=-1).reshape(theta.shape[0], 6)
    t = np.repeat(np.asarray(torque, dtype=np.float64), 2, axis=-1) / TORQUE_FULL
    return cfg.max_code * t * np.sin(ang)


# ---------------------------------------------------------------------------- motor model

def motor_torque(ia: np.ndarray, ib: np.ndarray, theta: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Sinusoidally wound three-phase motor behind an amplifier that takes two channel currents
    and derives the third as -(a + b). Winding j's torque per unit current is sin(theta - j*120deg)
    (theta electrical, the angle the commutation aims at). Returns (per-phase torques (n, 3), sum).
    Unit: current 1 = full-scale DAC code; a matched sine drive gives 1.5, six-step 3*sqrt(3)/pi."""
    ic = -(ia + ib)
    k = np.sin(theta[:, None] - np.arange(3) * 2 * np.pi / 3)
    per = np.stack([ia, ib, ic], axis=-1) * k
    return per, per.sum(axis=-1)


@dataclass
class Sweep:
    """One electrical cycle of one motor: breakpoint positions (where any code may change), the
    codes held from each breakpoint to the next, and a fine grid for the motor model."""
    pos: np.ndarray        # breakpoint positions, counts (frame inputs)
    seg_start: np.ndarray  # electrical angle (rad) of each breakpoint; last entry 2pi closes


def sweep_positions(cfg: CommutationConfig, offset: int = 0) -> Sweep:
    """Positions over one electrical cycle at which a channel's code can change: every angle-code
    edge and every six-step sector edge (the RTL reads the position through nothing else)."""
    cb, ab = cfg.count_bits, cfg.angle_bits
    span = (1 << cb) // cfg.pole_pairs              # counts per electrical cycle (power of 2)
    step = span >> ab                               # counts per angle code
    off_counts = offset * step
    code_edges = np.arange(cfg.codes) * step
    # sector edges D_j on u_a = pos*PP + offset*2**(CB-AB): first pos with u_a >= D_j
    u_off = offset << (cb - ab)
    d = (sector_edges(cfg) - u_off) % (1 << cb)
    six_edges = -(-d // cfg.pole_pairs)
    pts = np.unique(np.concatenate([(code_edges - off_counts) % span, six_edges % span]))
    theta = 2 * np.pi * (pts.astype(np.float64) * cfg.pole_pairs / (1 << cb) + offset / cfg.codes)
    return Sweep(pts.astype(np.int64), np.append(theta, 2 * np.pi + theta[0]))


def torque_curve(codes_a: np.ndarray, codes_b: np.ndarray, sweep: Sweep, cfg: CommutationConfig,
                 sub: int = 8) -> dict[str, np.ndarray]:
    """Motor torque over the cycle from per-breakpoint codes (held until the next breakpoint),
    evaluated at `sub` points per segment including both ends (the extremes of a segment with
    constant currents and sinusoidal windings lie at its ends or inside: sub resolves them)."""
    a0, a1 = sweep.seg_start[:-1], sweep.seg_start[1:]
    frac = np.linspace(0.0, 1.0, sub)
    theta = (a0[:, None] + (a1 - a0)[:, None] * frac[None, :]).ravel()
    ia = np.repeat(np.asarray(codes_a, np.float64) / cfg.max_code, sub)
    ib = np.repeat(np.asarray(codes_b, np.float64) / cfg.max_code, sub)
    per, tot = motor_torque(ia, ib, theta)
    w = np.repeat((a1 - a0) / (2 * np.pi), sub) / sub   # segment weights for the mean
    return {"theta": theta, "ia": ia, "ib": ib, "ic": -(ia + ib), "per": per, "total": tot,
            "mean": np.array(float(np.sum(tot * w))),
            "ripple": np.array(float((tot.max() - tot.min()) / tot.max()))}


SIX_STEP_RIPPLE = 1 - np.cos(np.pi / 6)       # 13.40 %
SIX_STEP_MEAN = 3 * np.sqrt(3) / np.pi        # 1.654
SINE_MEAN = 1.5
SINE_RIPPLE_BUDGET = 0.003                    # 0.3 % peak-to-peak (the target)


def sweep_frames(cfg: CommutationConfig, mode: int, offset: int = 0,
                 torque: int = TORQUE_FULL) -> tuple[Sweep, Frames]:
    """Frames that drive motor 0 (and, for the same cost, motors 1 and 2) over one cycle."""
    sw = sweep_positions(cfg, offset)
    pos = np.repeat(sw.pos[:, None], 3, axis=1)
    return sw, Frames.make(pos, torque, offset=offset, mode=mode)


def figures(cfg: CommutationConfig, codes_by_mode: Mapping[int, np.ndarray],
            sweeps: Mapping[int, Sweep]) -> dict[str, float]:
    """The paper's numbers from per-breakpoint codes of SINE and SIX_STEP (motor 0's channels)."""
    out: dict[str, float] = {}
    for mode, name in ((SINE, "sine"), (SIX_STEP, "six_step")):
        c = codes_by_mode[mode]
        r = torque_curve(c[:, 0], c[:, 1], sweeps[mode], cfg)
        out[f"{name}_ripple"] = float(r["ripple"])
        out[f"{name}_mean"] = float(r["mean"])
    out["mean_ratio"] = out["sine_mean"] / out["six_step_mean"]
    return out


def plot_figures(cfg: CommutationConfig, codes_by_mode: Mapping[int, np.ndarray],
                 sweeps: Mapping[int, Sweep], name: str = "commutation") -> list[str]:
    """Plots in the style of the paper's Figs. 8 (six-step) and 9 (sine): channel currents with
    the winding torque profiles (left), per-phase torques and their sum (right)."""
    plt = pyplot()
    paths = []
    for mode, title, fig_no in ((SIX_STEP, "six-step (Hall-sector) commutation", 8),
                                (SINE, "sinusoidal commutation", 9)):
        c = codes_by_mode[mode]
        r = torque_curve(c[:, 0], c[:, 1], sweeps[mode], cfg)
        deg = np.degrees(r["theta"])
        fig, ax = plt.subplots(2, 2, figsize=(11, 6), sharex=True)
        for j, (lab, cur) in enumerate((("a", r["ia"]), ("b", r["ib"]), ("c = -(a+b)", r["ic"]))):
            ax[0, 0].plot(deg, cur + 2.5 * (1 - j), label=f"i_{lab}")
            ax[1, 0].plot(deg, cur, lw=1.2, label=f"i_{lab}")
            ax[1, 0].plot(deg, np.sin(r["theta"] - j * 2 * np.pi / 3), "k:", lw=0.7)
            ax[0, 1].plot(deg, r["per"][:, j], label=f"phase {lab[0]}")
        ax[0, 0].set_title("amplifier channel currents (offset for clarity)")
        ax[1, 0].set_title("phase currents over the winding torque profiles (dotted)")
        ax[0, 1].set_title("per-phase torque")
        ax[1, 1].plot(deg, r["total"], "k")
        ax[1, 1].set_ylim(0, 2)
        ax[1, 1].set_title(f"sum: mean {float(r['mean']):.4f}, ripple "
                           f"{100 * float(r['ripple']):.3f} % (max-min)/max")
        for a in ax.ravel():
            a.grid(alpha=0.3)
        for a in ax[1]:
            a.set_xlabel("electrical angle [deg]")
        ax[0, 1].legend(fontsize=7)
        fig.suptitle(f"{title} from the RTL's DAC codes through the motor model "
                     f"(cf. paper Fig. {fig_no})")
        fig.tight_layout()
        p = figure_path(f"{name}_fig{fig_no}_{'six_step' if mode == SIX_STEP else 'sine'}.png")
        save_figure(fig, p, dpi=100)
        plt.close(fig)
        paths.append(str(p))
    return paths
