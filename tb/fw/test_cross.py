"""dsp-fw's freestanding build (issue 26): every dsp-fw/src/*.c with the stub board
(dsp-fw/board/) for a Cortex-M4F, -ffreestanding, linked against its HAL and libm only, with
Debian's arm-none-eabi-gcc (tb/debian-deps.sh). Its text/data/bss sizes are printed, not
asserted."""

from __future__ import annotations

import fcntl
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FW = ROOT / "dsp-fw"
BUILD = ROOT / "build" / "dsp-fw"
ELF = BUILD / "cross" / "hapgate-fw.elf"
MAP = BUILD / "cross" / "hapgate-fw.map"


def _make_cross() -> subprocess.CompletedProcess[str]:
    BUILD.mkdir(parents=True, exist_ok=True)
    with open(BUILD / ".lock", "w") as lock:   # the lock tb/fw/test_dsp_fw.py's make takes
        fcntl.flock(lock, fcntl.LOCK_EX)
        return subprocess.run(["make", "-s", "-C", str(FW), f"BUILD={BUILD}", "cross"],
                              check=False, capture_output=True, text=True, timeout=300)


def test_cross_build_links_against_its_hal_and_libm_only() -> None:
    r = _make_cross()
    assert r.returncode == 0, r.stdout + r.stderr
    # every firmware source is in the image (a bring-up module added later too)
    objs = set(re.findall(r"cross/src/(\w+)\.o", MAP.read_text()))
    assert objs == {p.stem for p in (FW / "src").glob("*.c")}
    # nothing left undefined
    nm = subprocess.run(["arm-none-eabi-nm", "-u", str(ELF)], check=True, capture_output=True,
                        text=True)
    assert nm.stdout.strip() == "", nm.stdout
    # the only libraries the linker took members from: libm and the compiler's libgcc
    libs = set(re.findall(r"/(lib\w+)\.a\(", MAP.read_text()))
    assert libs and libs <= {"libm", "libgcc"}, libs
    assert "libm" in libs                 # the trigonometry really comes from libm
    # a hard-float Cortex-M4 image
    hdr = subprocess.run(["arm-none-eabi-readelf", "-h", "-A", str(ELF)], check=True,
                         capture_output=True, text=True).stdout
    assert "ARM" in hdr and "Tag_ABI_VFP_args: VFP registers" in hdr, hdr
    assert re.search(r"Tag_CPU_name: \"?7E-M|Tag_CPU_arch: v7E-M", hdr), hdr
    size = subprocess.run(["arm-none-eabi-size", str(ELF)], check=True, capture_output=True,
                          text=True).stdout
    text, data, bss = (int(v) for v in size.splitlines()[1].split()[:3])
    print(f"\ndsp-fw cross build (Cortex-M4F, -Os): text {text} B, data {data} B, bss {bss} B")
