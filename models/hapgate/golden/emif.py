"""The DSP bus (rtl/bus/emif_slave.v): its timing rules, and a cocotb master and monitor
(imported inside the simulator process by tb/bus and tb/top).

Timing rules, in FPGA clocks T = 1/CLK_HZ (the slave synchronises CE, RE and WE with two flip-flops
and captures address and data at the third clock edge after the strobe falls):

- setup (address, CE, write data valid before the strobe falls): >= 0 T; they are captured
  2..3 clocks after the fall;
- strobe (RE or WE low): >= 5 T. The access is served iff the strobe is still low at the capture
  edge (< 3 T after the fall); read data are valid < 3 T + t_co after the fall; +1 T for a
  metastable first stage, +1 T of read-data setup at the DSP;
- data and address stable through the strobe (captured before it ends: hold >= 0);
- recovery (strobe high between two strobes, hold + next setup): >= 3 T, so the synchroniser
  sees the strobe high and `ready` falls.

A strobe that ends before the capture edge is dropped (nothing is written) and sets
STATUS.PROTO_ERR, as do read and write strobes low together; a strobe shorter than one clock may
not be seen at all. Read data drivers (`data_oe`) follow CE and RE combinationally, like an
SRAM's OE#. `ready` rises when the access has been served (3..4 T after the fall): a master that
waits for it needs no strobe length.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

SYNC_STAGES = 2
CAPTURE_EDGE = 3          # the access is captured at the 3rd clock edge after the strobe falls
MIN_SETUP_CLOCKS = 0
MIN_STROBE_CLOCKS = 5
MIN_RECOVERY_CLOCKS = 3


@dataclass
class Timing:
    """One access's phases in ps: setup (CE/address before the strobe), strobe, hold (after the
    strobe, CE still low) and idle (CE high before the next access)."""
    setup: int
    strobe: int
    hold: int
    idle: int = 0


def random_timing(rng: random.Random, period_ps: int, min_strobe_clocks: float = MIN_STROBE_CLOCKS
                  ) -> Timing:
    """EMIF-like timing: a bus clock of random period (0.2 .. 2.5 FPGA clocks), whole bus cycles
    per phase, strobe >= min_strobe_clocks and recovery >= MIN_RECOVERY_CLOCKS FPGA clocks."""
    eclk = int(period_ps * rng.uniform(0.2, 2.5))
    setup = rng.randint(0, 3) * eclk
    n_strobe = -(-int(min_strobe_clocks * period_ps) // eclk)
    strobe = (n_strobe + rng.choice((0, 0, 0, 1, 2, 5))) * eclk
    n_rec = -(-(MIN_RECOVERY_CLOCKS * period_ps + 1) // eclk)
    hold_cycles = rng.randint(0, 2)
    idle = max(0, n_rec - hold_cycles) * eclk + rng.choice((0, 0, 1)) * eclk  # (next setup: bonus)
    return Timing(setup=setup, strobe=strobe, hold=hold_cycles * eclk, idle=idle)


@dataclass
class Access:
    we: bool
    word: int
    wdata: int = 0
    rdata: int | None = None       # what the master sampled at the end of the strobe
    oe: int = 0                    # data_oe at the end of the strobe
    ready: int = 0                 # ready at the end of the strobe
    t_fall: int = 0                # ps


@dataclass
class Committed:
    edge: int                      # clock edge (index from the reset edge) that applied it
    we: bool
    word: int
    wdata: int


class EmifMaster:
    """Drives bus_ce_n/re_n/we_n/addr/data_in with Timer-based phases (3-4 awaits per access,
    independent of the FPGA clock, so the phase against it is random)."""

    def __init__(self, dut) -> None:
        self.dut = dut
        self.log: list[Access] = []
        dut.bus_ce_n.value = 1
        dut.bus_re_n.value = 1
        dut.bus_we_n.value = 1
        dut.bus_addr.value = 0
        dut.bus_data_in.value = 0

    async def access(self, we: bool, word: int, wdata: int, t: Timing) -> Access:
        from cocotb.triggers import Timer
        from cocotb.utils import get_sim_time

        dut = self.dut
        acc = Access(we=we, word=word, wdata=wdata if we else 0)
        dut.bus_addr.value = word
        dut.bus_data_in.value = wdata if we else random.getrandbits(32)
        dut.bus_ce_n.value = 0
        if t.setup:
            await Timer(t.setup, unit="ps")
        acc.t_fall = int(get_sim_time(unit="ps"))
        (dut.bus_we_n if we else dut.bus_re_n).value = 0
        await Timer(t.strobe, unit="ps")
        acc.oe = int(dut.bus_data_oe.value)
        acc.ready = int(dut.bus_ready.value)
        if not we:
            v = dut.bus_data_out.value
            acc.rdata = v.to_unsigned() if v.is_resolvable else -1
        (dut.bus_we_n if we else dut.bus_re_n).value = 1
        if t.hold:
            await Timer(t.hold, unit="ps")
        dut.bus_ce_n.value = 1
        if t.idle:
            await Timer(t.idle, unit="ps")
        self.log.append(acc)
        return acc

    async def read(self, word: int, t: Timing) -> int:
        acc = await self.access(False, word, 0, t)
        assert acc.rdata is not None
        return acc.rdata

    async def write(self, word: int, value: int, t: Timing) -> None:
        await self.access(True, word, value, t)


@dataclass
class Monitor:
    """Records every committed access (dbg_req) and dropped access (dbg_proto_err) with its
    clock edge, counted from the reset edge `ref_ps`. `scope`: the instance with the dbg_*
    signals (default: the DUT itself)."""
    dut: object
    period_ps: int
    ref_ps: int
    scope: object = None
    committed: list[Committed] = field(default_factory=list)
    proto: list[int] = field(default_factory=list)
    rises: dict[str, list[int]] = field(default_factory=dict)

    def edge_now(self) -> int:
        from cocotb.utils import get_sim_time

        t = int(get_sim_time(unit="ps")) - self.ref_ps
        e, r = divmod(t, self.period_ps)
        assert r == 0, "woken off a rising clock edge"
        return e

    def start(self, *watch: str) -> None:
        import cocotb

        if self.scope is None:
            self.scope = self.dut

        cocotb.start_soon(self._req())
        cocotb.start_soon(self._proto())
        for name in watch:
            self.rises[name] = []
            cocotb.start_soon(self._rise(name))

    async def _req(self) -> None:
        from cocotb.triggers import ReadOnly, RisingEdge

        dut = self.scope
        while True:
            await RisingEdge(dut.dbg_req)
            await ReadOnly()    # (Icarus shows zero-time glitches of the combinational pulse)
            if not int(dut.dbg_req.value):
                continue
            # m_req is high after edge e: the access is applied at edge e + 1
            self.committed.append(Committed(self.edge_now() + 1, bool(int(dut.dbg_we.value)),
                                            int(dut.dbg_addr.value), int(dut.dbg_wdata.value)))

    async def _proto(self) -> None:
        from cocotb.triggers import ReadOnly, RisingEdge

        while True:
            await RisingEdge(self.scope.dbg_proto_err)
            await ReadOnly()
            if not int(self.scope.dbg_proto_err.value):
                continue
            self.proto.append(self.edge_now() + 1)

    async def _rise(self, name: str) -> None:
        from cocotb.triggers import RisingEdge

        sig = getattr(self.scope, name)
        while True:
            await RisingEdge(sig)
            self.rises[name].append(self.edge_now())
