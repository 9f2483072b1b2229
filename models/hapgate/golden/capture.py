"""Golden model of the raw ADC capture buffer (rtl/capture/hg_capture.v): which ADC words land at
which buffer address for a given ADC stream, trigger and decimation, and the CAP_* registers
clock-exactly (what `hapgate.golden.regmodel` returns for them).

Conventions (docs/blocks/capture.md): edges are numbered as in the register model; a sample is
taken at the edge that ends its `adc_strobe` clock (its strobe edge). A CAP_CTRL write applied at
edge c stores the fields and ends the running capture (entries written at c and later are
cancelled); with ARM it starts a new one, which considers the strobes at edges > c. The trigger
sample is the first of them (TRIG = 0) or the first whose index is high and was low at the strobe
before (TRIG = 1; before the first strobe after a reset it counts as low). From the trigger on,
one sample in DECIM + 1 is recorded: entry m (SEL 0..2) or entries 3m..3m+2 (SEL = 3: axes 0, 1,
2) are written at the edges s+1 (.. s+3) after its strobe edge s, each {B, A} in 16 bits. COUNT
counts the entries written; at the last one (2**depth_log2, or 3 * floor(2**depth_log2 / 3))
DONE is set and the capture ends.

Vectorised over the samples with numpy: one capture (a session) is computed at once.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..base.block import Block, Params

NEVER = 1 << 62
SEL_ALL = 3
TRIG_ANY = 3


@dataclass(frozen=True)
class CapCtrl:
    """The fields of a CAP_CTRL write."""
    arm: bool = False
    sel: int = 0            # 0..2 one axis, 3 all three
    trig: int = 0           # 0 immediate, 1 index edge
    trig_axis: int = 0      # 0..2, 3 any
    decim: int = 0          # one sample in decim + 1

    @classmethod
    def decode(cls, word: int) -> CapCtrl:
        return cls(arm=bool(word & 1), sel=(word >> 4) & 3, trig=(word >> 6) & 1,
                   trig_axis=(word >> 8) & 3, decim=(word >> 16) & 0xFFFF)

    def encode(self) -> int:
        return (int(self.arm) | (self.sel << 4) | (self.trig << 6) | (self.trig_axis << 8)
                | (self.decim << 16))


def limit(depth_log2: int, sel: int) -> int:
    """Entries of a full capture."""
    depth = 1 << depth_log2
    return depth if sel != SEL_ALL else (depth // 3) * 3


def words(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The 16-bit entry {B, A} of every sample and axis: (n, 3) from (n, 3) signed ADC codes."""
    return ((np.asarray(b, np.int64) & 0xFF) << 8) | (np.asarray(a, np.int64) & 0xFF)


def rises(idx: np.ndarray, first_prev: np.ndarray | None = None) -> np.ndarray:
    """(n, 3) bool: the index is high at sample k and was low at sample k - 1 (low before 0)."""
    idx = np.asarray(idx, np.int64) != 0
    prev = np.vstack([np.zeros((1, 3), bool) if first_prev is None else first_prev[None, :],
                      idx[:-1]])
    return idx & ~prev


@dataclass
class Session:
    """One armed capture: its take and write schedule (before any cut)."""
    arm_edge: int
    ctrl: CapCtrl
    take_edges: np.ndarray       # strobe edges of the recorded samples
    w_edges: np.ndarray          # edge of each entry write, in address order
    w_data: np.ndarray           # its 16-bit word
    end: int = NEVER             # the first edge at which it was cut (writes >= end cancelled)

    def n_written(self, edge: int) -> int:
        """Entries written at edges <= edge."""
        return int(np.searchsorted(self.w_edges, min(edge, self.end - 1), side="right"))


def schedule(strobe_edges: np.ndarray, w: np.ndarray, rise: np.ndarray, arm_edge: int,
             ctrl: CapCtrl, depth_log2: int) -> Session:
    """The capture armed at `arm_edge` over samples with strobe edges `strobe_edges` (sorted),
    entries `w` (n, 3) and index rises `rise` (n, 3), if nothing cuts it."""
    k0 = int(np.searchsorted(strobe_edges, arm_edge, side="right"))
    if ctrl.trig == 0:
        trig = k0 if k0 < strobe_edges.size else None
    else:
        r = rise[k0:].any(axis=1) if ctrl.trig_axis == TRIG_ANY else rise[k0:, ctrl.trig_axis]
        hit = np.flatnonzero(r)
        trig = k0 + int(hit[0]) if hit.size else None
    per = 3 if ctrl.sel == SEL_ALL else 1
    ns = limit(depth_log2, ctrl.sel) // per
    if trig is None:
        ks = np.zeros(0, np.int64)
    else:
        ks = trig + np.arange(ns, dtype=np.int64) * (ctrl.decim + 1)
        ks = ks[ks < strobe_edges.size]
    takes = strobe_edges[ks]
    if ctrl.sel == SEL_ALL:
        w_edges = (takes[:, None] + np.arange(1, 4)[None, :]).ravel()
        w_data = w[ks].ravel()
    else:
        w_edges = takes + 1
        w_data = w[ks, ctrl.sel]
    return Session(arm_edge, ctrl, takes, w_edges.astype(np.int64), w_data.astype(np.int64))


def record(a: np.ndarray, b: np.ndarray, idx: np.ndarray, ctrl: CapCtrl,
           depth_log2: int = 10) -> np.ndarray:
    """The buffer contents (entries in address order) of a capture armed before sample 0 of the
    stream (a, b, idx: (n, 3) ADC codes and index bits), run to the end of the stream."""
    n = np.asarray(a).shape[0]
    s = schedule(np.arange(1, n + 1, dtype=np.int64), words(a, b), rises(idx), 0, ctrl,
                 depth_log2)
    return s.w_data


def unpack(entries: np.ndarray, sel: int) -> tuple[np.ndarray, np.ndarray]:
    """Signed A and B codes from captured entries: (m,) each for one axis, (m, 3) for SEL = 3."""
    e = np.asarray(entries, np.int64)
    if sel == SEL_ALL:
        e = e[: e.size // 3 * 3].reshape(-1, 3)
    a = (e & 0xFF).astype(np.int64)
    b = ((e >> 8) & 0xFF).astype(np.int64)
    return np.where(a >= 128, a - 256, a), np.where(b >= 128, b - 256, b)


@dataclass
class CaptureModel:
    """The CAP_* registers and the buffer RAM, clock-exact, for the register model.

    `strobe_edges` (sorted) are the strobe edges of the ADC samples `a`, `b`, `idx` ((n, 3)
    codes and index bits). Accesses come in time order: `ctrl_write`, `addr_write`,
    `data_read` at their commit edge, `reset` with the first and last edges that sample rst high.
    """
    strobe_edges: np.ndarray
    a: np.ndarray
    b: np.ndarray
    idx: np.ndarray
    depth_log2: int = 10
    sessions: list[Session] = field(default_factory=list)
    fields: CapCtrl = CapCtrl()
    raddr: int = 0
    reset_edge: int = -(1 << 62)     # the last edge that sampled rst high

    def __post_init__(self) -> None:
        self.strobe_edges = np.asarray(self.strobe_edges, np.int64)
        self.w = words(self.a, self.b)
        self._rise_for(self.reset_edge)

    def _rise_for(self, reset_edge: int) -> None:
        """Index rises with the sample before the first strobe after a reset counted as low."""
        idx = np.asarray(self.idx, np.int64) != 0
        self.rise = rises(idx)
        k = int(np.searchsorted(self.strobe_edges, reset_edge, side="right"))
        if k < idx.shape[0]:
            self.rise[k] = idx[k]

    @property
    def depth(self) -> int:
        return 1 << self.depth_log2

    def _cut(self, edge: int) -> None:
        if self.sessions and self.sessions[-1].end == NEVER:
            self.sessions[-1].end = edge

    def reset(self, first_edge: int, last_edge: int) -> None:
        self._cut(first_edge)
        self.fields = CapCtrl()
        self.raddr = 0
        self.reset_edge = last_edge
        self._rise_for(last_edge)
        self.sessions.append(Session(last_edge, CapCtrl(), np.zeros(0, np.int64),
                                     np.zeros(0, np.int64), np.zeros(0, np.int64), NEVER))

    def ctrl_write(self, edge: int, word: int) -> None:
        c = CapCtrl.decode(word)
        self.fields = CapCtrl(False, c.sel, c.trig, c.trig_axis, c.decim)
        self._cut(edge)
        if c.arm:
            self.sessions.append(schedule(self.strobe_edges, self.w, self.rise, edge, c,
                                          self.depth_log2))

    def addr_write(self, word: int) -> None:
        self.raddr = word & (self.depth - 1)

    def data_read(self) -> None:
        self.raddr = (self.raddr + 1) & (self.depth - 1)

    # ------------------------------------------------------------------ state after an edge
    def _armed_session(self) -> Session | None:
        """The last session, if an arming write (not a reset) started it."""
        if self.sessions and self.sessions[-1].ctrl.arm:
            return self.sessions[-1]
        return None

    def stat(self, edge: int) -> int:
        """CAP_STAT after every edge <= edge."""
        s = self._armed_session()
        count = done = armed = busy = 0
        if s is not None and s.arm_edge <= edge:
            lim = limit(self.depth_log2, s.ctrl.sel)
            count = s.n_written(edge)
            done = int(count == lim)
            live = edge < s.end
            first_take = int(s.take_edges[0]) if s.take_edges.size else NEVER
            armed = int(live and edge < first_take)
            busy = int(live and first_take <= edge and not done)
        return (count << 16) | (self.depth_log2 << 4) | (busy << 2) | (armed << 1) | done

    def entry(self, addr: int, edge: int) -> int | None:
        """Entry `addr` of the RAM after every edge <= edge (None: never written)."""
        for s in reversed(self.sessions):
            n = s.n_written(edge)
            if addr < n:
                return int(s.w_data[addr])
        return None

    def read(self, offset: int, edge: int) -> int:
        """Register `offset` (0 CAP_CTRL .. 3 CAP_DATA) as the bus samples it when the state is
        that after every edge <= edge (CAP_DATA: the RAM's output register, one edge older)."""
        if offset == 0:
            return self.fields.encode()
        if offset == 1:
            return self.stat(edge)
        if offset == 2:
            return self.raddr
        v = self.entry(self.raddr, edge - 1)
        if v is None:
            raise LookupError(f"CAP_DATA of entry {self.raddr}, never written (unknown)")
        return v


def capture_params(depth_log2: int = 10, clk_hz: int = 48_000_000) -> Params:
    return {"CLK_HZ": clk_hz, "SAMPLE_HZ": 1_000_000, "DEPTH_LOG2": depth_log2,
            "ADDR_BITS": 8, "BASE": 64}


def blocks() -> list[Block]:
    return [Block(name="hg_capture", top="hg_capture", sources=("capture/hg_capture.v",),
                  params=capture_params,
                  # (Yosys's generic synth has no RAM mapping: the buffer would be 16k flops)
                  lint_synth=("ice40",),
                  doc="raw ADC capture buffer: armed/triggered over the bus, block RAM, "
                      "read back through CAP_ADDR/CAP_DATA")]
