"""cocotb tests of rtl/interp/enc_interp.v with CAL = 1 (the online calibration stage,
rtl/interp/enc_calib.v) against hapgate.golden.interp / hapgate.golden.enccal.

Every output column and the calibration state (read in the cycle m_cal_valid presents it) are
compared with the bit-exact model on every sample, with the calibration enabled, disabled and
frozen along the way, back to back and with idle clocks between samples. Inputs are driven and
outputs sampled on the falling clock edge.
"""

from __future__ import annotations

import os

import cocotb
import numpy as np
from cocotb.triggers import FallingEdge
from cocotb.utils import get_sim_time
from hapgate.golden import encsig, interp
from hapgate.runners import native, tbutil

LATENCY = 6        # clocks from s_valid to m_valid with the calibration stage
PERIOD_NS = 20
MU = 4


def config() -> interp.InterpConfig:
    return interp.InterpConfig(**tbutil.model_config())  # type: ignore[arg-type]


def stimulus(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Paper-like signals: 100 rev/s, a reversal, standstill, a clipping burst; calibration
    enabled at n/20, disabled for 30 samples at n/2, frozen over [0.7 n, 0.8 n)."""
    k = np.arange(n)
    v = 100.0 * encsig.LINES / encsig.SAMPLE_HZ            # lines per sample
    x = 0.3 + np.cumsum(np.where(k < 0.6 * n, v, np.where(k < 0.75 * n, -v, 0.0)))
    a, b = encsig.adc_codes(x, encsig.with_spec(encsig.PAPER_LIKE, seed=5))
    lo = int(0.9 * n)
    a[lo:lo + 40] = 127                                     # clipping: no update from it
    en = (k >= n // 20) & ~((k >= n // 2) & (k < n // 2 + 30))
    fr = (k >= int(0.7 * n)) & (k < int(0.8 * n))
    return a, b, en, fr


async def stream(dut, a: np.ndarray, b: np.ndarray, en: np.ndarray, fr: np.ndarray,
                 gaps: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
    n = a.size
    cols: dict[str, list[int]] = {c: [] for c in native.ALL_COLUMNS}
    calq: list[tuple[int, ...]] = []
    sent: list[float] = []
    lat: list[float] = []
    k, wait, cycle = 0, int(gaps[0]), 0
    ua, ub = a.astype(np.int64) & 0xFF, b.astype(np.int64) & 0xFF
    while len(sent) < n or len(lat) < n:
        await FallingEdge(dut.clk)
        cycle += 1
        if dut.m_cal_valid.value == 1:
            calq.append((dut.m_cal_ofs_a.value.to_signed(), dut.m_cal_ofs_b.value.to_signed(),
                         dut.m_cal_gain_a.value.to_unsigned(),
                         dut.m_cal_gain_b.value.to_unsigned(),
                         dut.m_cal_phase.value.to_signed(), dut.m_cal_gear.value.to_unsigned(),
                         dut.m_cal_updates.value.to_unsigned()))
        if dut.m_valid.value == 1:
            lat.append(get_sim_time("ns") - sent[len(lat)])
            tbutil.append_interp_outputs(dut, cols)
            assert calq, "a result without its calibration state"
            for c, v in zip(native.CAL_COLUMNS, calq.pop(0)):
                cols[c].append(v)
        if k < n and wait == 0:
            dut.s_valid.value = 1
            dut.s_a.value = int(ua[k])
            dut.s_b.value = int(ub[k])
            dut.ctl_cal_en.value = int(en[k])
            dut.ctl_cal_freeze.value = int(fr[k])
            sent.append(get_sim_time("ns"))
            k += 1
            wait = int(gaps[k]) if k < n else 0
        else:
            dut.s_valid.value = 0
            # the levels between samples do not matter: only the captured ones
            dut.ctl_cal_en.value = int(cycle & 1)
            dut.ctl_cal_freeze.value = int((cycle >> 1) & 1)
            wait = max(0, wait - 1)
        assert cycle < int(np.sum(gaps)) + n + 50, "outputs stopped coming"
    return {c: np.array(v, dtype=np.int64) for c, v in cols.items()}, np.array(lat)


async def run_and_check(dut, gaps_max: int) -> None:
    cfg = config()
    n = int(os.environ["HG_SAMPLES"])
    a, b, en, fr = stimulus(n)
    gaps = np.random.default_rng(11).integers(0, gaps_max + 1, n)
    dut.s_valid.value = 0
    dut.s_a.value = 0
    dut.s_b.value = 0
    dut.s_index.value = 0
    dut.ctl_fault_clear.value = 0
    dut.ctl_home_arm.value = 0
    dut.ctl_cal_en.value = 0
    dut.ctl_cal_freeze.value = 0
    dut.cfg_cal_mu.value = MU
    await tbutil.start(dut, period_ns=PERIOD_NS)
    rtl, lat = await stream(dut, a, b, en, fr, gaps)
    out = interp.run(a, b, None, cfg, cal_en=en, cal_freeze=fr, cal_mu=MU)
    model = native.model_matrix(out) | native.cal_columns(out)
    bad = native.first_mismatch(rtl, model)
    assert bad is None, f"first mismatch at sample {bad[0]}, column {bad[1]}: " \
                        f"RTL {bad[2]} model {bad[3]}"
    assert int(model["cal_updates"][-1]) >= n // 50, "too few updates to test anything"
    want = LATENCY * PERIOD_NS
    assert np.all(np.round(lat, 3) == want), f"latency {sorted(set(lat.tolist()))} ns != {want} ns"


@cocotb.test()
async def calibration_bit_exact(dut):
    """One sample per clock: every column and the calibration state, every sample."""
    await run_and_check(dut, 0)


@cocotb.test()
async def calibration_bit_exact_with_gaps(dut):
    """0..3 idle clocks between samples (the clock ratio does not change any result)."""
    await run_and_check(dut, 3)
