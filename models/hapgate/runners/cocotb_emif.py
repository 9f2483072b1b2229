"""cocotb master and monitor of the DSP bus (rtl/bus/emif_slave.v), imported inside the simulator
process by tb/bus and tb/top. The timing rules and the access records: hapgate.golden.emif."""

from __future__ import annotations

import random
from dataclasses import dataclass, field

import cocotb
from cocotb.triggers import ReadOnly, RisingEdge, Timer
from cocotb.utils import get_sim_time

from ..golden.emif import Access, Committed, Timing


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
        t = int(get_sim_time(unit="ps")) - self.ref_ps
        e, r = divmod(t, self.period_ps)
        assert r == 0, "woken off a rising clock edge"
        return e

    def start(self, *watch: str) -> None:
        if self.scope is None:
            self.scope = self.dut

        cocotb.start_soon(self._req())
        cocotb.start_soon(self._proto())
        for name in watch:
            self.rises[name] = []
            cocotb.start_soon(self._rise(name))

    async def _req(self) -> None:
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
        while True:
            await RisingEdge(self.scope.dbg_proto_err)
            await ReadOnly()
            if not int(self.scope.dbg_proto_err.value):
                continue
            self.proto.append(self.edge_now() + 1)

    async def _rise(self, name: str) -> None:
        sig = getattr(self.scope, name)
        while True:
            await RisingEdge(sig)
            self.rises[name].append(self.edge_now())
