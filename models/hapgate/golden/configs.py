"""The named configurations of the gateware, read from models/hapgate/configs.toml: the one
place parameter sets are written (docs/configs.md).

A configuration is a flat, frozen `Config`: every key present (what its table leaves out is the
design's default, taken from the golden models' dataclasses at load), checked once by
`problems()`, and mapped onto the golden model (`top()`, a `TopConfig`) and the RTL
(`rtl_params()`). Where the RTL's booleans depend on each other the registry has one enum
instead: `angle` (ANGLE, HARM, COARSE), `velocity` (VEL_OBS, VEL_OBS_SEL) and `fit` (SERIAL_MUL,
SQ_RAM, HOLD_C, LATCH_RAM), so "HARM without ANGLE" cannot be written.

    cfg = configs.get("hires")                      # a named configuration
    point = cfg.replace(clk_hz=50_000_000)          # a sweep point of it (checked again)
    sim.run_cocotb(block, "verilator", ..., params=point.rtl_params())
"""

from __future__ import annotations

import json
import re
from dataclasses import asdict, dataclass, fields, replace
from functools import cache
from pathlib import Path

import tomllib

from ..base.block import Block, Params
from .commutation import CommutationConfig
from .interpcfg import InterpConfig
from .sine import SineRomConfig
from .top import SOURCES, TopConfig

REGISTRY = Path(__file__).resolve().parents[1] / "configs.toml"

# enum value -> what it sets (registry vocabulary -> the golden models' booleans / RTL parameters)
ANGLES = {   # the interpolator's angle stage
    "arcsine": {"ratio": False, "harm": False, "coarse": False},     # the paper's arcsine table
    "quadrature": {"ratio": False, "harm": False, "coarse": True},   # fine angle zeroed (COARSE)
    "ratio": {"ratio": True, "harm": False, "coarse": False},        # ANGLE = 1
    "ratio_harm": {"ratio": True, "harm": True, "coarse": False},    # ANGLE = 1, HARM = 1
}
VELOCITIES = {   # what VEL reports
    "fir": {"vel_obs": False, "vel_obs_sel": False},           # the window FIR only
    "fir_observer": {"vel_obs": True, "vel_obs_sel": False},   # observer built, FIR at reset
    "observer": {"vel_obs": True, "vel_obs_sel": True},        # observer built and selected
}
FITS = {   # resource trade-offs, each bit-identical at the pins
    "dsp": {"SERIAL_MUL": 0, "SQ_RAM": 0, "HOLD_C": 0, "LATCH_RAM": 0},
    "lut": {"SERIAL_MUL": 1, "SQ_RAM": 1, "HOLD_C": 1, "LATCH_RAM": 1},   # no DSP blocks
}
SEC_PARAMS = ("SEC_REGS", "SEC_COMM", "SEC_DAC", "SEC_TICK", "SEC_POS")
HARDENS = {   # integrity countermeasures (rtl/top/README.md, "Integrity alarms"), none changes
    "none": dict.fromkeys(SEC_PARAMS, 0),         # a fault-free run's outputs
    "all": dict.fromkeys(SEC_PARAMS, 1),
}
ENUMS = {"angle": ANGLES, "velocity": VELOCITIES, "fit": FITS, "harden": HARDENS}


class ConfigError(ValueError):
    """A bad configuration: the message names the file and line (when read from the registry),
    the configuration and the key."""


@dataclass(frozen=True)
class Config:
    name: str
    doc: str
    clk_hz: int            # FPGA clock, Hz (a multiple of 1 MHz and of sample_hz)
    sample_hz: int         # ADC sample rate, Hz
    lines_log2: int        # encoder lines per revolution = 2**lines_log2
    angle: str             # angle stage: ANGLES
    lut_bits: int          # arcsine codes per 45 deg = 2**lut_bits (1024 counts/line at 7)
    r_nom: int             # amplitude the arcsine table assumes, ADC codes
    ratio_bits: int        # angle ratio*: ratio table 2**ratio_bits entries
    angle_reg: bool        # register after the angle select (latency + 1)
    harm_log2: int         # angle ratio_harm: 2**harm_log2 table entries per line
    cal: bool              # online encoder calibration in every axis (CAL)
    cal_lines_log2: int    # cal: calibration block 2**cal_lines_log2 lines
    cal_nlog: int          # cal: blocks of >= 2**cal_nlog samples ignored
    velocity: str          # VELOCITIES
    vel_log2w: int         # velocity window 2**vel_log2w samples
    amp_min: int           # signal-loss window on the amplitude, ADC codes
    amp_max: int
    loss_samples: int      # consecutive out-of-window samples that raise signal loss
    pole_pairs: int        # motor electrical cycles per revolution
    skew_ns: int           # DAC channel-to-channel skew
    frame_ns: int          # commutation frame
    settle_ns: int         # DAC settling time
    wr_cycles: int         # DAC write strobe, clocks (never shorter than dac_twr_ns)
    dac_twr_ns: int        # the DAC's minimum write pulse
    dac_bits: int          # DAC width
    offset_binary: bool    # DAC coding: offset binary (else two's complement)
    rom_addr_bits: int     # sine ROM: 2**rom_addr_bits quarter-wave entries
    rom_fs: int            # sine ROM full scale
    fit: str               # FITS
    harden: str            # HARDENS

    def replace(self, **changes: object) -> Config:
        """This configuration with some keys changed (a sweep point), checked again."""
        bad = sorted(set(changes) - set(KEYS))
        if bad:
            raise ConfigError(f"configuration {self.name!r}: {bad[0]}: unknown key "
                              f"(known: {', '.join(KEYS)})")
        return _checked(replace(self, **changes))  # type: ignore[arg-type]

    def top(self) -> TopConfig:
        """The golden model of the whole FPGA for this configuration."""
        a, v = ANGLES[self.angle], VELOCITIES[self.velocity]
        interp = InterpConfig(
            lut_bits=self.lut_bits, r_nom=self.r_nom, vel_log2w=self.vel_log2w,
            amp_min=self.amp_min, amp_max=self.amp_max, loss_samples=self.loss_samples,
            lines=1 << self.lines_log2, cal=self.cal, cal_lines_log2=self.cal_lines_log2,
            cal_nlog=self.cal_nlog, coarse=a["coarse"], ratio=a["ratio"],
            ratio_bits=self.ratio_bits, angle_reg=self.angle_reg, harm=a["harm"],
            harm_log2=self.harm_log2, vel_obs=v["vel_obs"])
        comm = CommutationConfig(
            clk_hz=self.clk_hz, skew_ns=self.skew_ns, frame_ns=self.frame_ns,
            settle_ns=self.settle_ns, wr_cycles=self.wr_cycles,
            count_bits=self.lut_bits + 3 + self.lines_log2, pole_pairs=self.pole_pairs,
            rom=SineRomConfig(addr_bits=self.rom_addr_bits, fs=self.rom_fs),
            dac_bits=self.dac_bits, offset_binary=self.offset_binary,
            serial_mul=bool(FITS[self.fit]["SERIAL_MUL"]))
        return TopConfig(clk_hz=self.clk_hz, sample_hz=self.sample_hz, interp=interp,
                         comm=comm, lines_log2=self.lines_log2, dac_twr_ns=self.dac_twr_ns,
                         vel_obs_sel=v["vel_obs_sel"])

    def rtl_params(self) -> Params:
        """hapgate_top's parameters: the golden model's, plus the fit's switches that are on
        (the RTL's defaults are the paper's, so a parameter at its default is left out)."""
        return (self.top().rtl_params() | {k: v for k, v in FITS[self.fit].items() if v}
                | {k: v for k, v in HARDENS[self.harden].items() if v})

    def values(self) -> dict[str, object]:
        """Every key and its value (without name and doc)."""
        return {k: getattr(self, k) for k in KEYS}

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)


KEYS = tuple(f.name for f in fields(Config) if f.name not in ("name", "doc"))
_TYPES = {f.name: {"int": int, "bool": bool, "str": str}[str(f.type)] for f in fields(Config)}


def from_top(t: TopConfig) -> dict[str, object]:
    """The registry's keys of a golden-model configuration (the defaults come from here)."""
    i, c = t.interp, t.comm

    def enum(table: dict[str, dict[str, object]], have: dict[str, object], key: str) -> str:
        for value, sets in table.items():
            if all(have[k] == v for k, v in sets.items()):
                return value
        raise ConfigError(f"{key}: no value gives {have}")

    return {
        "clk_hz": t.clk_hz, "sample_hz": t.sample_hz, "lines_log2": t.lines_log2,
        "angle": enum(ANGLES, {"ratio": i.ratio, "harm": i.harm, "coarse": i.coarse}, "angle"),
        "lut_bits": i.lut_bits, "r_nom": i.r_nom, "ratio_bits": i.ratio_bits,
        "angle_reg": i.angle_reg, "harm_log2": i.harm_log2, "cal": i.cal,
        "cal_lines_log2": i.cal_lines_log2, "cal_nlog": i.cal_nlog,
        "velocity": enum(VELOCITIES, {"vel_obs": i.vel_obs, "vel_obs_sel": t.vel_obs_sel},
                         "velocity"),
        "vel_log2w": i.vel_log2w, "amp_min": i.amp_min, "amp_max": i.amp_max,
        "loss_samples": i.loss_samples, "pole_pairs": c.pole_pairs, "skew_ns": c.skew_ns,
        "frame_ns": c.frame_ns, "settle_ns": c.settle_ns, "wr_cycles": c.wr_cycles,
        "dac_twr_ns": t.dac_twr_ns, "dac_bits": c.dac_bits, "offset_binary": c.offset_binary,
        "rom_addr_bits": c.rom.addr_bits, "rom_fs": c.rom.fs,
        "fit": enum({k: {"SERIAL_MUL": v["SERIAL_MUL"]} for k, v in FITS.items()},
                    {"SERIAL_MUL": int(c.serial_mul)}, "fit")}


def defaults() -> dict[str, object]:
    """The value of every key a configuration leaves out: the golden models' defaults (the
    requested DAC strobe: TopConfig lengthens it to the DAC's t_WCS at its own clock)."""
    return from_top(TopConfig()) | {"wr_cycles": CommutationConfig().wr_cycles,
                                    "harden": "none"}


# ------------------------------------------------------------------------------- validity

def problems(c: Config) -> list[tuple[str, str]]:
    """Every rule the configuration breaks, as (key, what): the one validity check (the RTL
    refuses the same combinations at elaboration, naming the parameter)."""
    out: list[tuple[str, str]] = []
    for key, table in ENUMS.items():
        if getattr(c, key) not in table:
            out.append((key, f"{getattr(c, key)!r} is not one of {', '.join(table)}"))
    if out:
        return out
    ratio = ANGLES[c.angle]["ratio"]
    harm = ANGLES[c.angle]["harm"]
    if c.sample_hz < 1 or c.clk_hz % 1_000_000 or c.clk_hz % c.sample_hz:
        out.append(("clk_hz", f"{c.clk_hz} must be a multiple of 1 MHz and of sample_hz "
                              f"({c.sample_hz})"))
    if not 2 <= c.lut_bits <= 10:
        out.append(("lut_bits", f"{c.lut_bits} is not in 2..10"))
    if c.lut_bits + 3 + c.lines_log2 > 26:
        out.append(("lines_log2", f"lut_bits + 3 + lines_log2 = "
                                  f"{c.lut_bits + 3 + c.lines_log2} counts/rev bits > 26"))
    if ratio and c.lut_bits != 7:
        out.append(("lut_bits", f"angle {c.angle!r} runs at 1024 counts per line (the "
                                f"registers and the firmware count 2^20 per revolution): "
                                f"needs lut_bits = 7, got {c.lut_bits}"))
    if ratio and not 6 <= c.ratio_bits <= 12:
        out.append(("ratio_bits", f"{c.ratio_bits} is not in 6..12"))
    if harm and not 4 <= c.harm_log2 <= 8:
        out.append(("harm_log2", f"{c.harm_log2} is not in 4..8"))
    if harm and c.clk_hz < 2 * c.sample_hz:
        out.append(("clk_hz", f"angle 'ratio_harm' reads its table back between samples: "
                              f"needs clk_hz >= 2 * sample_hz, got {c.clk_hz}"))
    if c.cal and c.angle == "arcsine" and c.lut_bits > 8:
        out.append(("lut_bits", f"cal with angle 'arcsine' needs lut_bits <= 8, got "
                                f"{c.lut_bits}"))
    if FITS[c.fit]["HOLD_C"] and c.clk_hz < 2 * c.sample_hz:
        out.append(("clk_hz", f"fit {c.fit!r} (HOLD_C) needs clk_hz >= 2 * sample_hz, got "
                              f"{c.clk_hz}"))
    if not 0 <= c.amp_min < c.amp_max <= 182:
        out.append(("amp_max", f"needs 0 <= amp_min < amp_max <= 182, got {c.amp_min}, "
                               f"{c.amp_max}"))
    if not 1 <= c.loss_samples <= 65535:
        out.append(("loss_samples", f"{c.loss_samples} is not in 1..65535"))
    if not 2 <= c.vel_log2w <= 12:
        out.append(("vel_log2w", f"{c.vel_log2w} is not in 2..12"))
    if c.rom_addr_bits != 8:
        out.append(("rom_addr_bits", f"the 10-bit OFFSET register needs 8, got "
                                     f"{c.rom_addr_bits}"))
    if not 0 <= c.dac_twr_ns <= 1000:
        out.append(("dac_twr_ns", f"{c.dac_twr_ns} is not in 0..1000"))
    return out


def _checked(c: Config, where: str = "", lines: dict[str, int] | None = None) -> Config:
    for key, value in c.values().items():
        t = _TYPES[key]
        if type(value) is not t:
            raise ConfigError(f"{_at(where, lines, key)}configuration {c.name!r}: {key}: "
                              f"expected {t.__name__}, got {value!r}")
    bad = problems(c)
    if bad:
        key, what = bad[0]
        raise ConfigError(f"{_at(where, lines, key)}configuration {c.name!r}: {key}: {what}")
    return c


def _at(where: str, lines: dict[str, int] | None, key: str) -> str:
    if not where:
        return ""
    line = (lines or {}).get(key, (lines or {}).get("", 0))
    return f"{where}:{line}: " if line else f"{where}: "


# ------------------------------------------------------------------------------- the registry

def _key_lines(text: str) -> dict[str, dict[str, int]]:
    """Line of each table header ("") and key in the registry, for the error messages."""
    out: dict[str, dict[str, int]] = {}
    cur: dict[str, int] = {}
    for n, line in enumerate(text.splitlines(), 1):
        if m := re.match(r"\s*\[\s*([A-Za-z0-9_.-]+)\s*\]", line):
            cur = out.setdefault(m.group(1), {"": n})
        elif m := re.match(r"\s*([A-Za-z0-9_]+)\s*=", line):
            cur.setdefault(m.group(1), n)
    return out


def load(path: Path = REGISTRY) -> dict[str, Config]:
    """Read and check a registry file: every table is a configuration; a table may leave any
    key out (its default is filled in) but not add one. Raises ConfigError naming the file, the
    line, the configuration and the key."""
    where = str(path)
    text = Path(path).read_text()
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"\(at line (\d+), column \d+\)", str(exc))
        raise ConfigError(f"{where}:{m.group(1) if m else 0}: invalid TOML: {exc}") from None
    lines = _key_lines(text)
    base = defaults()
    out = {}
    for name, table in data.items():
        at = lines.get(name, {})
        if not isinstance(table, dict):
            raise ConfigError(f"{_at(where, at, name)}{name}: a configuration is a table")
        for key in table:
            if key != "doc" and key not in KEYS:
                raise ConfigError(f"{_at(where, at, key)}configuration {name!r}: {key}: "
                                  f"unknown key (known: doc, {', '.join(KEYS)})")
        if not isinstance(table.get("doc"), str) or not table["doc"]:
            raise ConfigError(f"{_at(where, at, 'doc')}configuration {name!r}: doc: a "
                              "one-line description is required")
        values = base | {k: v for k, v in table.items() if k != "doc"}
        out[name] = _checked(Config(name=name, doc=table["doc"], **values),  # type: ignore
                             where, at)
    if not out:
        raise ConfigError(f"{where}: no configuration")
    return out


@cache
def registry() -> dict[str, Config]:
    return load()


def names() -> list[str]:
    return list(registry())


def get(name: str) -> Config:
    """A named configuration (ConfigError, naming the known ones, for an unknown name)."""
    try:
        return registry()[name]
    except KeyError:
        raise ConfigError(f"unknown configuration {name!r}; known: {', '.join(registry())} "
                          f"({REGISTRY.name})") from None


def from_json(text: str) -> Config:
    """A configuration sent as Config.to_json (e.g. to a cocotb module), checked again."""
    d = json.loads(text)
    return _checked(Config(**d))


def blocks() -> list[Block]:
    """hapgate_top with the paper's parameters, and one block per other named configuration
    (hapgate_top_NAME): `hapgate lint` lints every one, `hapgate synth` synthesizes every one
    for its resource table."""
    out = []
    for name, cfg in registry().items():
        out.append(Block(name="hapgate_top" if name == "paper" else f"hapgate_top_{name}",
                         top="hapgate_top", sources=SOURCES, params=cfg.rtl_params,
                         doc=f"the FPGA, configuration {name}: {cfg.doc}",
                         # make lint synthesizes the paper's for the iCE40 (block RAM
                         # inferred); the generic synthesis (every memory as flip-flops: the
                         # capture buffer made it 95k cells, 145 s) is `hapgate synth`'s
                         lint_synth=("ice40",) if name == "paper" else (),
                         synth_only=("generic",) if name == "paper" else ("ice40",)))
    return out


# ------------------------------------------------------------------------------- docs

DOC_BEGIN = "<!-- generated by `hapgate configs --write-docs`: do not edit -->"
DOC_END = "<!-- end of generated tables -->"


def _cell(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int) and abs(v) >= 100_000:
        return f"{v:_}"
    return f"`{v}`" if isinstance(v, str) else str(v)


def markdown() -> str:
    """docs/configs.md's generated part: the configurations, every key of each, and what each
    enum value sets in the RTL (taken from `rtl_params()`, not restated)."""
    reg = registry()
    base = defaults()
    out = [DOC_BEGIN, "", "| configuration | what | sets (the rest: defaults) |", "|---|---|---|"]
    for name, c in reg.items():
        diff = ", ".join(f"`{k}` = {_cell(v)}" for k, v in c.values().items() if v != base[k])
        out.append(f"| `{name}` | {c.doc} | {diff or '(all defaults)'} |")
    out += ["", "| key | default | " + " | ".join(f"`{n}`" for n in reg) + " |",
            "|---|---|" + "---|" * len(reg)]
    for k in KEYS:
        out.append(f"| `{k}` | {_cell(base[k])} | "
                   + " | ".join(_cell(getattr(c, k)) if getattr(c, k) != base[k] else "·"
                                for c in reg.values()) + " |")
    paper = get("paper")
    out += ["", "| key | value | hapgate_top parameters it sets |", "|---|---|---|"]
    for key, table in ENUMS.items():
        for value in table:
            p = paper.replace(**{key: value}).rtl_params()
            sets = ", ".join(f"`{n}` = {int(p.get(n, 0))}"  # type: ignore[call-overload]
                             for n in table_params(key))
            out.append(f"| `{key}` | `{value}` | {sets} |")
    return "\n".join([*out, "", DOC_END]) + "\n"


def table_params(key: str) -> list[str]:
    """The RTL parameters an enum key decides."""
    return {"angle": ["ANGLE", "HARM", "COARSE"], "velocity": ["VEL_OBS", "VEL_OBS_SEL"],
            "fit": list(FITS["dsp"]), "harden": list(SEC_PARAMS)}[key]

