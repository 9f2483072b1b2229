"""Sin/cos encoder interpolator: the bit-exact integer model of rtl/interp/enc_interp.v.

Everything is vectorised over whole sample arrays (no per-sample Python loop): the quadrant
counter is a cumulative sum, sticky flags and homing are forward-filled event indices.

Algorithm (one axis, per ADC sample a, b: 8-bit two's complement, A = R sin(phi), B = R cos(phi)):

1. Quadrant from the sign bits: sa = a < 0, sb = b < 0, q = 2*sa + (sa xor sb)
   (q0: phi in [0, 90deg), q1: [90, 180), q2: [180, 270), q3: [270, 360)). A zero code keeps
   the channel's previous sign bit (a +-1/2 LSB hysteresis; see `sign_bits`).
2. In the quadrant the two magnitudes play y = sin(theta) and x = cos(theta) of the local angle
   theta = phi - 90deg*q: even q: y = |a|, x = |b|; odd q: y = |b|, x = |a|. |-128| = 128.
3. Half-quadrant h = (y >= x). The smaller channel m = h ? x : y addresses the arcsine table
   T[m] = min(2^L - 1, round(asin(min(m, R_NOM)/R_NOM) * 2^L / 45deg)), m = 0..128 (L = lut_bits,
   7 by default: 128 codes per 45deg). Fine angle f = h ? 2^(L+1) - T[m] : T[m], in 0..2^(L+1)
   (f = 2^(L+1) is the next quadrant's start: the mirror is 256 - T, not 255 - T).
4. Quadrant counter qc (32 - (L+1) bits, wraps): at the first sample qc = q; then
   dq = (q - q_prev) mod 4: 1 -> +1, 3 -> -1, 0 -> 0, 2 -> overspeed: the counter moves +2 or -2
   in the direction of the last single step (+2 before any step), so its low two bits stay equal
   to the sign-bit quadrant; the overspeed flag is set and counted (the position is suspect).
5. Position pos = (qc << (L+1)) + f, a 32-bit register (wraps mod 2^32, read as signed).
   Counts per line 2^(L+3) = 1024; 2^20 counts per revolution of a 1024-line encoder.
6. Index: on a rising edge of the index bit between two samples (the bit is taken as high before
   the first sample, so an index already high at start is not an edge) the nearest line start,
   ((qc + 2) & ~3) << (L+1), is latched and the index counter (16 bits, wraps) increments. The
   index is high in quadrant 0 of line 0, so its edge marks that line's start; at the edge the
   decoder may still show the neighbouring quadrant (q3 entering forwards, q1 backwards: the
   channel crossing zero reads 0 and holds its sign), and rounding qc to a multiple of 4 gives
   the same line start whichever way the index is entered. Homing: after an arm, the first
   index edge makes that latch the home; pos_homed = pos - home (mod 2^32); the raw pos never jumps.
7. Velocity: a window difference over W = 2^vel_log2w samples,
   vel[n] = pos[n] - pos[n - W] (0 for n < W), in counts per W samples. A FIR: exactly 0 at
   standstill without noise, no limit cycle, no overflow (|vel| <= 3 * 2^(L+1) * W < 2^(DW-1)
   with DW = L + vel_log2w + 4 stored bits).
8. Faults, sticky until a clear: bit 0 overspeed (a two-quadrant step), bit 1 clipping
   (a or b at -128 or +127), bit 2 signal loss (a^2 + b^2 outside [amp_min^2, amp_max^2] for
   loss_samples consecutive samples). A clear applies before its sample is evaluated.
   Control events (clear, arm) apply to the first sample captured at or after the pulse.
9. Direction invert (cfg.invert, RTL INVERT): A and B are swapped at capture, i.e. the angle
   90deg - phi: the count runs the other way and quadrant 0 (the index quadrant) maps onto itself.
10. Plain quadrature (cfg.coarse, RTL COARSE): the fine angle f is zeroed, so pos counts whole
   quadrants (4096 steps per revolution, in the same 2^20 counts/rev units): the paper's
   interpolator with its interpolation dropped, for comparisons (the Z-width sweep).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..base.block import Block, Params
from ..base.tables import write_hex
from .angle import HARM_FRAC, harm_correct, ratio_fine, ratio_table
from .enccal import CalConfig, CalState, calibrate
from .interpcfg import Decoder, cal_table, decode
from .interpcfg import InterpConfig as InterpConfig
from .interpcfg import asin_table as asin_table
from .interpcfg import sign_bits as sign_bits

FAULT_OVERSPEED = 1
FAULT_CLIP = 2
FAULT_LOSS = 4


BOARD_CLK_HZ = 48_000_000   # a board-like clock (iCE40 UP5K class)
MIN_CLK_HZ = 1_000_000      # the lowest clock: one clock per 1 MSPS sample


def interp3_params(cfg: InterpConfig | None = None, clk_hz: int = BOARD_CLK_HZ,
                   sample_hz: int = 1_000_000, axes: int = 3) -> Params:
    """Parameters of rtl/interp/enc_interp3.v (the three-axis top with the sample strobe);
    `cfg.invert` applies to every axis."""
    cfg = cfg or InterpConfig()
    per_axis = {k: v for k, v in cfg.rtl_params().items() if k != "INVERT"}
    mask = (1 << axes) - 1 if cfg.invert else 0
    return {"CLK_HZ": clk_hz, "SAMPLE_HZ": sample_hz, "AXES": axes, **per_axis,
            "INVERT_MASK": mask}


def blocks() -> list[Block]:
    srcs = ("interp/enc_calib.v", "interp/ratio_div.v", "interp/vel_observer.v",
            "interp/enc_interp.v")
    return [
        # the generic-gate syntheses of enc_interp and enc_interp3 (13 s each, 14k and 43k
        # cells) only count cells: `make lint` proves them synthesizable for the iCE40, and
        # `hapgate synth` keeps the generic counts in its table
        Block(name="enc_interp", top="enc_interp", sources=srcs,
              params=lambda: InterpConfig().rtl_params(),
              lint_synth=("ice40",), synth_only=("generic",),
              doc="one axis of the sin/cos interpolator"),
        Block(name="enc_interp_cal", top="enc_interp", sources=srcs,
              params=lambda: InterpConfig(cal=True).rtl_params(),
              # (the generic-gate synthesis of the update's barrel shifters takes minutes)
              lint_synth=("ice40",),
              doc="one axis with the online calibration stage (CAL = 1, rtl/interp/enc_calib.v)"),
        Block(name="enc_interp_ratio", top="enc_interp", sources=srcs,
              params=lambda: InterpConfig(ratio=True, lut_bits=9, angle_reg=True,
                                          harm=True).rtl_params(),
              # Yosys (ice40, ~11 CPU-s) runs in `make bench` (bench_calib.angle_resources)
              lint_synth=(),
              doc="one axis with the ratio angle stage at 4096 counts per line "
                  "(ANGLE = 1, rtl/interp/ratio_div.v), the angle register (ANGLE_REG = 1) "
                  "and the harmonic correction table (HARM = 1)"),
        Block(name="enc_interp_areg", top="enc_interp", sources=srcs,
              params=lambda: InterpConfig(angle_reg=True).rtl_params(),
              lint_synth=(),   # the same code is synthesised in enc_interp_ratio
              doc="one axis, the paper's angle stage with its register stage (ANGLE_REG = 1)"),
        Block(name="enc_interp_obs", top="enc_interp", sources=srcs,
              params=lambda: InterpConfig(vel_obs=True).rtl_params(),
              # (Verilator and Icarus only: the observer's synthesis is the next block's)
              lint_synth=(),
              doc="one axis with the tracking velocity observer (VEL_OBS = 1, vel_observer.v)"),
        Block(name="vel_observer", top="vel_observer", sources=("interp/vel_observer.v",),
              # (its synth_ice40 costs 10-25 CPU-s: run by `make bench`, not `make lint`)
              params=lambda: {"VEL_LOG2W": 8}, lint_synth=(),
              doc="the tracking velocity observer alone (type II/III loop, one axis)"),
        Block(name="enc_interp3", top="enc_interp3",
              sources=srcs + ("interp/sample_strobe.v", "interp/enc_interp3.v"),
              params=interp3_params, lint_synth=("ice40",), synth_only=("generic",),
              doc="three interpolator axes with the ADC sample strobe"),
    ]


def write_lut(cfg: InterpConfig = InterpConfig(), directory: Path | None = None) -> Path:
    """Write the arcsine table file now (rtl_params() names it; the build writes it)."""
    return write_hex(cfg.lut_name, asin_table(cfg), cfg.lut_bits, directory)


def write_cal_lut(cfg: InterpConfig = InterpConfig(), directory: Path | None = None) -> Path:
    """The 512-entry arcsine table of the calibrated path (interpcfg.cal_table), written now."""
    return write_hex(cfg.cal_lut_name, cal_table(cfg), cfg.lut_bits, directory)


def quadrant_and_fine(a: np.ndarray, b: np.ndarray, table: np.ndarray, lut_bits: int,
                      ratio_bits: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Steps 1-3: sign-bit quadrant q (0..3) and fine angle f (0..2**(lut_bits+1)); with
    ratio_bits > 0 the fine angle of the ratio stage (hapgate.golden.angle, `table` its table)."""
    q, _, _, _, _ = decode(a, b)
    return q.astype(np.int32), fine_angle(a, b, q, table, lut_bits, ratio_bits)


def fine_angle(a: np.ndarray, b: np.ndarray, q: np.ndarray, table: np.ndarray, lut_bits: int,
               ratio_bits: int = 0) -> np.ndarray:
    """Step 3: the fine angle of samples a, b in their sign-bit quadrant q."""
    a = np.asarray(a, dtype=np.int16)
    b = np.asarray(b, dtype=np.int16)
    odd = (q & 1).astype(bool)
    ma, mb = np.abs(a), np.abs(b)
    y = np.where(odd, mb, ma)
    x = np.where(odd, ma, mb)
    half = y >= x
    if ratio_bits:
        f = ratio_fine(np.where(half, x, y), np.where(half, y, x), half, table, lut_bits,
                       ratio_bits)
        return f.astype(np.int32)
    t = table[np.minimum(np.where(half, x, y), table.size - 1)]  # (the calibrated table clamps)
    return np.where(half, (2 << lut_bits) - t, t).astype(np.int32)


def _last_true_index(mask: np.ndarray, before: bool = False) -> np.ndarray:
    """For each n, the largest i <= n (i < n if `before`) with mask[i]; -1 if none.

    Built with np.repeat over the event positions: one pass, fast for sparse and dense masks."""
    n = mask.size
    ev = np.flatnonzero(mask)
    starts = ev + 1 if before else ev
    keep = starts < n
    starts, ev = starts[keep], ev[keep]
    vals = np.concatenate(([-1], ev)).astype(np.int64)
    reps = np.diff(np.concatenate(([0], starts, [n])))
    return np.repeat(vals, reps)


def _event_mask(n: int, events: np.ndarray | list[int] | None) -> np.ndarray:
    m = np.zeros(n, dtype=bool)
    if events is not None and len(events):
        ev = np.asarray(events, dtype=np.int64)
        m[ev[(ev >= 0) & (ev < n)]] = True
    return m


def _sticky(event: np.ndarray, clear: np.ndarray) -> np.ndarray:
    """flag[n] = an event happened at some i <= n, at or after the last clear <= n."""
    if not event.any():
        return np.zeros(event.size, dtype=bool)
    if not clear.any():
        flag = np.zeros(event.size, dtype=bool)
        flag[np.argmax(event):] = True
        return flag
    last_ev = _last_true_index(event)
    return (last_ev >= 0) & (last_ev >= _last_true_index(clear))


@dataclass
class InterpOut:
    """Per-sample outputs of one axis (row n = the result of input sample n)."""
    pos: np.ndarray            # int32 position register
    pos_homed: np.ndarray      # int32, pos - home
    vel: np.ndarray            # int32, counts per W samples
    index_pos: np.ndarray      # int32, last index latch
    index_count: np.ndarray    # uint16-range int
    homed: np.ndarray          # bool
    faults: np.ndarray         # int, fault bits
    overspeed_count: np.ndarray  # 16-bit saturating count of overspeed steps
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    COLUMNS = ("pos", "pos_homed", "vel", "index_pos", "index_count", "homed", "faults",
               "overspeed_count")

    def as_matrix(self) -> np.ndarray:
        return np.stack([np.asarray(getattr(self, c), dtype=np.int64) for c in self.COLUMNS], 1)


@dataclass(frozen=True)
class InterpState:
    """Everything one axis carries from a chunk of samples to the next (`run_chunk`): the
    decoder (held sign bits, last quadrant and step direction, quadrant counter), the index
    latch and homing, the last 2^vel_log2w positions of the velocity window, the sticky faults,
    the signal-loss run, the overspeed count and the calibration's carry. `InterpState()` is the
    state after reset."""
    n: int = 0                                   # samples so far
    dec: Decoder = Decoder()
    idx_prev: bool = True                        # the index bit is taken as high before sample 0
    index_pos: int = 0
    index_count: int = 0
    last_rise: int = -1                          # sample numbers (absolute), -1: none yet
    last_arm: int = -1
    homed: bool = False
    home: int = 0
    hist: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int32))
    sticky: tuple[bool, bool, bool] = (False, False, False)   # overspeed, clip, loss
    last_good: int = -1                          # last sample inside the amplitude window
    ovs_count: int = 0
    cal: CalState | None = None


def _last_index(mask: np.ndarray, n0: int, before: int) -> np.ndarray:
    """Absolute sample number of the last True at or before each sample of a chunk starting at
    sample n0, or `before` (the carried value) where the chunk has none yet."""
    last = _last_true_index(mask)
    return np.where(last >= 0, last + n0, before)


def run(a: np.ndarray, b: np.ndarray, index: np.ndarray | None = None,
        cfg: InterpConfig = InterpConfig(), clear_at: list[int] | np.ndarray | None = None,
        arm_at: list[int] | np.ndarray | None = None,
        table: np.ndarray | None = None, cal_en: np.ndarray | bool = False,
        cal_freeze: np.ndarray | bool = False, cal_mu: np.ndarray | int = 6,
        harm_table: np.ndarray | None = None, harm_en: np.ndarray | bool = False) -> InterpOut:
    """Bit-exact model of one axis over a whole capture (arrays of equal length): `run_chunk`
    from the reset state."""
    return run_chunk(a, b, index, cfg, InterpState(), clear_at, arm_at, table, cal_en,
                     cal_freeze, cal_mu, harm_table, harm_en)[0]


def run_chunk(a: np.ndarray, b: np.ndarray, index: np.ndarray | None = None,
              cfg: InterpConfig = InterpConfig(), state: InterpState = InterpState(),
              clear_at: list[int] | np.ndarray | None = None,
              arm_at: list[int] | np.ndarray | None = None,
              table: np.ndarray | None = None, cal_en: np.ndarray | bool = False,
              cal_freeze: np.ndarray | bool = False, cal_mu: np.ndarray | int = 6,
              harm_table: np.ndarray | None = None, harm_en: np.ndarray | bool = False
              ) -> tuple[InterpOut, InterpState]:
    """Bit-exact model of one axis over a chunk of samples that follows `state` (the reset state
    for the first): (the chunk's outputs, the state after it). A capture cut anywhere into
    chunks, each run from the state the previous one returned, gives the outputs of the whole.
    clear_at / arm_at are sample numbers within the chunk.

    With cfg.cal the calibration stage (hapgate.golden.enccal) runs between capture and angle:
    cal_en, cal_freeze and cal_mu are its controls per sample (or constant); its corrected
    channels feed the quadrant and the 512-entry table, the faults still see the raw codes, and
    `extra` carries its state ("cal_state", "cal_gear", "cal_updates"). With cfg.harm (and
    cfg.ratio) the harmonic table harm_table (zeros if None) applies where harm_en is set
    (per sample or constant; hapgate.golden.angle)."""
    a = np.asarray(a)
    b = np.asarray(b)
    n = a.size
    n0 = state.n
    if b.size != n:
        raise ValueError("a and b differ in length")
    if n == 0:
        raise ValueError("no samples")
    idx = np.zeros(n, dtype=bool) if index is None else np.asarray(index).astype(bool)
    table_arg = table
    rb = cfg.ratio_bits if cfg.ratio else 0
    if cfg.harm and not cfg.ratio:
        raise ValueError("the harmonic correction needs the ratio angle stage")
    tl = cfg.lut_bits + (HARM_FRAC if cfg.ratio else 0)    # the angle table's codes per 45 deg
    if cfg.ratio and table is None:
        table = ratio_table(tl, cfg.ratio_bits)
        table_arg = table
    table = asin_table(cfg) if table is None else table
    fb = cfg.fine_bits
    if cfg.invert:
        a, b = b, a
    extra: dict[str, np.ndarray] = {}
    cal_carry: CalState | None = None
    if cfg.cal:
        c = calibrate(a, b, cal_en, cal_freeze, cal_mu, cfg,
                      CalConfig(cfg.cal_lines_log2, cfg.cal_nlog), state.cal)
        cal_carry = c.carry
        ctab = cal_table(cfg) if table_arg is None else table_arg
        q, _, overspeed, qc64, dec = decode(c.ac, c.bc, state.dec)
        f = fine_angle(c.ac, c.bc, q, ctab, tl, rb)
        extra = {"cal_state": c.state, "cal_state_after": c.state_after, "cal_gear": c.gear,
                 "cal_updates": c.updates,
                 "cal_ac": c.ac, "cal_bc": c.bc}
    else:
        q, _, overspeed, qc64, dec = decode(a, b, state.dec)
        f = fine_angle(a, b, q, table, tl, rb)
    q = q.astype(np.int32)
    if cfg.ratio:   # 1/4-count fine angle: the harmonic table (cfg.harm), rounded to counts
        ht = np.zeros(1 << cfg.harm_log2, dtype=np.int64) if harm_table is None else harm_table
        extra["fine_h"] = f
        en = np.broadcast_to(np.asarray(harm_en, dtype=bool) & cfg.harm, (n,))
        f = harm_correct(q, f, en, ht, cfg.lut_bits, cfg.harm_log2).astype(np.int32)
    if cfg.coarse:                                      # plain quadrature: no fine angle
        f = np.zeros_like(f)

    # 4. quadrant counter: a cumulative sum of steps; overspeed steps follow the last direction
    # (interpcfg.decode). The 32-bit register wraps: int32 arithmetic.
    qc = qc64.astype(np.int32)
    dec = replace(dec, qc=int(qc[-1]))
    pos = (qc << np.int32(fb)) + f.astype(np.int32)
    # index latch: the nearest line start (qc rounded to a multiple of 4), see step 6
    line_start = ((qc + np.int32(2)) & np.int32(~3)) << np.int32(fb)

    # 6. index latch and homing (sample numbers absolute: n0 + k)
    prev = np.concatenate(([state.idx_prev], idx[:-1]))
    rise = idx & ~prev
    arm = _event_mask(n, arm_at)
    k_abs = n0 + np.arange(n)
    last_rise = _last_index(rise, n0, state.last_rise)
    in_chunk = last_rise >= n0
    index_pos = np.where(in_chunk, line_start[np.maximum(last_rise - n0, 0)],
                         np.int32(state.index_pos))
    index_count = (state.index_count + np.cumsum(rise, dtype=np.int64)) & 0xFFFF
    last_arm = _last_index(arm, n0, state.last_arm)
    homed = (last_arm >= 0) & (last_rise >= last_arm)
    # the home is the first rise at or after each arm; it holds until the next homing edge
    home_edge = rise & homed & ~np.concatenate(([state.homed], homed[:-1]))
    home_edge |= rise & (last_arm == k_abs)             # arm and edge on the same sample
    last_home = _last_true_index(home_edge)
    home = np.where(last_home >= 0, line_start[np.maximum(last_home, 0)], np.int32(state.home))
    pos_homed = pos - home.astype(np.int32)

    # 7. velocity: window difference over W samples, in stored DW bits (sign-extended); the
    # window reaches back into the carried positions
    w = 1 << cfg.vel_log2w
    dw = cfg.vel_store_bits
    ext = np.concatenate((state.hist, pos))
    vel_ext = np.zeros(ext.size, dtype=np.int32)
    if ext.size > w:
        d = (ext[w:] - ext[:-w]) & np.int32((1 << dw) - 1)
        vel_ext[w:] = np.where(d >= 1 << (dw - 1), d - np.int32(1 << dw), d)
    vel = vel_ext[state.hist.size:]

    # 8. faults
    clear = _event_mask(n, clear_at)
    a16 = a.astype(np.int32)
    b16 = b.astype(np.int32)
    clip = (a16 == -128) | (a16 == 127) | (b16 == -128) | (b16 == 127)
    amp2 = a16 * a16 + b16 * b16
    bad = (amp2 < cfg.amp_min ** 2) | (amp2 > cfg.amp_max ** 2)
    last_good = _last_index(~bad, n0, state.last_good)
    loss = (k_abs - last_good) >= cfg.loss_samples
    not_cleared = ~np.logical_or.accumulate(clear)     # no clear yet in this chunk
    flags = [_sticky(ev, clear) | (carried & not_cleared)
             for ev, carried in zip((overspeed, clip, loss), state.sticky)]
    faults = flags[0] * FAULT_OVERSPEED + flags[1] * FAULT_CLIP + flags[2] * FAULT_LOSS
    ovs_count = np.minimum(state.ovs_count + np.cumsum(overspeed, dtype=np.int64), 0xFFFF)

    out = InterpOut(pos=pos, pos_homed=pos_homed, vel=vel,
                    index_pos=index_pos.astype(np.int32), index_count=index_count, homed=homed,
                    faults=faults.astype(np.int64), overspeed_count=ovs_count,
                    extra={"q": q, "fine": f, "qc": qc, **extra})
    nxt = InterpState(n=n0 + n, dec=dec, idx_prev=bool(idx[-1]), index_pos=int(index_pos[-1]),
                      index_count=int(index_count[-1]), last_rise=int(last_rise[-1]),
                      last_arm=int(last_arm[-1]), homed=bool(homed[-1]), home=int(home[-1]),
                      hist=ext[-w:].copy(), sticky=tuple(bool(fl[-1]) for fl in flags),
                      last_good=int(last_good[-1]), ovs_count=int(ovs_count[-1]),
                      cal=cal_carry)
    return out, nxt


# ----------------------------------------------------------------------------------------------
# Float truth and unit conversions


def truth_counts_error(pos: np.ndarray, truth_counts: np.ndarray) -> np.ndarray:
    """pos - truth in counts, with the 32-bit wrap of the position register undone against the
    (continuous) float truth. No offset is removed: that is the caller's decision."""
    p = np.asarray(pos, dtype=np.float64)
    t = np.asarray(truth_counts, dtype=np.float64)
    return p + np.round((t - p) / 2.0**32) * 2.0**32 - t


def counts_to_elec_deg(err_counts: np.ndarray, cfg: InterpConfig) -> np.ndarray:
    return np.asarray(err_counts) * 360.0 / cfg.counts_per_line


def counts_to_mech_deg(err_counts: np.ndarray, cfg: InterpConfig) -> np.ndarray:
    return np.asarray(err_counts) * 360.0 / cfg.counts_per_rev


def atan2_counts(a: np.ndarray, b: np.ndarray, cfg: InterpConfig) -> np.ndarray:
    """Float reference interpolator (the best a per-sample method can do): atan2 of the samples,
    in counts within the line, 0 <= c < counts_per_line."""
    phi = np.arctan2(np.asarray(a, float), np.asarray(b, float)) % (2 * np.pi)
    return phi * cfg.counts_per_line / (2 * np.pi)
