"""cocotb test of the tracking velocity observer inside rtl/interp/enc_interp.v (VEL_OBS = 1)
against hapgate.golden.interp + hapgate.golden.velobs: every output column (the FIR's included)
on every sample, with the bandwidth code and the loop type changing between samples (codes
outside 2..8 included) and the stress scenario's faults, clears and homing arms."""

from __future__ import annotations

import os

import cocotb
import numpy as np
from cocotb.triggers import FallingEdge
from hapgate.golden import encsig, interp, velobs
from hapgate.runners import native, tbutil

PERIOD_NS = 20


def settings(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample bandwidth code and loop type: piecewise constant, changing every 150 samples."""
    rng = np.random.default_rng(seed)
    seg = np.arange(n) // 150
    codes = np.array([6, 3, 8, 0, 5, 15, 2, 7, 1, 9, 4, 6])
    bw = codes[(seg + rng.integers(0, codes.size)) % codes.size]
    t3 = ((seg + seed) % 3) != 1
    return bw, t3


def joined(names: list[str], n_each: int) -> encsig.Scenario:
    """The named scenarios back to back (one stream: one reset, the loop carried across)."""
    parts = [encsig.scenario(s, n_each) for s in names]
    off = np.arange(len(parts)) * n_each
    return encsig.Scenario(
        "+".join(names), np.concatenate([p.a for p in parts]),
        np.concatenate([p.b for p in parts]), np.concatenate([p.index for p in parts]),
        np.concatenate([p.truth_lines for p in parts]),
        np.concatenate([p.clear_at + o for p, o in zip(parts, off)]).astype(np.int64),
        np.concatenate([p.arm_at + o for p, o in zip(parts, off)]).astype(np.int64))


@cocotb.test()
async def observer_bit_exact(dut):
    cfg = interp.InterpConfig(**tbutil.model_config())  # type: ignore[arg-type]
    sc = joined(os.environ["HG_SCENARIO"].split(","), int(os.environ["HG_SAMPLES"]))
    n = sc.a.size
    bw, t3 = settings(n, int(os.environ.get("HG_SEED", "1")))
    clear = np.zeros(n, dtype=bool)
    clear[sc.clear_at] = True
    arm = np.zeros(n, dtype=bool)
    arm[sc.arm_at] = True
    dut.s_valid.value = 0
    dut.s_a.value = 0
    dut.s_b.value = 0
    dut.s_index.value = 0
    dut.ctl_fault_clear.value = 0
    dut.ctl_home_arm.value = 0
    dut.cfg_obs_bw.value = 0
    dut.cfg_obs_type3.value = 0
    await tbutil.start(dut, period_ns=PERIOD_NS)
    a = (sc.a.astype(np.int64) & 0xFF).tolist()
    b = (sc.b.astype(np.int64) & 0xFF).tolist()
    idx = sc.index.astype(np.int64).tolist()
    cols: dict[str, list[int]] = {c: [] for c in (*native.COLUMNS, "vel_obs")}
    k = 0
    for _ in range(n + 20):
        await FallingEdge(dut.clk)
        if dut.m_valid.value == 1:
            tbutil.append_interp_outputs(dut, cols)
            cols["vel_obs"].append(dut.m_vel_obs.value.to_signed())
        if k < n:
            dut.s_valid.value = 1
            dut.s_a.value = a[k]
            dut.s_b.value = b[k]
            dut.s_index.value = idx[k]
            dut.ctl_fault_clear.value = int(clear[k])
            dut.ctl_home_arm.value = int(arm[k])
            dut.cfg_obs_bw.value = int(bw[k])
            dut.cfg_obs_type3.value = int(t3[k])
            k += 1
        else:
            dut.s_valid.value = 0
    rtl = {c: np.array(v, dtype=np.int64) for c, v in cols.items()}
    assert rtl["pos"].size == n, f"{rtl['pos'].size} results for {n} samples"
    out = interp.run(sc.a, sc.b, sc.index, cfg, clear_at=sc.clear_at, arm_at=sc.arm_at)
    model = native.model_matrix(out)
    # the settings are levels read at each sample's update, latency - 2 clocks after its capture:
    # at one sample per clock, those driven with sample k + latency - 2
    lag = cfg.latency - 2
    at = np.minimum(np.arange(n) + lag, n - 1)
    model["vel_obs"] = velobs.run_interp(out, velobs.ObsConfig(vel_log2w=cfg.vel_log2w),
                                         bw=bw[at], type3=t3[at])
    bad = native.first_mismatch(rtl, model)
    assert bad is None, f"{sc.name}: first mismatch at sample {bad[0]}, column {bad[1]}: " \
                        f"RTL {bad[2]} model {bad[3]}"
    moving = np.abs(model["vel_obs"]).max()
    dut._log.info(f"{sc.name}: {n} samples bit-exact, max |vel_obs| {moving}")
