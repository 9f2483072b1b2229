"""cocotb test of the capture buffer through the whole FPGA (rtl/top/hapgate_top.v, CAPTURE = 1)
over the DSP bus: the ADC words the interpolators take are recorded (all axes at an index edge
with decimation, one axis at once, a stop mid-capture) and read back through CAP_ADDR /
CAP_DATA; every bus read of ID and the CAP_* registers against the register model with the
capture model (`hapgate.golden.regmodel`, `hapgate.golden.capture`), and every entry read back
against the ADC stream driven (independent of both models). Axis 0 carries an encoder signal
with 3 % 2nd harmonic (`hapgate.golden.encsig`): its capture, read over the bus, goes through
the signal-quality analysis (`hapgate.golden.encquality`), which must find the harmonic and
fail only that band."""

from __future__ import annotations

import random

import cocotb
import numpy as np
from cocotb.triggers import ClockCycles, RisingEdge
from hapgate.flows import regmap
from hapgate.golden import encquality, encsig
from hapgate.golden.capture import CapCtrl, CaptureModel, limit, unpack
from hapgate.golden.regmodel import RegModel
from hapgate.runners import tbutil

P = tbutil.params()
CLK_HZ = int(P["CLK_HZ"])  # type: ignore[arg-type]
PERIOD_PS = 10**12 // CLK_HZ
DL2 = int(P["CAP_DEPTH_LOG2"])  # type: ignore[arg-type]
RM = regmap.load(CLK_HZ)
W = {r.name: r.word for r in RM.registers}
N = 3000


@cocotb.test()
async def capture_over_bus(dut) -> None:
    rng = random.Random(3)
    g = np.random.default_rng(3)
    a = g.integers(-100, 100, (N, 3))      # inside the interpolator's range: no clipping fault
    b = g.integers(-100, 100, (N, 3))
    idx = np.zeros((N, 3), np.int64)
    spec = encsig.SignalSpec(amplitude=127 / 1.2, h2=0.03, noise_lsb=0.3, seed=2)
    a[:, 0], b[:, 0] = encsig.adc_codes(encsig.constant(60.0, N, start=0.3), spec)  # 16 lines
    idx[400:404, 1] = 1
    idx[900:902, 2] = 1
    bus = await tbutil.TopBus(dut, PERIOD_PS, W, rng).start()
    mon = bus.mon
    assert mon is not None
    strobes: list[int] = []

    async def drive() -> None:
        for k in range(N):
            await RisingEdge(dut.adc_strobe)
            strobes.append(mon.edge_now() + 1)        # the words are taken at the next edge
            dut.adc_a.value = sum((int(a[k, i]) & 0xFF) << (8 * i) for i in range(3))
            dut.adc_b.value = sum((int(b[k, i]) & 0xFF) << (8 * i) for i in range(3))
            dut.enc_index.value = sum(int(idx[k, i]) << i for i in range(3))

    cocotb.start_soon(drive())
    await ClockCycles(dut.clk, 40)
    got: dict[str, list[int]] = {}

    async def capture(name: str, c: CapCtrl, stop_after: int | None = None) -> None:
        await bus.wr("CAP_CTRL", c.encode())
        if stop_after is not None:
            await ClockCycles(dut.clk, stop_after)
            await bus.wr("CAP_CTRL", 0)
        while True:
            s = await bus.rd("CAP_STAT")
            if s & 1 or (stop_after is not None and not s & 0b110):
                break
            await ClockCycles(dut.clk, 200)
        await bus.wr("CAP_ADDR", 0)
        got[name] = [await bus.rd("CAP_DATA") for _ in range(s >> 16)]

    assert await bus.rd("ID") == RM.by_name()["ID"].reset
    await capture("all_index_decim", CapCtrl(True, sel=3, trig=1, trig_axis=3, decim=1))
    await capture("axis1_now", CapCtrl(True, sel=1))
    await capture("axis0_quality", CapCtrl(True, sel=0))
    await capture("axis2_stopped", CapCtrl(True, sel=2, decim=2), stop_after=100 * CLK_HZ
                  // 1_000_000)
    await bus.rd("CAP_CTRL")
    await bus.rd("CAP_ADDR")
    # replay through the register model with the capture model
    n = len(strobes)
    cap = CaptureModel(np.array(strobes), a[:n], b[:n], idx[:n], depth_log2=DL2, reset_edge=0)
    model = RegModel(RM, capture=cap)
    errors = []
    for acc, c in zip(bus.master.log, mon.committed):
        assert (acc.we, acc.word) == (c.we, c.word)
        exp = model.access(c.word, c.we, c.wdata, c.edge)
        if not acc.we and exp != acc.rdata:
            errors.append(f"read 0x{c.word:02x} at edge {c.edge}: 0x{acc.rdata:08x}, model "
                          f"0x{exp:08x}")
    assert len(mon.committed) == len(bus.master.log)
    assert not errors, f"{len(errors)} reads differ:\n" + "\n".join(errors[:10])
    # the entries against the stream itself
    w = (b & 0xFF) << 8 | (a & 0xFF)
    k_trig = 400            # the first index rise after the arming (axis 1)
    ks = k_trig + 2 * np.arange(limit(DL2, 3) // 3)
    assert got["all_index_decim"] == w[ks].ravel().tolist()
    arms = [c.edge for c in mon.committed if c.we and c.word == W["CAP_CTRL"] and c.wdata & 1]
    assert len(got["axis1_now"]) == limit(DL2, 1)
    first = int(np.searchsorted(np.array(strobes), arms[1], side="right"))   # the next sample
    assert got["axis1_now"] == w[first:first + limit(DL2, 1), 1].tolist()
    assert 0 < len(got["axis2_stopped"]) < limit(DL2, 2)
    q = encquality.analyse(*unpack(np.array(got["axis0_quality"]), 0))
    failed = {c.name for c in encquality.checks(q) if c.result == "FAIL"}
    # tolerance as tb/capture/test_encquality.py: 0.3 LSB on a coefficient of a 106-code signal
    assert abs(q.h2_pct - 3.0) <= 100 * 0.3 / spec.amplitude and failed == {"h2_pct"}, (q, failed)
    dut._log.info(f"capture over the bus: {len(bus.master.log)} accesses as the model; entries "
                  f"{ {k: len(v) for k, v in got.items()} } as the ADC stream; axis 0: "
                  f"h2 {q.h2_pct:.2f} % (built 3 %), {q.cycles:.1f} lines, failed {failed}")
