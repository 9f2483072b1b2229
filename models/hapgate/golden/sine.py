"""The commutation sine ROM: one generator for the RTL's table, the bit-exact model and the truth.

Quarter-wave table of N = 2**ADDR_BITS entries (default 256):
entry i = round(FS*sin((i+1/2)*90deg/N)).
The half-step offset makes mirroring exact, so angle code k of a 4N-code cycle stands for
(k + 1/2) * 360deg / (4N) and unfolding needs no special case at 90deg or 270deg:

    quadrant q = k >> ADDR_BITS, i = k mod N
    q = 0: +T[i]       q = 1: +T[N-1-i]       q = 2: -T[i]       q = 3: -T[N-1-i]

Accuracy budget (error against FS*sin of the code's angle): at most 0.5 LSB, from rounding alone.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np

from ..base.block import Block, Params
from ..base.tables import TableFile, write_hex

ERROR_BUDGET_LSB = 0.5


@dataclass(frozen=True)
class SineRomConfig:
    addr_bits: int = 8    # quarter-wave entries = 2**addr_bits (256 default)
    fs: int = 8191        # full scale: the table's value at sin = 1 (14-bit bipolar DAC: +-8191)

    @property
    def entries(self) -> int:
        return 1 << self.addr_bits

    @property
    def angle_bits(self) -> int:
        return self.addr_bits + 2

    @property
    def mag_bits(self) -> int:
        """Unsigned width of one table entry."""
        return max(1, int(self.fs).bit_length())

    @property
    def out_bits(self) -> int:
        """Signed width of the unfolded output."""
        return self.mag_bits + 1

    @property
    def name(self) -> str:
        return f"sine_q{self.entries}_fs{self.fs}"


def quarter_table(cfg: SineRomConfig = SineRomConfig()) -> np.ndarray:
    """The ROM contents (unsigned magnitudes)."""
    i = np.arange(cfg.entries, dtype=np.float64)
    return np.floor(cfg.fs * np.sin((i + 0.5) * (np.pi / 2) / cfg.entries) + 0.5).astype(np.int64)


def write_rom(cfg: SineRomConfig = SineRomConfig(), directory: Path | None = None) -> Path:
    """Generate the ROM file for the RTL (build/gen/<name>.hex) and return its path."""
    return write_hex(cfg.name, quarter_table(cfg), cfg.mag_bits, directory)


def unfold(codes: np.ndarray, table: np.ndarray, addr_bits: int) -> np.ndarray:
    """Bit-exact model of the RTL's quarter-wave unfolding (vectorised over angle codes)."""
    k = np.asarray(codes, dtype=np.int64) & ((4 << addr_bits) - 1)
    n = 1 << addr_bits
    q = k >> addr_bits
    i = k & (n - 1)
    mag = table[np.where(q & 1, n - 1 - i, i)]
    return np.where(q & 2, -mag, mag)


def sine_model(codes: np.ndarray, cfg: SineRomConfig = SineRomConfig()) -> np.ndarray:
    """Integer output of the sine LUT for each angle code: what the RTL must produce."""
    return unfold(codes, quarter_table(cfg), cfg.addr_bits)


def sine_truth(codes: np.ndarray, cfg: SineRomConfig = SineRomConfig()) -> np.ndarray:
    """Float truth: FS * sin of the angle each code stands for, (k + 1/2) * 2pi / (4N)."""
    k = np.asarray(codes, dtype=np.float64)
    return cfg.fs * np.sin((k + 0.5) * 2 * np.pi / (4 * cfg.entries))


def error_vs_truth(outputs: np.ndarray, cfg: SineRomConfig = SineRomConfig()) -> np.ndarray:
    """Signed error (LSB) of a full-cycle output array (index = angle code) against the truth."""
    codes = np.arange(4 * cfg.entries)
    return np.asarray(outputs, dtype=np.float64) - sine_truth(codes, cfg)


def rom_file(cfg: SineRomConfig = SineRomConfig()) -> TableFile:
    """The ROM file build/gen/<name>.hex, written by the build (base.tables.write_tables)."""
    return TableFile.of(cfg.name, partial(quarter_table, cfg), cfg.mag_bits)


def rtl_params(cfg: SineRomConfig = SineRomConfig()) -> Params:
    """Parameters of rtl/commutation/sine_lut.v for `cfg` (pure: the ROM is a TableFile)."""
    return {"ADDR_BITS": cfg.addr_bits, "MAG_BITS": cfg.mag_bits, "LUT_FILE": rom_file(cfg)}


def blocks() -> list[Block]:
    return [Block(name="sine_lut", top="sine_lut", sources=("commutation/sine_lut.v",),
                  params=rtl_params,
                  doc="256-entry quarter-wave sine ROM, unfolded over 1024 angle codes")]
