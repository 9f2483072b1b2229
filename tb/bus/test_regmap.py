"""The register map's one source: the committed generated files are up to date, the firmware's
mapping header (dsp-fw/include/hg_fpga_regs.h) resolves to the RDL's addresses and bits (compiled
with the firmware's flags and printed), and the RDL says what the safety rules require."""

from __future__ import annotations

import subprocess

from hapgate.base.paths import BUILD, ROOT, ensure
from hapgate.flows import regmap

FW_INCLUDE = ROOT / "dsp-fw" / "include"


def test_committed_outputs_are_fresh() -> None:
    stale = regmap.generate(check=True)
    assert not stale, f"stale generated files (run `python -m hapgate.flows.regmap`): {stale}"


def _c_values(exprs: dict[str, str]) -> dict[str, int]:
    out = ensure(BUILD / "regmap")
    src = out / "print_map.c"
    body = "\n".join(f'    printf("{k} %lu\\n", (unsigned long)({v}));' for k, v in exprs.items())
    src.write_text('#include <stdio.h>\n#include "hg_fpga_regs.h"\nint main(void)\n{\n'
                   f"{body}\n    return 0;\n}}\n")
    exe = out / "print_map"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-Wconversion",
                    f"-I{FW_INCLUDE}", str(src), "-o", str(exe)], check=True)
    text = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout
    return {k: int(v) for k, v in (ln.split() for ln in text.splitlines())}


def test_firmware_header_matches_rdl() -> None:
    rm = regmap.load()
    regs = rm.by_name()
    exprs = {f"HG_REG_{n}": f"HG_REG_{n}" for n in
             ("ID", "CTRL", "STATUS", "SEQ", "TICK_DIV", "IRQ", "WDOG", "SCRATCH", "WDOG_TIMEOUT",
              "CLK_KHZ")}
    fw_ax = {"POS": "POS", "VEL": "VEL", "IDX_POS": "IDX_POS", "FAULT_CNT": "COUNTS",
             "POS_HOMED": "POS_HOMED", "FLAGS": "FLAGS", "TORQUE": "TORQUE", "OFFSET": "OFFSET",
             "MODE": "MODE", "TQ_LIMIT": "TQ_LIMIT", "CAL_CTRL": "CAL_CTRL",
             "CAL_STAT": "CAL_STAT", "CAL_OFS": "CAL_OFS", "CAL_GAIN": "CAL_GAIN",
             "CAL_PHASE": "CAL_PHASE"}
    for i in range(3):
        for fw, rdl in fw_ax.items():
            exprs[f"AXIS[{i}].{rdl}"] = f"HG_REG_AXIS({i}, HG_AX_{fw})"
    bits = {"CTRL.GLOBAL_EN": "HG_CTRL_GLOBAL_EN", "CTRL.FAULT_CLR": "HG_CTRL_FAULT_CLR",
            "CTRL.SNAP": "HG_CTRL_SNAP", "STATUS.WDOG": "HG_STAT_WDOG",
            "STATUS.FAULT": "HG_STAT_FAULT_ALL", "IRQ.TICK": "HG_IRQ_TICK",
            "STATUS.PROTO_ERR": "HG_STAT_PROTO_ERR"}
    for i in range(3):
        bits[f"CTRL.AXIS_EN/{i}"] = f"HG_CTRL_AXIS_EN({i})"
        bits[f"CTRL.HOME_ARM{i}"] = f"HG_CTRL_HOME_ARM_AXIS({i})"
        bits[f"STATUS.HOMED/{i}"] = f"HG_STAT_HOMED({i})"
        bits[f"STATUS.INDEX/{i}"] = f"HG_STAT_INDEX({i})"
    got = _c_values({**exprs, **bits, "MAGIC": "HG_ID_MAGIC", "NREGS": "HG_NREGS"})
    for name in exprs:
        want = regs[name.removeprefix("HG_REG_")].word
        assert got[name] == want, f"{name}: header {got[name]:#x}, RDL {want:#x}"
    for name, _ in bits.items():
        reg, fld = name.split(".")
        fld, _, sub = fld.partition("/")
        f = regs[reg].field(fld)
        want = (1 << (f.lsb + int(sub))) if sub else f.mask
        assert got[name] == want, f"{name}: header {got[name]:#x}, RDL {want:#x}"
    assert got["MAGIC"] == regs["ID"].field("MAGIC").reset == 0x4847
    assert got["NREGS"] == 0x45   # the map spans 0x114 bytes = 69 words (HW_FAULT at 0x44)


def test_rdl_safety_defaults() -> None:
    """What the safety rules need from the map itself: no torque after reset (every axis OFF,
    limit 0, drive disabled), a 1 kHz tick by default with a 10 kHz ceiling, a watchdog."""
    for clk in (48_000_000, 50_000_000):
        rm = regmap.load(clk)
        r = rm.by_name()
        assert rm.unmapped_read == 0xDEADBEEF
        assert r["CTRL"].reset == 0
        for i in range(3):
            assert r[f"AXIS[{i}].MODE"].reset == 3 and r[f"AXIS[{i}].TQ_LIMIT"].reset == 0
            assert r[f"AXIS[{i}].TORQUE"].reset == 0
        div = r["TICK_DIV"].field("DIV")
        assert div.reset * 1000 == clk and div.range_min * 10_000 == clk
        assert r["WDOG_TIMEOUT"].field("US").range_max <= 1_000_000
        words = [x.word for x in rm.registers]
        assert len(words) == len(set(words)) and max(words) < 1 << regmap.BUS_ADDR_BITS
