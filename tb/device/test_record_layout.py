"""The harnesses' record layouts are written twice, as C++ structs (tb/native/device/
harness_common.h: FrameRec, TickRec, LoadRec) and as numpy dtypes (hapgate.device.harness:
FRAME_DT, TICK_DT, LOAD_DT) that read the files those structs are written to. This test is the
one place they are held together: the C++ compiler prints every field's offset, size and element
type (tb/native/device/record_layout.cpp), and each must equal the dtype's, field for field, in
order, with the same total size."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest
from hapgate.base.paths import ROOT
from hapgate.device import harness

PROBE = ROOT / "tb" / "native" / "device" / "record_layout.cpp"
DTYPES = {"FrameRec": harness.FRAME_DT, "TickRec": harness.TICK_DT, "LoadRec": harness.LOAD_DT}


@pytest.fixture(scope="module")
def cxx_layout(tmp_path_factory) -> dict[str, list[tuple[str, int, int, str]]]:
    exe = tmp_path_factory.mktemp("layout") / "record_layout"
    subprocess.run(["g++", "-std=c++17", "-Wall", "-Wextra", "-Werror",
                    f"-I{PROBE.parent}", f"-I{ROOT / 'dsp-fw' / 'include'}", str(PROBE),
                    "-o", str(exe)], check=True)
    out: dict[str, list[tuple[str, int, int, str]]] = {}
    for line in subprocess.run([str(exe)], check=True, capture_output=True,
                               text=True).stdout.splitlines():
        rec, field, off, size, kind = line.split()
        out.setdefault(rec, []).append((field, int(off), int(size), kind))
    return out


def numpy_layout(dt: np.dtype) -> list[tuple[str, int, int, str]]:
    rows = []
    for name in dt.names:
        sub, off = dt.fields[name][:2]
        base = sub.base
        rows.append((name, off, sub.itemsize, f"{base.kind}{base.itemsize}"))
    rows.append((".", 0, dt.itemsize, "-"))
    return rows


@pytest.mark.parametrize("rec", sorted(DTYPES))
def test_record_layout_matches(cxx_layout, rec):
    assert cxx_layout[rec] == numpy_layout(DTYPES[rec])


def test_a_moved_field_is_seen(cxx_layout):
    """The comparison has power: the same dtype with two fields swapped, or one widened, differs."""
    dt = harness.LOAD_DT
    swapped = np.dtype([("edge", "<i8"), ("code", "<i4"), ("ch", "<i4")])
    widened = np.dtype([("edge", "<i8"), ("ch", "<i8"), ("code", "<i4")])
    assert cxx_layout["LoadRec"] == numpy_layout(dt)
    assert cxx_layout["LoadRec"] != numpy_layout(swapped)
    assert cxx_layout["LoadRec"] != numpy_layout(widened)


def test_fault_kinds_match(cxx_layout):
    """The fault kinds are named once in C++ (harness_common.h kFaultKinds); the run
    configuration names them, so Python's list of the kinds the harnesses simulate must be the
    same names, each found by the parser's look-up, with distinct values."""
    rows = cxx_layout["FaultKind"]
    assert tuple(r[0] for r in rows) == harness.HARNESS_FAULTS
    assert all(r[2] == 1 for r in rows)                    # fault_kind_of finds each name
    assert len({r[1] for r in rows}) == len(rows)
