"""`hapgate mutants` (`make mutants`): mutation testing as a standing check.

The list lives in tb/mutants/mutants.toml: each mutant is a deliberate bug (text edits, applied
to the golden model AND the RTL together where both exist, so bit-exactness cannot see it) and
the tests that must catch it. Each mutant runs in its own scratch copy of the tracked tree under
build/mutants/<name>/tree, imported from there (PYTHONPATH=<copy>/models: the editable install
in .venv points at this checkout, and the copy's `hapgate.base.paths.ROOT` is the copy, so its
RTL, firmware and build directory are the copy's). A mutant is killed when its tests fail
(pytest exit 1); it survives when they pass; anything else (an edit that does not apply, a test
id that does not exist, a timeout) is an error. A baseline run of every listed test on an
unmutated copy must pass first, or no kill means anything. Exit 0 only if every mutant is killed.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from ..base.paths import BUILD, ROOT, TB
from ..base.report import table

LIST = TB / "mutants" / "mutants.toml"
WORK = BUILD / "mutants"
MUTANT_KEYS = {"name", "block", "what", "tests", "edit"}
EDIT_KEYS = {"file", "find", "replace", "count"}


class MutantListError(ValueError):
    """The mutant list is malformed (the message names the file and the key)."""


@dataclass(frozen=True)
class Edit:
    file: str
    find: str
    replace: str
    count: int = 1


@dataclass(frozen=True)
class Mutant:
    name: str
    block: str
    what: str
    tests: tuple[str, ...]
    edits: tuple[Edit, ...]


@dataclass
class Outcome:
    name: str
    block: str
    status: str              # killed | SURVIVED | ERROR
    seconds: float
    detail: str = ""
    failed: list[str] = field(default_factory=list)


def load(path: Path = LIST) -> list[Mutant]:
    import tomllib

    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise MutantListError(f"{path}: {exc}") from None
    extra = set(data) - {"mutant"}
    if extra:
        raise MutantListError(f"{path}: unknown top-level key(s) {', '.join(sorted(extra))}")
    out: list[Mutant] = []
    for i, m in enumerate(data.get("mutant", [])):
        where = f"{path}: mutant[{i}]"
        bad = set(m) - MUTANT_KEYS
        if bad:
            raise MutantListError(f"{where}: unknown key(s) {', '.join(sorted(bad))}")
        for key in ("name", "block", "what", "tests", "edit"):
            if key not in m:
                raise MutantListError(f"{where}: missing key {key!r}")
        name = m["name"]
        if not isinstance(name, str) or not re.fullmatch(r"[a-z0-9_]+", name):
            raise MutantListError(f"{where}: name must match [a-z0-9_]+")
        where = f"{path}: mutant {name!r}"
        if any(x.name == name for x in out):
            raise MutantListError(f"{where}: duplicate name")
        tests = m["tests"]
        if not (isinstance(tests, list) and tests and all(isinstance(t, str) for t in tests)):
            raise MutantListError(f"{where}: 'tests' must be a non-empty list of pytest ids")
        edits = []
        for j, e in enumerate(m["edit"]):
            bad = set(e) - EDIT_KEYS
            if bad:
                raise MutantListError(f"{where}: edit[{j}]: unknown key(s) "
                                      f"{', '.join(sorted(bad))}")
            for key in ("file", "find", "replace"):
                if not isinstance(e.get(key), str):
                    raise MutantListError(f"{where}: edit[{j}]: {key!r} must be a string")
            count = e.get("count", 1)
            if not isinstance(count, int) or count < 1:
                raise MutantListError(f"{where}: edit[{j}]: 'count' must be a positive integer")
            edits.append(Edit(e["file"], e["find"], e["replace"], count))
        if not edits:
            raise MutantListError(f"{where}: no edits")
        out.append(Mutant(name, str(m["block"]), str(m["what"]), tuple(tests), tuple(edits)))
    if not out:
        raise MutantListError(f"{path}: no [[mutant]] entries")
    return out


def copy_tree(dest: Path) -> None:
    """The tracked files of this checkout (as they are on disk) into dest."""
    if dest.exists():
        shutil.rmtree(dest)
    files = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True,
                           check=True).stdout.decode().split("\0")
    for rel in filter(None, files):
        src = ROOT / rel
        if not src.is_file():
            continue                       # deleted in the work tree
        dst = dest / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dst)


def apply_edits(tree: Path, edits: tuple[Edit, ...]) -> None:
    for e in edits:
        p = tree / e.file
        if not p.is_file():
            raise MutantListError(f"edit: no file {e.file}")
        text = p.read_text()
        n = text.count(e.find)
        if n != e.count:
            raise MutantListError(f"edit: {e.file}: {e.find!r} occurs {n} times, "
                                  f"expected {e.count}")
        p.write_text(text.replace(e.find, e.replace))


def _env(tree: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(tree / "models"),
                                         *filter(None, [env.get("PYTHONPATH")])])
    env.pop("PYTEST_XDIST_WORKER", None)
    return env


def _check_import(tree: Path) -> None:
    out = subprocess.run([sys.executable, "-c", "import hapgate, sys; print(hapgate.__file__)"],
                         cwd=tree, env=_env(tree), capture_output=True, text=True)
    got = Path(out.stdout.strip()).resolve()
    if tree.resolve() not in got.parents:
        raise RuntimeError(f"the scratch copy imports hapgate from {got}, not from {tree}")


def run_tests(tree: Path, tests: tuple[str, ...], log: Path, timeout_s: float
              ) -> tuple[int, list[str]]:
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist",
           "-x", *tests]
    try:
        out = subprocess.run(cmd, cwd=tree, env=_env(tree), capture_output=True, text=True,
                             timeout=timeout_s)
        text, rc = out.stdout + out.stderr, out.returncode
    except subprocess.TimeoutExpired as exc:
        text, rc = f"timeout after {timeout_s:.0f} s\n{exc.stdout or ''}", -1
    log.write_text(text)
    failed = re.findall(r"^(?:FAILED|ERROR) (\S+)", text, flags=re.M)
    return rc, failed


def run_one(m: Mutant | None, tests: tuple[str, ...], timeout_s: float, keep: bool) -> Outcome:
    name = m.name if m else "baseline"
    work = WORK / name
    work.mkdir(parents=True, exist_ok=True)
    tree = work / "tree"
    t0 = time.perf_counter()
    try:
        copy_tree(tree)
        if m:
            apply_edits(tree, m.edits)
        _check_import(tree)
        rc, failed = run_tests(tree, tests, work / "pytest.log", timeout_s)
    except (MutantListError, RuntimeError, OSError, subprocess.CalledProcessError) as exc:
        return Outcome(name, m.block if m else "-", "ERROR", time.perf_counter() - t0, str(exc))
    finally:
        if not keep and tree.exists():
            shutil.rmtree(tree, ignore_errors=True)
    secs = time.perf_counter() - t0
    block = m.block if m else "-"
    log = work / "pytest.log"
    if m is None:
        status = "passed" if rc == 0 else "ERROR"
        return Outcome(name, block, status, secs, f"exit {rc}; log {log}", failed)
    if rc == 1:
        return Outcome(name, block, "killed", secs, "", failed)
    if rc == 0:
        return Outcome(name, block, "SURVIVED", secs, f"log {log}")
    return Outcome(name, block, "ERROR", secs, f"pytest exit {rc}; log {log}", failed)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--list", type=Path, default=LIST, help="the mutant list (TOML)")
    p.add_argument("--only", nargs="+", metavar="NAME", help="run only these mutants")
    p.add_argument("--jobs", type=int, default=1, help="mutants run at once (default 1)")
    p.add_argument("--timeout", type=float, default=1200.0, help="seconds per mutant")
    p.add_argument("--no-baseline", action="store_true",
                   help="skip the unmutated run of every listed test")
    p.add_argument("--keep", action="store_true", help="keep the scratch copies")


def main(args: argparse.Namespace) -> int:
    try:
        mutants = load(args.list)
    except MutantListError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.only:
        unknown = set(args.only) - {m.name for m in mutants}
        if unknown:
            print(f"error: unknown mutant(s) {', '.join(sorted(unknown))}", file=sys.stderr)
            return 2
        mutants = [m for m in mutants if m.name in args.only]
    if args.jobs < 1 or args.timeout <= 0:
        print("error: --jobs must be >= 1 and --timeout > 0", file=sys.stderr)
        return 2
    t_all = time.perf_counter()
    rows = []
    if not args.no_baseline:
        union = tuple(dict.fromkeys(t for m in mutants for t in m.tests))
        print(f"baseline: {len(union)} test ids on an unmutated copy ...", flush=True)
        base = run_one(None, union, args.timeout * 2, args.keep)
        print(f"baseline: {base.status} in {base.seconds:.0f} s", flush=True)
        if base.status != "passed":
            print(f"error: the listed tests fail without any mutant ({base.detail}): "
                  f"{', '.join(base.failed[:5])}", file=sys.stderr)
            return 1
    print(f"{len(mutants)} mutants, {args.jobs} at a time", flush=True)

    def job(m: Mutant) -> Outcome:
        o = run_one(m, m.tests, args.timeout, args.keep)
        print(f"  {m.name}: {o.status} ({o.seconds:.0f} s)", flush=True)
        return o

    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        outcomes = list(pool.map(job, mutants))
    for m, o in zip(mutants, outcomes):
        by = o.failed[0] if o.failed else o.detail
        rows.append([m.name, m.block, o.status, f"{o.seconds:.1f}", by])
    print(table(["mutant", "block", "result", "seconds", "killed by (first failing test)"],
                rows))
    killed = sum(o.status == "killed" for o in outcomes)
    print(f"{killed} of {len(outcomes)} killed in {time.perf_counter() - t_all:.0f} s "
          f"(logs: {WORK}/<mutant>/pytest.log)")
    return 0 if killed == len(outcomes) else 1
