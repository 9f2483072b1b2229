"""Cycle-exact behavioural model of the register file (rtl/bus/hg_regfile.v) built on the RDL.

The generic part comes from the register map (`hapgate.golden.regmap`, compiled from the RDL
by `hapgate.flows.regmap`): which
fields exist at which word address, their reset values, and what a software access does (read
only, write only and reads 0, read-write, write-1-to-clear, single pulse, range-checked writes
refused). The hapgate-specific hardware behaviour is written out here:

- servo tick: every TICK_DIV clocks exactly; the first one TICK_DIV clocks after reset or after
  the accepted TICK_DIV write; at a tick the snapshot of all axes is latched, SEQ increments and
  IRQ.TICK is set (IRQ.MISSED too if TICK was still pending; a tick beats a same-clock ack);
- CTRL.SNAP: the snapshot is latched one clock after the write (one SEQ increment if a tick falls
  on the same clock);
- watchdog: restarted by the key or CTRL.FAULT_CLR; expires WDOG_TIMEOUT * CLK_HZ/1e6 clocks after
  the restarting clock; STATUS.WDOG is sticky until CTRL.FAULT_CLR;
- STATUS.CFG_ERR one clock after a refused write; BUS_ERR at an unmapped access; PROTO_ERR at a
  dropped access; all three cleared by CTRL.FAULT_CLR;
- VEL reads floor(v * SAMPLE_HZ / 2**VEL_LOG2W) of the snapshot's window difference v, or of the
  observer's velocity when the FPGA has the observer (`vel_obs`) and bit i of VEL_CTRL.SEL was
  set before the snapshot's edge (`vel_sel_reset`: SEL resets to 7, hapgate_top VEL_OBS_SEL);
- harmonic table (`harm`, hapgate_top HARM = 1; otherwise HARM_CTRL/HARM_ADDR/HARM_DATA read 0
  and ignore writes): a HARM_DATA write stores its low byte into entry ADDR mod 2**harm_log2 of
  axis AXIS's table (AXIS = 3: none); every HARM_DATA access, read or write, then increments
  ADDR (mod 256) at its commit edge; a read returns that entry (0 for AXIS = 3); HARM_CTRL.LOG2
  reads harm_log2. The tables are block RAM, not reset: an entry never written reads as
  unknown in the hardware (here: 0);
- capture buffer (`capture`, a `hapgate.golden.capture.CaptureModel`, hapgate_top CAPTURE = 1;
  without it CAP_CTRL/CAP_STAT/CAP_ADDR/CAP_DATA read 0 and ignore writes): CAP_CTRL and
  CAP_ADDR writes and CAP_DATA reads go to it at their commit edge; CAP_STAT and CAP_DATA read
  its state as the bus samples it.

Time is counted in clock edges (integers). Every register updates at an edge from the values
before it. `access(word, we, wdata, edge)` applies an access that the bus slave committed at
`edge`; a read returns the value the slave sampled one edge earlier, i.e. the state after every
edge up to `edge - 2`. The interpolator outputs come from `inputs(edge)`, the values the hardware
sees at that edge.
"""

from __future__ import annotations

import bisect
from collections.abc import Callable
from dataclasses import dataclass, field

from .capture import CaptureModel
from .regmap import Register, RegMap

WDOG_KEY = 0x5AFEC0DE
NEVER = 1 << 62


@dataclass
class AxisInputs:
    """Live interpolator outputs of one axis (what the register file's inputs carry)."""
    pos: int = 0
    pos_homed: int = 0
    vel: int = 0             # counts per 2**VEL_LOG2W samples (signed)
    vel_obs: int = 0         # the tracking observer's velocity, same unit (VEL_OBS = 1)
    index_pos: int = 0
    index_count: int = 0
    overspeed_count: int = 0
    homed: int = 0
    faults: int = 0          # 3 bits
    # live calibration state (enc_calib), read directly (not part of the snapshot)
    cal_ofs_a: int = 0
    cal_ofs_b: int = 0
    cal_gain_a: int = 0x4000
    cal_gain_b: int = 0x4000
    cal_phase: int = 0
    cal_gear: int = 0
    cal_updates: int = 0

    @property
    def fault(self) -> int:
        return int(self.faults != 0)


Inputs = Callable[[int], list[AxisInputs]]


def _zero_inputs(_: int) -> list[AxisInputs]:
    return [AxisInputs() for _ in range(3)]


@dataclass
class RegModel:
    rm: RegMap
    reset_edge: int = 0                  # the last edge that sampled rst high
    sample_hz: int = 1_000_000
    vel_log2w: int = 8
    vel_obs: bool = False                # the interpolator has the observer (VEL_OBS = 1)
    vel_sel_reset: bool = False          # VEL_CTRL.SEL resets to 7 (hapgate_top VEL_OBS_SEL)
    harm: bool = False                   # the interpolator has the harmonic table (HARM = 1)
    harm_log2: int = 6                   # its entries per line, log2 (HARM_LOG2)
    capture: CaptureModel | None = None  # the capture buffer (CAPTURE = 1)
    sec: int = 0                         # integrity checks built (SEC_*: HW_FAULT.BUILT)
    inputs: Inputs = _zero_inputs
    input_edges: list[int] = field(default_factory=list)  # sorted edges where inputs(e) changes
    # state
    stored: dict[str, int] = field(default_factory=dict)   # software-visible storage per register
    snap: list[AxisInputs] = field(default_factory=list)
    seq: int = 0
    wd_expired: bool = False
    wd_expiry: int = NEVER               # edge at which the watchdog expires
    next_tick: int = NEVER
    snap_at: int = NEVER                 # pending CTRL.SNAP
    cfg_err_at: int = NEVER              # pending STATUS.CFG_ERR
    sticky: dict[str, bool] = field(default_factory=dict)
    index_seen: list[bool] = field(default_factory=lambda: [False] * 3)
    done: int = 0                        # every edge <= done has been applied
    ticks: list[int] = field(default_factory=list)       # edges of every tick (for checks)
    expiries: list[int] = field(default_factory=list)
    pulses: list[tuple[int, str, int]] = field(default_factory=list)  # (edge, field, bits)
    harm_tables: list[list[int]] = field(default_factory=list)  # per axis, 8-bit entries

    def __post_init__(self) -> None:
        self.regs = self.rm.by_name()
        self.words = self.rm.by_word()
        self.clk_hz = int(self.rm.params["CLK_HZ"])
        self.clk_per_us = self.clk_hz // 1_000_000
        if not self.harm_tables:   # block RAM: kept through a reset
            self.harm_tables = [[0] * (1 << self.harm_log2) for _ in range(3)]
        self.reset(self.reset_edge)

    # ------------------------------------------------------------------ state
    def reset(self, edge: int) -> None:
        self.stored = {r.name: r.reset for r in self.rm.registers}
        if self.vel_sel_reset:
            self.stored["VEL_CTRL"] |= self.regs["VEL_CTRL"].field("SEL").mask
        self.snap = [AxisInputs() for _ in range(3)]
        self.seq = 0
        self.sticky = {"CFG_ERR": False, "BUS_ERR": False, "PROTO_ERR": False}
        self.index_seen = [False] * 3
        self.wd_expired = False
        self.wd_expiry = edge + self._field("WDOG_TIMEOUT", "US") * self.clk_per_us
        self.next_tick = edge + self._field("TICK_DIV", "DIV")
        self.snap_at = self.cfg_err_at = NEVER
        self.done = edge
        self.reset_edge = edge
        if self.capture is not None:
            self.capture.reset(edge, edge)

    def _field(self, reg: str, name: str) -> int:
        f = self.regs[reg].field(name)
        return (self.stored[reg] & f.mask) >> f.lsb

    # ------------------------------------------------------------------ internal events
    def _next_internal(self) -> int:
        nxt = min(self.next_tick, self.snap_at, self.cfg_err_at)
        k = bisect.bisect_right(self.input_edges, self.done)
        if k < len(self.input_edges):   # (the sticky STATUS.INDEX follows the inputs)
            nxt = min(nxt, self.input_edges[k])
        if not self.wd_expired:
            nxt = min(nxt, self.wd_expiry)
        return nxt

    def _edge(self, e: int, write: tuple[Register, int] | None = None,
              access_word: int | None = None, proto: bool = False) -> None:
        """Apply everything that happens at edge e (all from the values before e)."""
        timeout_pre = self._field("WDOG_TIMEOUT", "US")
        sel_pre = [self.vel_obs and (self._field("VEL_CTRL", "SEL") >> i) & 1 == 1
                   for i in range(3)]
        ins = self.inputs(e)
        for i in range(3):  # index seen: sticky on a non-zero index count
            if ins[i].index_count != 0:
                self.index_seen[i] = True
        tick = e == self.next_tick
        snap = tick or e == self.snap_at
        irq_pre = self.stored["IRQ"]
        ack = 0
        fault_clr = pet = False
        tick_div_ok = False
        if write is not None:
            reg, data = write
            ack, fault_clr, pet, tick_div_ok = self._write(reg, data, e)
        # IRQ: a tick beats a same-clock acknowledge
        t_pre, m_pre = irq_pre & 1, (irq_pre >> 1) & 1
        t_new = 1 if tick else (t_pre & ~ack & 1)
        m_new = 1 if (tick and t_pre) else (m_pre & ~(ack >> 1) & 1)
        self.stored["IRQ"] = t_new | (m_new << 1)
        if tick:
            self.ticks.append(e)
        if tick or tick_div_ok:
            self.next_tick = e + self._field("TICK_DIV", "DIV")
        if snap:
            self.snap = [AxisInputs(**vars(a)) for a in ins]
            for i in range(3):
                if sel_pre[i]:
                    self.snap[i].vel = self.snap[i].vel_obs
            self.seq = (self.seq + 1) & 0xFFFFFFFF
        if e == self.snap_at:
            self.snap_at = NEVER
        # status stickies
        cfg_set = e == self.cfg_err_at
        if cfg_set:
            self.cfg_err_at = NEVER
        self.sticky["CFG_ERR"] = cfg_set or (self.sticky["CFG_ERR"] and not fault_clr)
        bus = access_word is not None and access_word not in self.words
        self.sticky["BUS_ERR"] = bus or (self.sticky["BUS_ERR"] and not fault_clr)
        self.sticky["PROTO_ERR"] = proto or (self.sticky["PROTO_ERR"] and not fault_clr)
        # watchdog: a restart beats an expiry on the same edge
        if pet or fault_clr:  # a key restarts the count; only FAULT_CLR clears the flag
            if fault_clr:
                self.wd_expired = False
            self.wd_expiry = e + timeout_pre * self.clk_per_us
        elif not self.wd_expired and e == self.wd_expiry:
            self.wd_expired = True
            self.expiries.append(e)
        self.done = e

    def _write(self, reg: Register, data: int, e: int) -> tuple[int, bool, bool, bool]:
        """Generic RDL write semantics; returns (IRQ ack bits, fault clear, pet, tick_div ok)."""
        value = self.stored[reg.name]
        ack = 0
        fault_clr = pet = tick_ok = False
        if reg.name.startswith("CAP_"):
            if self.capture is not None and reg.name == "CAP_CTRL":
                self.capture.ctrl_write(e, data)
            elif self.capture is not None and reg.name == "CAP_ADDR":
                self.capture.addr_write(data)
            return ack, fault_clr, pet, tick_ok
        if reg.name.startswith("HARM_"):
            if self.harm and reg.name == "HARM_DATA":
                addr, axis = self._field("HARM_ADDR", "ADDR"), self._field("HARM_ADDR", "AXIS")
                if axis < 3:
                    self.harm_tables[axis][addr % (1 << self.harm_log2)] = data & 0xFF
                self._harm_step()
                return ack, fault_clr, pet, tick_ok
            if not self.harm:      # no harmonic stage: the registers ignore writes
                return ack, fault_clr, pet, tick_ok
        for f in reg.fields:
            if "w" not in f.sw:
                continue
            bits = (data & f.mask) >> f.lsb
            if f.singlepulse:
                if bits:
                    self.pulses.append((e, f"{reg.name}.{f.name}", bits))
                    if f.name == "FAULT_CLR":
                        fault_clr = True
                    elif f.name == "SNAP":
                        self.snap_at = e + 1
            elif f.woclr:
                if reg.name == "IRQ":
                    ack |= bits << f.lsb
                else:
                    value &= ~(bits << f.lsb)
            elif f.sw == "w":      # write-only command field (the watchdog key)
                if reg.name == "WDOG" and data == WDOG_KEY:
                    pet = True
            elif f.range_min is not None or f.range_max is not None:
                lo = f.range_min if f.range_min is not None else 0
                hi = f.range_max if f.range_max is not None else (1 << 32) - 1
                if lo <= data <= hi:   # the whole written word must be in range
                    value = (value & ~f.mask) | (bits << f.lsb)
                    tick_ok = tick_ok or reg.name == "TICK_DIV"
                else:
                    self.cfg_err_at = e + 1
            else:
                value = (value & ~f.mask) | (bits << f.lsb)
        self.stored[reg.name] = value
        return ack, fault_clr, pet, tick_ok

    def run_to(self, edge: int) -> None:
        """Apply every internal event at edges <= edge."""
        while True:
            nxt = self._next_internal()
            if nxt > edge:
                break
            self._edge(nxt)
        self.done = max(self.done, edge)

    # ------------------------------------------------------------------ accesses
    def access(self, word: int, we: bool, wdata: int, edge: int) -> int | None:
        """A committed access at `edge`; returns the read value (None for a write)."""
        if edge <= self.done:
            raise ValueError(f"access at edge {edge} but the model is already at {self.done}")
        self.run_to(edge - 2)
        value = None if we else self.read(word)
        self.run_to(edge - 1)
        reg = self.words.get(word)
        self._edge(edge, write=(reg, wdata) if (we and reg is not None) else None,
                   access_word=word)
        if not we and self.harm and reg is not None and reg.name == "HARM_DATA":
            self._harm_step()      # a read increments the address too (at its commit edge)
        if not we and self.capture is not None and reg is not None and reg.name == "CAP_DATA":
            self.capture.data_read()
        return value

    def _harm_step(self) -> None:
        f = self.regs["HARM_ADDR"].field("ADDR")
        addr = (self._field("HARM_ADDR", "ADDR") + 1) & 0xFF
        self.stored["HARM_ADDR"] = (self.stored["HARM_ADDR"] & ~f.mask) | (addr << f.lsb)

    def proto_error(self, edge: int) -> None:
        self.run_to(edge - 1)
        self._edge(edge, proto=True)

    # ------------------------------------------------------------------ reads
    def read(self, word: int) -> int:
        reg = self.words.get(word)
        if reg is None:
            return self.rm.unmapped_read
        if reg.name.startswith("HARM_") and not self.harm:
            return 0
        if reg.name.startswith("CAP_"):
            if self.capture is None:
                return 0
            return self.capture.read(word - self.regs["CAP_CTRL"].word, self.done)
        if reg.name == "HARM_DATA":
            axis = self._field("HARM_ADDR", "AXIS")
            addr = self._field("HARM_ADDR", "ADDR") % (1 << self.harm_log2)
            return self.harm_tables[axis][addr] if axis < 3 else 0
        value = 0
        for f in reg.fields:
            if f.sw == "w":
                v = 0
            elif "w" in f.sw:          # software storage (RW, W1C)
                v = (self.stored[reg.name] & f.mask) >> f.lsb
            elif f.hw == "na":         # constant
                v = f.reset
            else:                      # hardware-driven read-only field
                v = self._hw_value(reg.name, f.name)
            value |= (v & ((1 << f.width) - 1)) << f.lsb
        return value

    def _hw_value(self, reg: str, name: str) -> int:
        if reg == "SEQ":
            return self.seq
        if reg == "HARM_CTRL":     # LOG2: the build's table size
            return self.harm_log2 if self.harm else 0
        if reg == "HW_FAULT":      # a fault-free design raises no alarm; BUILT: the build's
            return self.sec if name == "BUILT" else 0
        if reg == "STATUS":
            if name == "HW_FAULT":
                return 0
            ins = self.inputs(self.done + 1)
            if name == "FAULT":
                return sum(a.fault << i for i, a in enumerate(ins))
            if name == "HOMED":
                return sum((a.homed & 1) << i for i, a in enumerate(ins))
            if name == "INDEX":
                now = self.inputs(self.done)   # (set from the inputs at every edge <= done)
                return sum(int(s or now[i].index_count != 0) << i
                           for i, s in enumerate(self.index_seen))
            if name == "WDOG":
                return int(self.wd_expired)
            return int(self.sticky[name])
        if reg.startswith("AXIS[") and ".CAL_" in reg:   # live, like STATUS
            live = self.inputs(self.done + 1)[int(reg[5])]
            return int(getattr(live, "cal_" + name.lower()))
        if reg.startswith("AXIS["):
            a = self.snap[int(reg[5])]
            sub = reg.split(".")[1]
            if sub == "VEL":
                return ((a.vel * self.sample_hz) >> self.vel_log2w) & 0xFFFFFFFF
            if sub == "COUNTS":
                return a.overspeed_count if name == "OVERSPEED" else a.index_count
            if sub == "FLAGS":
                return a.faults if name == "FAULTS" else a.homed
            return {"POS": a.pos, "IDX_POS": a.index_pos, "POS_HOMED": a.pos_homed}[sub]
        raise KeyError(f"no hardware value for {reg}.{name}")
