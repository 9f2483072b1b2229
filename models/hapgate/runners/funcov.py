"""Functional coverage (`make coverage`): cover points and crosses over what each block's spec
defines, kept with cocotb-coverage (PyPI) and sampled where the suite's runners and benches
already hold the RTL's inputs and outputs.

Active only in a coverage run (HG_COVERAGE_DIR set, as for code coverage: runners/covbuild.py);
every `sample_*` is a no-op otherwise, so `make test` pays nothing. Sampling is vectorised: the
bins a run hits are computed with numpy over all its samples, and the decorated cocotb-coverage
function is called once per distinct bin tuple (never once per sample). Each process writes its
database to `<HG_COVERAGE_DIR>/func/<pid>.yml` at exit (and at every `flush()`); the coverage
command merges them with cocotb_coverage.coverage.merge_coverage. Every process that imports this
module declares every group, so the merged totals count the bins nobody hit.

The groups (their bins come from docs/design/SPEC.md and the block docs):
- interp: quadrant transition (from quadrant) x direction x speed band up to the spec's
  244.2 rev/s; the index edge in each quadrant; each fault kind (overspeed, clipping, loss)
- commutation: mode x channel x torque sign x clamp hit (|torque| above the limit)
- dac_sched: every DAC slot (channel load) at every shipped clock
- bus: every register x access kind; each snapshot register read before and after the first
  snapshot; unmapped addresses read and written
- top: every cause of zero torque seen at the DAC pins (watchdog, disable, each axis fault kind)
- device: every [[fault]] kind of a scene x the axis it names
"""

from __future__ import annotations

import atexit
import functools
import os
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

import numpy as np

from .covbuild import ENV

# --------------------------------------------------------------------------------- the bins
QUADRANTS = (0, 1, 2, 3)
DIRECTIONS = ("up", "down")
# speed bands of a quadrant transition, rev/s: the spec's capture limit is 244.2 rev/s
# (1 MSPS / (4 samples/line x 1024 lines)); a transition faster than it is not a transition bin
SPEED_EDGES = (0.0, 1.0, 10.0, 100.0, 244.2)
SPEEDS = ("<1", "1-10", "10-100", "100-244")
INTERP_FAULTS = ("overspeed", "clip", "loss")       # golden.interp FAULT_* bits 1, 2, 4
MODES = ("sine", "six_step", "align", "off")        # golden.commutation MODES, by value 0..3
CHANNELS = ("m0a", "m0b", "m1a", "m1b", "m2a", "m2b")
SIGNS = ("neg", "zero", "pos")
# shipped clocks: the paper design's default and the boards' (flows/boards.py); the tests check
# this tuple against both (tb/coverage/test_funcov.py)
SHIPPED_HZ = (12_000_000, 48_000_000)
ACCESS = ("read", "write")
SNAP_STATES = ("before_first", "after_first")
TOP_CAUSES = ("watchdog", "disable", "overspeed", "clip", "loss")
DEVICE_FAULTS = (("dropout", 0), ("dropout", 1), ("dropout", 2), ("hang", "all"),
                 ("watchdog", "all"), ("link_garbage", "all"))


@functools.cache
def _bus_registers() -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(every register's name, the snapshot registers' names) of the RDL register map."""
    from ..flows import regmap
    rm = regmap.load()
    names = tuple(r.name for r in rm.registers)
    snap = ("POS", "VEL", "IDX_POS", "COUNTS", "POS_HOMED", "FLAGS")   # (golden.regmodel)
    return names, tuple(n for n in names if n == "SEQ" or n.split(".")[-1] in snap
                        and n.startswith("AXIS["))


_items: dict[str, Callable[..., None]] = {}


def _declare() -> dict[str, Callable[..., None]]:
    """Declare every cover item once per process (on the first sample of a coverage run, so
    that a process outside one neither imports cocotb-coverage nor compiles the RDL)."""
    if _items:
        return _items
    from cocotb_coverage.coverage import CoverCross, CoverPoint

    def ident(i: int) -> Callable[..., object]:
        return lambda *a: a[i]

    registers, snap_registers = _bus_registers()

    @CoverPoint("interp.transition.from", xf=ident(0), bins=list(QUADRANTS))
    @CoverPoint("interp.transition.direction", xf=ident(1), bins=list(DIRECTIONS))
    @CoverPoint("interp.transition.speed", xf=ident(2), bins=list(SPEEDS))
    @CoverCross("interp.transition.cross", items=["interp.transition.from",
                                                  "interp.transition.direction",
                                                  "interp.transition.speed"])
    def interp_transition(quadrant: int, direction: str, speed: str) -> None:
        pass

    @CoverPoint("interp.index.quadrant", xf=ident(0), bins=list(QUADRANTS))
    def interp_index(quadrant: int) -> None:
        pass

    @CoverPoint("interp.fault.kind", xf=ident(0), bins=list(INTERP_FAULTS))
    def interp_fault(kind: str) -> None:
        pass

    @CoverPoint("commutation.frame.mode", xf=ident(0), bins=list(MODES))
    @CoverPoint("commutation.frame.channel", xf=ident(1), bins=list(CHANNELS))
    @CoverPoint("commutation.frame.sign", xf=ident(2), bins=list(SIGNS))
    @CoverPoint("commutation.frame.clamp", xf=ident(3), bins=[False, True])
    @CoverCross("commutation.frame.cross", items=["commutation.frame.mode",
                                                  "commutation.frame.channel",
                                                  "commutation.frame.sign",
                                                  "commutation.frame.clamp"],
                # a zero torque command cannot exceed a limit (limits are >= 0)
                ign_bins=[(None, None, "zero", True)])
    def comm_frame(mode: str, channel: str, sign: str, clamp: bool) -> None:
        pass

    @CoverPoint("dac_sched.load.slot", xf=ident(0), bins=list(range(len(CHANNELS))))
    @CoverPoint("dac_sched.load.clock", xf=ident(1), bins=list(SHIPPED_HZ))
    @CoverCross("dac_sched.load.cross", items=["dac_sched.load.slot", "dac_sched.load.clock"])
    def dac_load(slot: int, clk_hz: int) -> None:
        pass

    @CoverPoint("bus.access.register", xf=ident(0), bins=list(registers))
    @CoverPoint("bus.access.kind", xf=ident(1), bins=list(ACCESS))
    @CoverCross("bus.access.cross", items=["bus.access.register", "bus.access.kind"])
    def bus_access(register: str, kind: str) -> None:
        pass

    @CoverPoint("bus.snapshot.register", xf=ident(0), bins=list(snap_registers))
    @CoverPoint("bus.snapshot.state", xf=ident(1), bins=list(SNAP_STATES))
    @CoverCross("bus.snapshot.cross", items=["bus.snapshot.register", "bus.snapshot.state"])
    def bus_snapshot(register: str, state: str) -> None:
        pass

    @CoverPoint("bus.unmapped.kind", xf=ident(0), bins=list(ACCESS))
    def bus_unmapped(kind: str) -> None:
        pass

    @CoverPoint("top.zero_torque.cause", xf=ident(0), bins=list(TOP_CAUSES))
    def top_zero(cause: str) -> None:
        pass

    @CoverPoint("device.fault.kind_axis", xf=lambda k, a: (k, a), bins=list(DEVICE_FAULTS))
    def device_fault(kind: str, axis: object) -> None:
        pass

    _items.update(interp_transition=interp_transition, interp_index=interp_index,
                  interp_fault=interp_fault, comm_frame=comm_frame, dac_load=dac_load,
                  bus_access=bus_access, bus_snapshot=bus_snapshot, bus_unmapped=bus_unmapped,
                  top_zero=top_zero, device_fault=device_fault)
    return _items


GROUPS = ("interp", "commutation", "dac_sched", "bus", "top", "device")


# ------------------------------------------------------------------------------ sampling
_sampled = False


def active() -> bool:
    return bool(os.environ.get(ENV))


def _hit(item: str, rows: Iterable[tuple]) -> None:
    """Call the cover function `item` once per distinct bin tuple."""
    global _sampled
    fn = _declare()[item]
    for row in dict.fromkeys(rows):
        fn(*row)
    if not _sampled:
        _sampled = True
        atexit.register(flush)


def flush() -> None:
    """Write this process's database (a coverage run that sampled anything)."""
    d = os.environ.get(ENV)
    if not d or not _sampled:
        return
    out = Path(d) / "func"
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / f".{os.getpid()}.yml.tmp"
    from cocotb_coverage.coverage import coverage_db
    coverage_db.export_to_yaml(str(tmp))
    tmp.replace(out / f"{os.getpid()}.yml")


def _rows(*cols: np.ndarray) -> list[tuple]:
    if not cols or cols[0].size == 0:
        return []
    u = np.unique(np.stack([np.asarray(c, dtype=np.int64).ravel() for c in cols], axis=1),
                  axis=0)
    return [tuple(int(x) for x in r) for r in u]


def speed_band(rev_s: np.ndarray) -> np.ndarray:
    """Band index per speed (len(SPEEDS) for a speed beyond the last edge)."""
    return np.searchsorted(np.asarray(SPEED_EDGES[1:]), rev_s, side="left")


def sample_interp(pos: np.ndarray, faults: np.ndarray, index: np.ndarray | None,
                  quadrant_counts: int, counts_per_rev: int, sample_hz: int) -> None:
    """One axis of an interpolator run: RTL positions and fault bits per sample, the index
    input (None: low), the counts of one quadrant and of one revolution, the sample rate."""
    if not active():
        return
    pos = np.asarray(pos, dtype=np.int64)
    q = (pos // quadrant_counts) % 4
    ch = np.flatnonzero(q[1:] != q[:-1])
    step = pos[ch + 1] - pos[ch]
    band = speed_band(np.abs(step) * sample_hz / counts_per_rev)
    ok = (band < len(SPEEDS)) & (step != 0)
    _hit("interp_transition", [(int(a), DIRECTIONS[int(d)], SPEEDS[int(s)]) for a, d, s in
                              _rows(q[ch][ok], (step[ok] < 0), band[ok])])
    if index is not None:
        idx = np.asarray(index).astype(bool).ravel()
        rise = np.flatnonzero(idx[1:] & ~idx[:-1]) + 1
        _hit("interp_index", [(int(a),) for (a,) in _rows(q[rise])])
    f = np.asarray(faults, dtype=np.int64)
    new = f[1:] & ~f[:-1]
    seen = np.bitwise_or.reduce(np.concatenate([f[:1], new])) if f.size else 0
    _hit("interp_fault", [(k,) for b, k in zip((1, 2, 4), INTERP_FAULTS) if seen & b])


def sample_commutation(mode: np.ndarray, torque: np.ndarray, limit: np.ndarray) -> None:
    """Commutator frames: mode and torque per motor (n, 3), the torque limit per frame (n,)."""
    if not active():
        return
    mode = np.asarray(mode, dtype=np.int64) & 3
    tq = np.asarray(torque, dtype=np.int64)
    lim = np.broadcast_to(np.asarray(limit, dtype=np.int64)[:, None], tq.shape)
    sign = np.sign(tq) + 1
    clamp = np.abs(tq) > lim
    motor = np.broadcast_to(np.arange(3), tq.shape)
    rows = _rows(mode, motor, sign, clamp)
    _hit("comm_frame", [(MODES[m], CHANNELS[2 * k + c], SIGNS[s], bool(cl))
                       for m, k, s, cl in rows for c in (0, 1)])


def sample_dac(slots: Sequence[int], clk_hz: int) -> None:
    """The DAC channels (slots) a scheduler run loaded, at its clock."""
    if not active():
        return
    _hit("dac_load", [(int(s), int(clk_hz)) for s in set(slots) if 0 <= s < len(CHANNELS)])


def sample_bus(accesses: Sequence[tuple[str | None, bool, bool]]) -> None:
    """Bus accesses: (register name or None when unmapped, write?, a snapshot latched yet?)."""
    if not active():
        return
    rows = set(accesses)
    _hit("bus_access", [(r, ACCESS[w]) for r, w, _ in rows if r is not None])
    _hit("bus_snapshot", [(r, SNAP_STATES[s]) for r, w, s in rows
                         if r in _bus_registers()[1] and not w])
    _hit("bus_unmapped", [(ACCESS[w],) for r, w, _ in rows if r is None])


def sample_top(causes: Iterable[str]) -> None:
    """Causes of zero torque whose DAC loads a test checked."""
    if not active():
        return
    _hit("top_zero", [(c,) for c in causes])


def sample_device(faults: Iterable[tuple[str, object]]) -> None:
    """[[fault]] entries a virtual-device run applied: (kind, axis or "all")."""
    if not active():
        return
    _hit("device_fault", [(k, a) for k, a in faults])
