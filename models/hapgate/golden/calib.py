"""The device's calibration (issue 26): what bring-up finds per axis, as a `calibration.toml`
file, the plant's own values ("truth"), and the words the firmware takes (dsp-fw/include/hg_calib.h
`hg_axis_calib_t`, sent with SET_CALIB). The file format is in dsp-fw/README.md, "Calibration".

The file states each value in the convention of the plant's `[plant]` keys of the same name
(tb/native/device/README.md, "Bring-up errors"); `AxisCalib.words()` turns them into the
firmware's: the FPGA `OFFSET` code (the field's angle at the home, 1/1024 electrical cycle) from
the offset, the phase order and the encoder direction:

    OFFSET = sigma * c - (60 deg if swapped) - d * sigma * pole_pairs * 256 counts * 360 / 2^20

with sigma = -1 for swapped phases (they turn the field backwards: winding 0 sees the field at
-te - 60 deg) and d the encoder direction (a reversed encoder's count is 256 counts, a quarter
line, past the index latch at the index: its A and B are swapped, the angle 90 deg - phi).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

COUNTS_PER_REV = 1 << 20       # dsp-fw HG_ENC_COUNTS_PER_REV
OFFSET_CODES = 1024            # the FPGA OFFSET register: 1/1024 electrical cycle
QUARTER_LINE = 256             # counts: the swapped-A/B encoder's count at the index latch
FPGA_POLE_PAIRS = 2            # dsp-fw HG_FPGA_POLE_PAIRS (rtl/top/hapgate_top.v POLE_PAIRS)
CAL_HOMED, CAL_ALIGNED, CAL_DIR_SEEN = 1, 2, 4   # hg_calib.h HG_CAL_*
KEYS = ("index_to_zero_counts", "comm_offset_elec_deg", "phases_swapped", "encoder_dir",
        "pole_pairs", "dir_confirmed")
REQUIRED = KEYS[:5]


class CalibError(ValueError):
    """A malformed calibration file (the message names the file and the key)."""


@dataclass(frozen=True)
class AxisCalib:
    """One axis's calibration in the plant's conventions (the file's keys)."""
    index_to_zero_counts: int = 0      # counts from the index latch to q = 0
    comm_offset_elec_deg: float = 0.0  # the index-to-winding offset, electrical degrees
    phases_swapped: bool = False       # amplifier inputs a and b swapped
    encoder_dir: int = 1               # +1 / -1: counts against the joint angle
    pole_pairs: int = FPGA_POLE_PAIRS
    dir_confirmed: bool = False        # the direction was seen in a guided move
    homed: bool = True                 # index_to_zero_counts is known
    aligned: bool = True               # offset, phase order and pole pairs are known

    def offset_code(self) -> int:
        """The FPGA OFFSET register (module docstring)."""
        sigma = -1.0 if self.phases_swapped else 1.0
        shift = QUARTER_LINE if self.encoder_dir < 0 else 0
        deg = (sigma * self.comm_offset_elec_deg - (60.0 if self.phases_swapped else 0.0)
               - self.encoder_dir * sigma * self.pole_pairs * shift * 360.0 / COUNTS_PER_REV)
        return round(deg / 360.0 * OFFSET_CODES) % OFFSET_CODES

    def words(self) -> tuple[int, int, int, int, int, int]:
        """hg_axis_calib_t: flags, enc_dir, phases_swapped, pole_pairs, index_to_zero,
        comm_offset."""
        flags = ((CAL_HOMED if self.homed else 0) | (CAL_ALIGNED if self.aligned else 0)
                 | (CAL_DIR_SEEN if self.dir_confirmed else 0))
        return (flags, int(self.encoder_dir), int(self.phases_swapped), int(self.pole_pairs),
                int(self.index_to_zero_counts), self.offset_code() if self.aligned else 0)


def from_words(words: Any) -> AxisCalib:
    """The inverse of AxisCalib.words() (the offset to the OFFSET register's 360/1024 deg
    electrical, in -180..180)."""
    flags, d, sw, pp, i2z, code = (int(w) for w in words)
    sigma = -1.0 if sw else 1.0
    shift = QUARTER_LINE if d < 0 else 0
    deg = code * 360.0 / OFFSET_CODES
    c = sigma * (deg + (60.0 if sw else 0.0) + d * sigma * pp * shift * 360.0 / COUNTS_PER_REV)
    c = (c + 180.0) % 360.0 - 180.0
    return AxisCalib(i2z, c, bool(sw), d, pp, bool(flags & CAL_DIR_SEEN),
                     bool(flags & CAL_HOMED), bool(flags & CAL_ALIGNED))


NONE = (AxisCalib(homed=False, aligned=False),) * 3   # "none": the firmware starts uncalibrated


def _lround(x: float) -> int:
    """C's lround: half away from zero."""
    return int(math.copysign(math.floor(abs(x) + 0.5), x))


def truth(q_index_rad: Any, comm_offset_elec_deg: Any, phases_swapped: Any, encoder_dir: Any,
          pole_pairs: int) -> tuple[AxisCalib, AxisCalib, AxisCalib]:
    """The plant's own calibration ("truth"): index_to_zero from the index's joint angle (the
    same arithmetic as the harness had, lround(-q_index / 2 pi * 2^20), for a forward encoder;
    a reversed one counts the other way from 256 counts past the latch)."""
    out = []
    for i in range(3):
        qi = float(q_index_rad[i])
        d = int(encoder_dir[i])
        i2z = (_lround(-qi / (2 * math.pi) * COUNTS_PER_REV) if d > 0
               else _lround(qi / (2 * math.pi) * COUNTS_PER_REV) + QUARTER_LINE)
        out.append(AxisCalib(i2z, float(comm_offset_elec_deg[i]), bool(phases_swapped[i]), d,
                             int(pole_pairs)))
    return out[0], out[1], out[2]


def loads(text: str, source: str = "<calibration>") -> tuple[AxisCalib, AxisCalib, AxisCalib]:
    """Parse a calibration.toml: three [[axis]] tables in axis order, each with the REQUIRED
    keys (and optionally dir_confirmed). Raises CalibError naming the source and the key."""
    import tomllib  # here: `hapgate` itself still starts on Python 3.10

    try:
        d = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CalibError(f"{source}: invalid TOML: {exc}") from None
    for k in d:
        if k != "axis":
            raise CalibError(f"{source}: {k}: unknown key (known: axis)")
    axes = d.get("axis")
    if not isinstance(axes, list) or len(axes) != 3:
        raise CalibError(f"{source}: axis: needs exactly three [[axis]] tables (axes 0, 1, 2)")
    out = []
    for i, a in enumerate(axes):
        key = f"axis[{i}]"
        for k in a:
            if k not in KEYS:
                raise CalibError(f"{source}: {key}.{k}: unknown key (known: {', '.join(KEYS)})")
        for k in REQUIRED:
            if k not in a:
                raise CalibError(f"{source}: {key}.{k}: missing")

        def integer(k: str, ok: Any, rule: str, a: dict = a, key: str = key) -> int:
            v = a[k]
            if isinstance(v, bool) or not isinstance(v, int):
                raise CalibError(f"{source}: {key}.{k}: must be an integer, got {v!r}")
            if not ok(v):
                raise CalibError(f"{source}: {key}.{k}: {v} out of range: {rule}")
            return v

        def boolean(k: str, a: dict = a, key: str = key) -> bool:
            v = a.get(k, False)
            if not isinstance(v, bool):
                raise CalibError(f"{source}: {key}.{k}: must be true or false, got {v!r}")
            return v

        c = a["comm_offset_elec_deg"]
        if isinstance(c, bool) or not isinstance(c, int | float) or not math.isfinite(c) \
                or abs(c) > 360:
            raise CalibError(f"{source}: {key}.comm_offset_elec_deg: must be a number in "
                             f"-360..360, got {c!r}")
        out.append(AxisCalib(
            index_to_zero_counts=integer("index_to_zero_counts", lambda v: -2**31 <= v < 2**31,
                                         "a signed 32-bit count"),
            comm_offset_elec_deg=float(c),
            phases_swapped=boolean("phases_swapped"),
            encoder_dir=integer("encoder_dir", lambda v: v in (1, -1), "+1 or -1"),
            pole_pairs=integer("pole_pairs", lambda v: 1 <= v <= 255, "1..255"),
            dir_confirmed=boolean("dir_confirmed")))
    return out[0], out[1], out[2]


def load(path: str | Path) -> tuple[AxisCalib, AxisCalib, AxisCalib]:
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise CalibError(f"{path}: cannot read: {exc}") from None
    return loads(text, str(path))


def dumps(axes: Any) -> str:
    """A calibration.toml for three AxisCalib (what bring-up writes)."""
    lines = ["# hapgate calibration (format: dsp-fw/README.md, \"Calibration\")"]
    for a in axes:
        lines += ["", "[[axis]]", f"index_to_zero_counts = {int(a.index_to_zero_counts)}",
                  f"comm_offset_elec_deg = {float(a.comm_offset_elec_deg)!r}",
                  f"phases_swapped = {'true' if a.phases_swapped else 'false'}",
                  f"encoder_dir = {int(a.encoder_dir)}", f"pole_pairs = {int(a.pole_pairs)}",
                  f"dir_confirmed = {'true' if a.dir_confirmed else 'false'}"]
    return "\n".join(lines) + "\n"
