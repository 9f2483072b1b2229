"""The converters' datasheet timing and the FPGA side of it (rtl/top/README.md, "Converter
timing"): the parts of the paper's class, with each figure's source; the ADC sample clock's
plan at a given CLK_HZ, exactly as rtl/top/hapgate_top.v derives it (ADC_HI, ADC_Q, ADC_SU,
ADC_HO) and refuses it; and the judges a simulation applies to recorded pin edges (plain Python,
so a test can show that they fail on a wrong schedule).

Figures marked `stated` were not found in the offline library: they are conservative values
chosen here (larger delays, smaller holds than any part of the class plausibly has), and the
board is only as safe as they are. Check them against your part's datasheet before wiring.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

PS_PER_NS = 1000


@dataclass(frozen=True)
class AdcPart:
    name: str
    bits: int
    fmax_hz: int          # maximum conversion rate
    tpw_ns: int           # clock high and low, minimum
    tpw_max_ns: int       # clock high and low, maximum
    tod_ns: int           # output delay after a clock edge, maximum
    th_ns: int            # output hold after a clock edge, minimum
    latency_clocks: float  # pipeline latency, sampling edge to output
    sources: tuple[str, ...]

    @property
    def pipeline_samples(self) -> int:
        """Sample periods from the ADC clock cycle whose sample a capture holds to that
        capture: the word captured at strobe n is the conversion of cycle n - this (a cycle
        starts with the rise before its capture; the sample is taken at an edge of that cycle
        and comes out `latency_clocks` later, after the next rise or fall)."""
        return math.ceil(self.latency_clocks)


@dataclass(frozen=True)
class DacPart:
    name: str
    bits: int
    t_wr_ns: int          # write strobe (CS / WR) low, minimum
    t_su_fall_ns: int     # data and address valid before the strobe falls
    t_su_rise_ns: int     # data and address valid before the strobe rises (the latching edge)
    t_h_ns: int           # data and address valid after the strobe rises
    settle_us: float
    sources: tuple[str, ...]


@dataclass(frozen=True)
class IoBudget:
    """The FPGA and board between the ADC's pins and the capture register (stated, conservative:
    an iCE40 / ECP5 output register to pin, 10 cm of board, input pin to register)."""
    out_in_ns: int = 25   # adc_clk clock-to-pin (max) + board skew + data input setup
    in_hold_ns: int = 5   # data input hold (+ skew) after the capture edge


HI1175 = AdcPart(
    name="Intersil HI1175 (= Sony CXD1175)", bits=8, fmax_hz=20_000_000, tpw_ns=23,
    tpw_max_ns=1100, tod_ns=50, th_ns=0, latency_clocks=2.5,
    sources=(
        "Intersil HI1175 data sheet FN3577.8, October 25, 2005 (dtsheet.com/doc/1108449): 8-bit, "
        "20 MSPS maximum conversion speed (min), 2.5 clock cycle data latency, three-state "
        "outputs with OE, 'direct replacement for the Sony CXD1175'",
        "Sony CXD1175AM/AP data sheet E89321F78-PS (dtsheet.com/doc/314693), Recommended "
        "Operating Conditions: clock pulse width TPW1, TPW0 23 ns (min) to 1.1 us (max)",
        "t_OD max 50 ns and t_H min 0 ns: stated (the timing table was not in the offline "
        "library)",
    ))

DAC7625 = DacPart(
    name="TI (Burr-Brown) DAC7624/DAC7625", bits=12, t_wr_ns=50, t_su_fall_ns=0,
    t_su_rise_ns=50, t_h_ns=0, settle_us=10.0,
    sources=("DAC7624/7625 data sheet, Table II 'Timing Specifications', page 11: t_WCS CS low "
             "for write >= 50 ns, t_DS / t_AS data / address valid to CS low >= 0, t_DH / t_AH "
             ">= 0 after CS high (R/W tied low; LDAC tied low)",))

AD7836 = DacPart(
    name="Analog Devices AD7836 (quad 14-bit, parallel, bipolar outputs)", bits=14,
    t_wr_ns=100, t_su_fall_ns=0, t_su_rise_ns=100, t_h_ns=10, settle_us=10.0,
    sources=("the paper's DAC class (14-bit bipolar, 16 us settling); AD7836 named for it. Its "
             "timing table was not in the offline library: t_WR >= 100 ns, data / address "
             "valid >= 100 ns before and >= 10 ns after the latching (rising) edge of WR are "
             "stated, conservative (2x the 50 ns of the DAC7625 class); LDAC tied low",))

DAC_PARTS = {"dac7625": DAC7625, "ad7836": AD7836}


@dataclass(frozen=True)
class AdcPlan:
    """The ADC clock at one CLK_HZ (clocks), as hapgate_top.v derives it: `div` clocks per
    sample, `hi` high, rising `q` clocks before the core's capture edge. The board reads the
    pins `lead` clocks before the core's capture edge (and, with a lead: the HX8K pair adapter,
    also `s` clocks before that: the A words), each read `su` clocks after the clock's last
    edge and `ho` clocks before its next. With a lead both reads sit in the high phase."""
    clk_hz: int
    sample_hz: int
    lead: int
    div: int
    hi: int
    q: int
    su: int
    ho: int
    s: int
    m: int

    @property
    def lo(self) -> int:
        return self.div - self.hi


def adc_plan(clk_hz: int, sample_hz: int = 1_000_000, lead: int = 0) -> AdcPlan:
    div = clk_hz // sample_hz
    s = div - div // 2
    m = (div - s - 1) // 2
    if lead == 0:
        hi = div // 2
        q = hi // 2
        su, ho = q, hi - q
    else:
        hi = s + 2 * m
        q = lead + s + m
        su = ho = m
    return AdcPlan(clk_hz, sample_hz, lead, div, hi, q, su, ho, s, m)


def adc_refusals(plan: AdcPlan, part: AdcPart = HI1175, io: IoBudget = IoBudget()) -> list[str]:
    """Why hapgate_top.v refuses this clock (its g_adc_* checks, same integer arithmetic);
    empty: the clock is accepted."""
    khz = plan.clk_hz // 1000
    pw, pwx = min(plan.hi, plan.lo), max(plan.hi, plan.lo)
    out = []
    if plan.div < 2 or plan.div > 2000 or plan.lead < 0 or plan.lead > plan.m:
        out.append("needs 2 to 2000 clocks per sample (and a lead of at most m)")
    if plan.sample_hz > part.fmax_hz:
        out.append("sample rate above the ADC's maximum conversion rate")
    if pw < 1 or pw * 1_000_000 < part.tpw_ns * khz:
        out.append("clock high or low shorter than t_PW")
    if pwx * 1_000_000 > part.tpw_max_ns * khz:
        out.append("clock high or low longer than t_PW max")
    if plan.su < 1 or plan.su * 1_000_000 < (part.tod_ns + io.out_in_ns) * khz:
        out.append("capture earlier than t_OD + the IO budget after an edge")
    if plan.ho < 1 or plan.ho * 1_000_000 < (io.in_hold_ns - part.th_ns) * khz:
        out.append("capture too close to the next edge for the input hold")
    return out


@dataclass
class AdcVerdict:
    high_ps: tuple[int, int]       # min, max clock high
    low_ps: tuple[int, int]        # min, max clock low
    periods_ps: set[int]
    setup_ps: int                  # min over captures: capture - last clock edge
    hold_ps: int                   # min over captures: next clock edge - capture
    problems: list[str]


def _next_after(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    """For every t, the first x > t (-1 where none); x sorted."""
    i = np.searchsorted(x, t, side="right")
    out = np.full(t.shape, -1, dtype=np.int64)
    ok = i < x.size
    out[ok] = x[i[ok]]
    return out


def judge_adc(rises: list[int], falls: list[int], captures: list[int], period_ps: int,
              part: AdcPart = HI1175, io: IoBudget = IoBudget()) -> AdcVerdict:
    """The ADC clock and the pin captures (ps, simulation time) against the part: every high
    and low between t_PW and t_PW max, the period `period_ps` (the sample period in the
    simulation's clock; >= 1 / the maximum rate), and
    every capture at least t_OD + the IO budget after the last clock edge of either polarity
    (the outputs may change after either) and at least the input hold - t_H before the next.
    Captures outside the recorded clock and falls before its first rise (the clock leaving
    reset) are ignored; no capture at all is a problem."""
    r = np.asarray(sorted(rises), dtype=np.int64)
    f = np.asarray(sorted(falls), dtype=np.int64)
    f = f[f > r[0]] if r.size else f      # a fall before the first rise: the clock's reset
    fr, rf = _next_after(f, r), _next_after(r, f)
    highs, lows = (fr - r)[fr >= 0], (rf - f)[rf >= 0]
    periods = {int(p) for p in np.diff(r)}
    problems = []
    if not highs.size or not lows.size or not periods:
        return AdcVerdict((0, 0), (0, 0), periods, 0, 0, ["the ADC clock does not toggle"])
    lo_pw, hi_pw = part.tpw_ns * PS_PER_NS, part.tpw_max_ns * PS_PER_NS
    for name, w in (("high", highs), ("low", lows)):
        if w.min() < lo_pw or w.max() > hi_pw:
            problems.append(f"clock {name} {w.min()}..{w.max()} ps outside t_PW "
                            f"{lo_pw}..{hi_pw} ps")
    if periods != {period_ps} or period_ps < 10**12 // part.fmax_hz:
        problems.append(f"clock period {sorted(periods)} ps != {period_ps} ps (or above the "
                        f"maximum rate)")
    edges = np.sort(np.concatenate([r, f]))
    c = np.asarray(captures, dtype=np.int64)
    i = np.searchsorted(edges, c, side="left")          # edges[i - 1] < c <= edges[i]
    ok = (i > 0) & (i < edges.size)
    if not ok.any():
        problems.append("no capture inside the recorded clock")
        return AdcVerdict((int(highs.min()), int(highs.max())), (int(lows.min()),
                          int(lows.max())), periods, 0, 0, problems)
    su = int((c[ok] - edges[i[ok] - 1]).min())
    ho = int((edges[i[ok]] - c[ok]).min())
    need_su = (part.tod_ns + io.out_in_ns) * PS_PER_NS
    need_ho = (io.in_hold_ns - part.th_ns) * PS_PER_NS
    if su < need_su:
        problems.append(f"capture {su} ps after an ADC clock edge < t_OD + IO {need_su} ps")
    if ho < max(need_ho, 1):
        problems.append(f"capture {ho} ps before the next ADC clock edge < hold {need_ho} ps")
    return AdcVerdict((int(highs.min()), int(highs.max())), (int(lows.min()), int(lows.max())),
                      periods, su, ho, problems)


def adc_alignment_problems(rises: list[int], captures: list[int], codes: list[int | None],
                           part: AdcPart = HI1175, modulo: int = 16) -> list[str]:
    """The pipeline accounted for: capture m (m = 0, 1, ... from reset) must follow ADC clock
    rise m (the last rise before it), and hold the conversion of cycle m - L (L =
    part.pipeline_samples); `codes[m]` is what the pins showed at capture m, the ADC model
    encoding its cycle index mod `modulo` (None: not a valid word). The first L captures hold
    the converter's power-up output and are not checked."""
    lag = part.pipeline_samples
    c = np.asarray(captures, dtype=np.int64)
    m = np.arange(c.size)
    last = np.searchsorted(np.asarray(sorted(rises), dtype=np.int64), c, side="left") - 1
    got = np.array([-1 if v is None else v for v in codes], dtype=np.int64)
    out = [f"capture {k} follows ADC clock rise {last[k]}, not {k}"
           for k in np.flatnonzero(last != m)[:3]]
    bad = np.flatnonzero((m >= lag) & (got != (m - lag) % modulo))
    out += [f"capture {k} holds code {got[k]}, not cycle {k - lag} (= {(k - lag) % modulo} "
            f"mod {modulo})" for k in bad[:3]]
    return out


@dataclass
class DacVerdict:
    low_ps: int
    setup_fall_ps: int
    setup_rise_ps: int
    hold_ps: int
    changes_while_low: int
    problems: list[str]


def judge_dac(writes: list[tuple[int, int]], changes: list[int], part: DacPart,
              period_ps: int) -> DacVerdict:
    """DAC writes (strobe fall, rise; ps) and data or address changes (ps) against the part:
    strobe low >= t_WR, no change while low, data valid >= t_SU before the fall (and >= one
    clock: the port's own setup) and before the rise, and >= t_H (and >= one clock) after it."""
    if not writes:
        return DacVerdict(0, 0, 0, 0, 0, ["no DAC writes"])
    w = np.asarray(writes, dtype=np.int64)
    fall, rise = w[:, 0], w[:, 1]
    ch = np.asarray(sorted(changes) or [-(10**15)], dtype=np.int64)
    i = np.searchsorted(ch, fall, side="right") - 1               # last change <= fall
    prev = np.where(i >= 0, ch[np.maximum(i, 0)], -(10**15))
    j = np.searchsorted(ch, rise, side="left")                    # first change >= rise
    nxt = np.where(j < ch.size, ch[np.minimum(j, ch.size - 1)], 10**15)
    inside = int(np.count_nonzero(np.searchsorted(ch, rise, side="left")
                                  - np.searchsorted(ch, fall, side="right")))
    low, su_f = int((rise - fall).min()), int((fall - prev).min())
    su_r, hold = int((rise - prev).min()), int((nxt - rise).min())
    problems = []
    if low < part.t_wr_ns * PS_PER_NS:
        problems.append(f"strobe low {low} ps < t_WR {part.t_wr_ns} ns")
    if inside:
        problems.append(f"{inside} writes with a data/address change while the strobe was low")
    if su_f < max(part.t_su_fall_ns * PS_PER_NS, period_ps):
        problems.append(f"setup to the strobe's fall {su_f} ps")
    if su_r < part.t_su_rise_ns * PS_PER_NS:
        problems.append(f"setup to the latching edge {su_r} ps < {part.t_su_rise_ns} ns")
    if hold < max(part.t_h_ns * PS_PER_NS, period_ps):
        problems.append(f"hold {hold} ps < {part.t_h_ns} ns (or one clock)")
    return DacVerdict(low, su_f, su_r, hold, inside, problems)
