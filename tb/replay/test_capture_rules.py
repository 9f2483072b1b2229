"""The replay commands' one input reader (hapgate.base.capture), tried as a new user would: every
case gets a clear error naming FILE:LINE(:COL), exit 2 and nothing written, and the same rule for
`replay interp` and `replay commutation` (issue 14's list, one test per case)."""

from __future__ import annotations

import resource
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hapgate.base import capture

# per command: a valid header and a valid data line; the first cell is the one the cases spoil
COMMANDS = {
    "interp": ("a,b", "1,2"),
    "commutation": ("pos0,pos1,pos2,torque0,torque1,torque2", "0,0,0,1,2,3"),
}


def replay(cmd: str, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "hapgate.commands.cli", "replay", cmd,
                           "--engine", "model", *args], capture_output=True, text=True)


def body(cmd: str, bad_first_cell: bytes, before: int = 1) -> bytes:
    header, row = COMMANDS[cmd]
    rest = row.split(",", 1)[1]
    good = (row + "\n").encode() * before
    return header.encode() + b"\n" + good + bad_first_cell + b"," + rest.encode() + b"\n"


def expect_error(r: subprocess.CompletedProcess[str], where: str, words: str, out: Path) -> None:
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    assert where in r.stderr and words in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and "np.float64" not in r.stderr, r.stderr
    assert "np.str_" not in r.stderr, r.stderr
    assert r.stderr.startswith("error: ") and r.stderr.count("\n") == 1, r.stderr
    assert not out.exists()


CELL_CASES = [
    # (id, first cell of line 3, words in the message)
    ("non_utf8", b"\xff1", "not UTF-8"),
    ("huge_integer", b"99999999999999999999", "outside"),
    ("one_point_zero", b"1.0", "not an integer"),
    ("exponent", b"1e1", "not an integer"),
    ("hex", b"0x10", "not an integer"),
    ("double_sign", b"--1", "not an integer"),
    ("empty_cell", b" ", "empty cell"),
]


@pytest.mark.parametrize("cmd", COMMANDS)
@pytest.mark.parametrize("case, cell, words", CELL_CASES, ids=[c[0] for c in CELL_CASES])
def test_bad_cell(tmp_path: Path, cmd: str, case: str, cell: bytes, words: str) -> None:
    src = tmp_path / "cap.csv"
    src.write_bytes(body(cmd, cell))
    out = tmp_path / "out.csv"
    r = replay(cmd, "--in", str(src), "--out", str(out))
    expect_error(r, "cap.csv:3:1:", words, out)


@pytest.mark.parametrize("cell", ["nan", "inf", "-Infinity"])
def test_non_finite_float_cell(tmp_path: Path, cell: str) -> None:
    src = tmp_path / "cap.csv"
    src.write_text(f"a,b,truth_counts\n1,2,0.5\n1,2,{cell}\n")
    out = tmp_path / "out.csv"
    r = replay("interp", "--in", str(src), "--out", str(out))
    expect_error(r, "cap.csv:3:5:", f"'{cell}' is not a finite number", out)


@pytest.mark.parametrize("cmd", COMMANDS)
def test_cell_column_is_named(tmp_path: Path, cmd: str) -> None:
    header, row = COMMANDS[cmd]
    cells = row.split(",")
    cells[1] = "12x"
    src = tmp_path / "cap.csv"
    src.write_text(f"{header}\n{row}\n{','.join(cells)}\n")
    out = tmp_path / "out.csv"
    r = replay(cmd, "--in", str(src), "--out", str(out))
    expect_error(r, f"cap.csv:3:{len(cells[0]) + 2}:", f"column {header.split(',')[1]!r}", out)


@pytest.mark.parametrize("cmd", COMMANDS)
def test_blank_lines_keep_the_file_line_numbers(tmp_path: Path, cmd: str) -> None:
    header, row = COMMANDS[cmd]
    src = tmp_path / "cap.csv"
    src.write_text(f"\n{header}\n\n{row}\n   \n\n{row.replace('1', 'x', 1)}\n")
    out = tmp_path / "out.csv"
    r = replay(cmd, "--in", str(src), "--out", str(out))
    expect_error(r, "cap.csv:7:", "not an integer", out)


@pytest.mark.parametrize("cmd", COMMANDS)
def test_trailing_blank_lines_and_crlf_are_accepted(tmp_path: Path, cmd: str) -> None:
    header, row = COMMANDS[cmd]
    plain, crlf = tmp_path / "plain.csv", tmp_path / "crlf.csv"
    plain.write_text(f"{header}\n{row}\n{row}\n")
    crlf.write_bytes(f"\ufeff{header}\r\n{row}\r\n{row}\r\n\r\n\n  \n".encode())
    outs = []
    for src in (plain, crlf):
        out = tmp_path / (src.stem + "_out.csv")
        r = replay(cmd, "--in", str(src), "--out", str(out))
        assert r.returncode == 0, r.stderr
        outs.append(out.read_text())
    assert outs[0] == outs[1] and len(outs[0].splitlines()) == 3


@pytest.mark.parametrize("cmd", COMMANDS)
def test_duplicate_column(tmp_path: Path, cmd: str) -> None:
    header, row = COMMANDS[cmd]
    first = header.split(",")[0]
    src = tmp_path / "cap.csv"
    src.write_text(f"{header},{first.upper()}\n{row},5\n")
    out = tmp_path / "out.csv"
    expect_error(replay(cmd, "--in", str(src), "--out", str(out)), "cap.csv:1:",
                 f"duplicate column(s) in the header: {first}", out)


@pytest.mark.parametrize("cmd", COMMANDS)
def test_structure_errors(tmp_path: Path, cmd: str) -> None:
    header, row = COMMANDS[cmd]
    out = tmp_path / "out.csv"
    cases = [("", "cap.csv:1:", "empty file"), (f"{header}\n\n", "cap.csv:3:", "no data lines"),
             (f"{header}\n{row}\n{row},7\n", "cap.csv:3:", "fields, the header has"),
             ("x,y\n1,2\n", "cap.csv:1:", "header lacks"),
             (f"{header},\n{row},1\n", "cap.csv:1:", "empty column name")]
    for text, where, words in cases:
        src = tmp_path / "cap.csv"
        src.write_text(text)
        expect_error(replay(cmd, "--in", str(src), "--out", str(out)), where, words, out)


@pytest.mark.parametrize("cmd", COMMANDS)
def test_over_long_line_is_rejected_with_bounded_memory(tmp_path: Path, cmd: str) -> None:
    """A single 64 MiB line: rejected at its line, and the process never holds it (its peak
    memory grows by far less than the line)."""
    header, row = COMMANDS[cmd]
    src = tmp_path / "cap.csv"
    with open(src, "wb") as f:
        f.write(f"{header}\n{row}\n1".encode())
        f.write(b"1" * (64 << 20))
        f.write(b",2\n")
    out = tmp_path / "out.csv"
    probe = ("import resource, sys\nfrom hapgate.commands.cli import main\n"
             f"rc = main(['replay', {cmd!r}, '--engine', 'model', '--in', {str(src)!r}, "
             f"'--out', {str(out)!r}])\n"
             "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)\nsys.exit(rc)\n")
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    expect_error(r, "cap.csv:3:", f"line longer than {capture.MAX_LINE_BYTES} bytes", out)
    peak_kib = int(r.stdout.split()[-1])
    base = subprocess.run([sys.executable, "-c", "import resource\nimport hapgate.commands.cli"
                           "\nprint(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)"],
                          capture_output=True, text=True)
    grown = peak_kib - int(base.stdout.split()[-1])
    print(f"peak memory {peak_kib} KiB, {grown} KiB above an idle import")
    assert grown < 24 * 1024            # well under the 64 MiB line
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss > 0


@pytest.mark.parametrize("cmd", COMMANDS)
def test_out_rules(tmp_path: Path, cmd: str) -> None:
    header, row = COMMANDS[cmd]
    src = tmp_path / "cap.csv"
    src.write_text(f"{header}\n{row}\n")
    before = src.read_bytes()
    missing = tmp_path / "no_such_dir" / "out.csv"
    expect_error(replay(cmd, "--in", str(src), "--out", str(missing)), "no_such_dir",
                 "does not exist", missing)
    assert not missing.parent.exists()                       # not created either
    folder = tmp_path / "d"
    folder.mkdir()
    r = replay(cmd, "--in", str(src), "--out", str(folder))
    assert r.returncode == 2 and "is a folder" in r.stderr and not any(folder.iterdir())
    r = replay(cmd, "--in", str(src), "--out", "/proc/hapgate_out.csv")
    expect_error(r, "/proc", "not writable", Path("/proc/hapgate_out.csv"))
    r = replay(cmd, "--in", str(src), "--out", str(tmp_path / "." / "cap.csv"))
    assert r.returncode == 2 and "the input file" in r.stderr, r.stderr
    assert src.read_bytes() == before                         # the capture is untouched
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap.csv", "d"]   # no temp files


@pytest.mark.parametrize("cmd", COMMANDS)
@pytest.mark.parametrize("clk", ["0", "-5", "1", "1500000999"])
def test_clock_checked_before_any_work(tmp_path: Path, cmd: str, clk: str) -> None:
    header, row = COMMANDS[cmd]
    src = tmp_path / "cap.csv"
    src.write_text(f"{header}\n{row}\n")
    out = tmp_path / "out.csv"
    expect_error(replay(cmd, "--in", str(src), "--out", str(out), "--clk-hz", clk),
                 f"--clk-hz {clk}:", "must be", out)


def test_commutation_clock_the_rtl_refuses(tmp_path: Path) -> None:
    """1 MHz passes the basic rule but not the DAC schedule (skew of 2 clocks < strobe + 3), and
    200 MHz overflows the scheduler's 32-bit clock arithmetic: refused up front with the reason,
    by both engines, the RTL engine without building anything."""
    header, row = COMMANDS["commutation"]
    src = tmp_path / "cap.csv"
    src.write_text(f"{header}\n{row}\n")
    out = tmp_path / "out.csv"
    for clk, words in (("1000000", "too slow for the DAC schedule"),
                       ("200000000", "too fast for the DAC scheduler")):
        for engine in ("model", "rtl"):
            r = subprocess.run([sys.executable, "-m", "hapgate.commands.cli", "replay",
                                "commutation", "--engine", engine, "--in", str(src), "--out",
                                str(out), "--clk-hz", clk], capture_output=True, text=True)
            expect_error(r, f"--clk-hz {clk}:", words, out)


def test_unknown_columns_are_named(tmp_path: Path) -> None:
    for cmd, (header, row) in COMMANDS.items():
        src = tmp_path / f"{cmd}.csv"
        src.write_text(f"{header},Note\n{row},hello\n")
        r = replay(cmd, "--in", str(src), "--out", str(tmp_path / f"{cmd}_out.csv"))
        assert r.returncode == 0 and "ignored column(s) note" in r.stderr, r.stderr


def test_reader_chunk_boundaries() -> None:
    """The same table whatever the chunk size (lines cut at every possible place)."""
    import tempfile

    rng = np.random.default_rng(3)
    a = rng.integers(-128, 128, 300)
    text = "a,b,truth_counts\n" + "".join(
        f"{x},{-x}{' ' * (i % 3)},{x * 0.5}\n" + ("\n" if i % 17 == 0 else "")
        for i, x in enumerate(a.tolist()))
    cols = (capture.Column("a", lo=-128, hi=127), capture.Column("b", lo=-127, hi=128),
            capture.Column("truth_counts", kind="float"))
    with tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False) as f:
        f.write(text)
    path = Path(f.name)
    try:
        ref = capture.read_table(path, cols)
        assert np.array_equal(ref.columns["a"], a) and np.array_equal(ref.columns["b"], -a)
        assert np.allclose(ref.columns["truth_counts"], a * 0.5)
        for chunk in (7, 8, 13, 64, 1000):
            t = capture.read_table(path, cols, max_line_bytes=40, chunk_bytes=chunk)
            assert np.array_equal(t.lines, ref.lines)
            for c in ("a", "b", "truth_counts"):
                assert np.array_equal(t.columns[c], ref.columns[c])
    finally:
        path.unlink()
