"""The named configurations (models/hapgate/configs.toml, hapgate.golden.configs): every one
complete and valid, the validity rules and the registry's refusals (file, line, configuration,
key), the enums' RTL parameters, the readers (boards, hapgate.core, scenes, docs/configs.md),
and that no parameter set is written outside the registry."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest
from hapgate.base.paths import ROOT, RTL
from hapgate.commands import cli
from hapgate.flows import blocks, boards, fusesoc
from hapgate.golden import configs

NAMES = ("paper", "hx8k", "ecp5", "hires", "quad", "observer")   # issue 24's list


def test_registry_names_and_full_sets() -> None:
    assert set(NAMES) <= set(configs.names())
    base = configs.defaults()
    assert configs.get("paper").values() == base          # the paper's design: every default
    for name in configs.names():
        c = configs.get(name)
        assert set(c.values()) == set(configs.KEYS) == set(base), name
        assert not configs.problems(c), name
        assert blocks.get("hapgate_top" if name == "paper" else f"hapgate_top_{name}"
                          ).params() == c.rtl_params()


def test_named_configurations_are_what_their_names_say() -> None:
    """The figures from the boards and the paper (docs/design/SPEC.md, rtl/boards/README.md),
    not from the registry: the HX8K's 12 MHz oscillator and LUT-only fit, the ECP5's 48 MHz
    PLL clock, the paper's 48 MHz and 1024 counts per line."""
    p = configs.get("paper").rtl_params()
    assert (p["CLK_HZ"], p["LUT_BITS"], p["LINES_LOG2"], p["SERIAL_MUL"]) == (48_000_000, 7, 10, 0)
    h = configs.get("hx8k").rtl_params()
    assert h["CLK_HZ"] == 12_000_000
    assert all(h[k] == 1 for k in ("SERIAL_MUL", "SQ_RAM", "HOLD_C", "LATCH_RAM"))
    assert configs.get("ecp5").rtl_params()["CLK_HZ"] == 48_000_000
    r = configs.get("hires").rtl_params()
    assert (r["ANGLE"], r["HARM"], r["CAL"]) == (1, 1, 1)
    assert configs.get("quad").rtl_params()["COARSE"] == 1
    o = configs.get("observer").rtl_params()
    assert (o["VEL_OBS"], o["VEL_OBS_SEL"]) == (1, 1)


@pytest.mark.parametrize("name, changes, key, what", [
    ("hires", {"lut_bits": 9}, "lut_bits", "1024 counts per line"),
    ("paper", {"angle": "ratio", "lut_bits": 8}, "lut_bits", "1024 counts per line"),
    ("hires", {"clk_hz": 1_000_000}, "clk_hz", "clk_hz >= 2 \\* sample_hz"),
    ("hx8k", {"clk_hz": 1_000_000}, "clk_hz", "HOLD_C"),
    ("paper", {"clk_hz": 12_500_000}, "clk_hz", "multiple of 1 MHz"),
    ("hires", {"harm_log2": 9}, "harm_log2", "4..8"),
    ("hires", {"ratio_bits": 13}, "ratio_bits", "6..12"),
    ("paper", {"cal": True, "lut_bits": 9}, "lut_bits", "lut_bits <= 8"),
    ("paper", {"lines_log2": 17}, "lines_log2", "> 26"),
    ("paper", {"angle": "harm"}, "angle", "not one of"),
    ("paper", {"fit": "small"}, "fit", "not one of"),
    ("paper", {"amp_min": 170}, "amp_max", "amp_min < amp_max"),
    ("paper", {"rom_addr_bits": 9}, "rom_addr_bits", "OFFSET"),
    ("paper", {"lut_bits": True}, "lut_bits", "expected int"),
])
def test_rules(name: str, changes: dict[str, object], key: str, what: str) -> None:
    with pytest.raises(configs.ConfigError, match=f"configuration '{name}': {key}: .*{what}"):
        configs.get(name).replace(**changes)


def test_the_rules_allow_what_the_rtl_builds() -> None:
    """The rules are not stricter than the RTL: the combinations the other tests build pass."""
    hires = configs.get("hires")
    for c in (hires.replace(clk_hz=8_000_000, cal=False),
              hires.replace(angle="arcsine", cal_lines_log2=0),
              configs.get("paper").replace(lut_bits=8, cal=True),
              configs.get("hx8k").replace(clk_hz=2_000_000)):
        assert not configs.problems(c), c


def test_enums_cannot_say_the_impossible() -> None:
    """The dependent booleans are enums: no angle mode has the harmonic table without the ratio
    stage, or the ratio stage with plain quadrature; the observer is never selected unbuilt."""
    for mode, sets in configs.ANGLES.items():
        assert sets["ratio"] or not sets["harm"], mode
        assert not (sets["ratio"] and sets["coarse"]), mode
    for mode, sets in configs.VELOCITIES.items():
        assert sets["vel_obs"] or not sets["vel_obs_sel"], mode
    p = configs.get("paper")
    rtl = {m: p.replace(angle=m).rtl_params() for m in configs.ANGLES}
    assert [(r.get("ANGLE", 0), r.get("HARM", 0), r.get("COARSE", 0)) for r in rtl.values()] \
        == [(0, 0, 0), (0, 0, 1), (1, 0, 0), (1, 1, 0)]


def write(tmp_path: Path, text: str) -> Path:
    f = tmp_path / "configs.toml"
    f.write_text(text)
    return f


@pytest.mark.parametrize("text, where", [
    ('[a]\ndoc = "x"\nclk_hz = 48_000_000\nlut_bitz = 7\n', r":4: configuration 'a': lut_bitz: "
                                                             "unknown key"),
    ('[a]\ndoc = "x"\n\n[b]\ndoc = "y"\nangle = "ratio"\nlut_bits = 9\n',
     r":7: configuration 'b': lut_bits: angle 'ratio'"),
    ('[a]\ndoc = "x"\ncal = 1\n', r":3: configuration 'a': cal: expected bool"),
    ('[a]\nclk_hz = 12_000_000\n', r":1: configuration 'a': doc: a one-line description"),
    ('[a]\ndoc = "x"\nfit = "lut"\nclk_hz = 1_000_000\n', r":4: configuration 'a': clk_hz:"),
    ('[a]\ndoc = "x"\n[a\n', r":3: invalid TOML"),
])
def test_registry_refusals(tmp_path: Path, text: str, where: str,
                           capsys: pytest.CaptureFixture[str]) -> None:
    f = write(tmp_path, text)
    with pytest.raises(configs.ConfigError, match=re.escape(str(f)) + where):
        configs.load(f)
    assert cli.main(["configs", "--file", str(f)]) == 2
    assert str(f) in capsys.readouterr().err


def test_unknown_name() -> None:
    with pytest.raises(configs.ConfigError, match="unknown configuration 'nope'; known: paper"):
        configs.get("nope")


def test_scene_selects_a_configuration(tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    from hapgate.device import scene

    base = scene.load(ROOT / "scenes" / "short.toml")
    assert base.run.gateware().name == "paper"
    q = base.override({"run.config": "quad"})
    assert q.run.gateware().angle == "quadrature"
    o = base.override({"run.config": "observer"}).run.gateware()
    assert (o.name, o.velocity) == ("observer", "observer")
    for name, why in (("nope", "'nope' is not one of paper"), ("hires", "sets cal, angle"),
                      ("hx8k", "sets fit")):
        f = tmp_path / f"{name}.toml"
        f.write_text(f'[run]\nduration_s = 0.01\nconfig = "{name}"\n')
        assert cli.main(["scene", "check", str(f)]) == 2
        err = capsys.readouterr().err
        assert f"{f}: run.config:" in err and why in err, err


def test_boards_read_the_registry() -> None:
    """Each board's parameters are its configuration's, and its board top's Verilog defaults
    (used when the top is elaborated on its own) are the same values."""
    for b in boards.BOARDS.values():
        cfg = configs.get(b.config)
        assert b.clk_hz == cfg.clk_hz
        p = boards.board_params(b)
        core = cfg.rtl_params()
        assert {k: v for k, v in p.items() if k in core} == \
            {k: core[k] for k in p if k in core}
        defaults = boards.module_params(RTL / "boards" / f"{b.top}.v")
        for k, v in p.items():
            if k in core and not isinstance(v, Path):
                assert int(defaults[k].replace("_", "")) == v, (b.top, k)


def test_board_refuses_a_parameter_its_top_does_not_take(monkeypatch: pytest.MonkeyPatch
                                                         ) -> None:
    hires = configs.get("hires")
    monkeypatch.setitem(configs.registry(), "hx8k", hires.replace(clk_hz=12_000_000))
    with pytest.raises(ValueError, match="sets .*ANGLE.*hapgate_ice40_hx8k.v does not take"):
        boards.board_params(boards.BOARDS["ice40-hx8k"])


def test_fusesoc_core_is_generated() -> None:
    assert fusesoc.CORE.read_text() == fusesoc.core_text(), "hapgate.core: run `hapgate core`"
    import yaml

    core = yaml.safe_load(fusesoc.CORE.read_text().split("\n", 1)[1])
    assert core["filesets"]["rtl"]["files"] == [f"rtl/{s}" for s in
                                                blocks.get("hapgate_top").sources] + [
        {"rtl/include/hg_sim.vh": {"is_include_file": True}}]   # the simulation-only macros
    hx8k = core["targets"]["ice40-hx8k"]["flow_options"]["nextpnr_options"]
    assert hx8k[hx8k.index("--router") + 1] == "router2"    # router1 livelocks (issue 24)
    for name in configs.names():
        tgt = core["targets"]["lint" if name == "paper" else f"lint-{name}"]
        got = dict(p.split("=") for p in tgt["parameters"] if "=" in p)
        want = {k: str(v) for k, v in configs.get(name).rtl_params().items()
                if not isinstance(v, Path)}
        assert got == want, name


def test_docs_tables_are_generated() -> None:
    assert cli.configs_doc_text() == cli.CONFIGS_DOC.read_text(), \
        "docs/configs.md: run `hapgate configs --write-docs`"


# ------------------------------------------------------------------- no parameter set elsewhere

READER = ROOT / "models" / "hapgate" / "golden" / "configs.py"
CLASSES = {("hapgate.golden.top", "TopConfig"), ("hapgate.golden.configs", "Config")}


def _module_of(path: Path) -> str:
    rel = path.relative_to(ROOT / "models") if path.is_relative_to(ROOT / "models") else None
    return ".".join(rel.with_suffix("").parts) if rel else ""


def _resolve(module: str | None, level: int, here: str) -> str:
    if not level:
        return module or ""
    base = here.split(".")[:-level]
    return ".".join([*base, *([module] if module else [])])


def _config_params() -> set[str]:
    """The RTL parameters a configuration sets (the vocabulary of a parameter set)."""
    keys = set(configs.FITS["dsp"])
    for name in configs.names():
        keys |= set(configs.get(name).rtl_params())
    return keys


def _block_params() -> list[set[str]]:
    """Each sub-block's parameters (every module under rtl/ but the top and the board tops)."""
    return [set(boards.module_params(f)) for f in sorted(RTL.rglob("*.v"))
            if f.parent.name not in ("top", "boards")]


def _whole_fpga(keys: list[str]) -> bool:
    """Two or more configuration parameters that no single block takes together: a parameter
    set of the whole FPGA (a block's own sweep, e.g. dac_sched's SKEW_NS and FRAME_NS, is not
    one)."""
    return len(keys) >= 2 and not any(set(keys) <= b for b in _block_params())


def parameter_sets(source: str, path: Path) -> list[str]:
    """Where `source` writes a parameter set: a construction of TopConfig or the registry's
    Config (found through imports, aliases and module attributes, not by name), or a dict
    literal (or dict(...)) giving constant values to configuration parameters that no single
    block takes together."""
    tree = ast.parse(source)
    here = _module_of(path)
    names: set[str] = set()        # local names bound to one of the classes
    modules: dict[str, str] = {}   # local name -> module it is bound to
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            mod = _resolve(node.module, node.level, here)
            for a in node.names:
                if (mod, a.name) in CLASSES:
                    names.add(a.asname or a.name)
                modules[a.asname or a.name] = f"{mod}.{a.name}"
        elif isinstance(node, ast.Import):
            for a in node.names:
                modules[a.asname or a.name.split(".")[0]] = a.name if a.asname else \
                    a.name.split(".")[0]
    out = []
    vocab = _config_params()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            hit = isinstance(f, ast.Name) and f.id in names
            if isinstance(f, ast.Attribute):
                chain = []
                v: ast.expr = f.value
                while isinstance(v, ast.Attribute):
                    chain.insert(0, v.attr)
                    v = v.value
                if isinstance(v, ast.Name) and v.id in modules:
                    mod = ".".join([modules[v.id], *chain])
                    hit = (mod, f.attr) in CLASSES
            if hit:
                out.append(f"{path.relative_to(ROOT)}:{node.lineno}: constructs "
                           f"{ast.unparse(f)}")
            if isinstance(f, ast.Name) and f.id == "dict":
                consts = [str(k.arg) for k in node.keywords
                          if k.arg in vocab and isinstance(k.value, ast.Constant)]
                if _whole_fpga(consts):
                    out.append(f"{path.relative_to(ROOT)}:{node.lineno}: dict of "
                               f"{', '.join(consts)}")
        if isinstance(node, ast.Dict):
            consts = [k.value for k, v in zip(node.keys, node.values)
                      if isinstance(k, ast.Constant) and k.value in vocab
                      and isinstance(v, ast.Constant)]
            if _whole_fpga(consts):
                out.append(f"{path.relative_to(ROOT)}:{node.lineno}: parameter dict of "
                           f"{', '.join(consts)}")
    return out


def test_scanner_sees_through_names() -> None:
    """The scan follows what a name refers to: renamed classes, module aliases, relative
    imports, nested module attributes; and it is not fooled by an unrelated `Config`."""
    p = ROOT / "tb" / "x.py"
    caught = [
        "from hapgate.golden.top import TopConfig as T\nT(clk_hz=1)\n",
        "from hapgate.golden import top as m\nm.TopConfig()\n",
        "import hapgate.golden.top as t\nt.TopConfig(clk_hz=2)\n",
        "import hapgate\nhapgate.golden.configs.Config(name='x')\n",
        "from hapgate.golden import configs as c\nc.Config(**d)\n",
        "p = {'SERIAL_MUL': 1, 'SQ_RAM': 1}\n",              # commutator + interpolator
        "p = dict(CLK_HZ=12_000_000, LINES_LOG2=10)\n",     # LINES_LOG2: the top's alone
    ]
    for src in caught:
        assert parameter_sets(src, p), src
    rel = ROOT / "models" / "hapgate" / "device" / "x.py"
    assert parameter_sets("from ..golden.top import TopConfig\nTopConfig()\n", rel)
    fine = [
        "from dataclasses import dataclass\nclass Config: ...\nConfig()\n",
        "from hapgate.golden import configs\nconfigs.get('hx8k').replace(clk_hz=16_000_000)\n",
        "p = {'LUT_BITS': 9}\n", "p = {'CLK_HZ': clk, 'AXIS_MASK': 5}\n",
        "p = {'SKEW_NS': 2000, 'FRAME_NS': 12000}\n",       # dac_sched's own sweep
    ]
    for src in fine:
        assert not parameter_sets(src, p), src


def test_no_parameter_set_outside_the_registry() -> None:
    files = [f for d in ("models", "tb") for f in sorted((ROOT / d).rglob("*.py"))
             if f != READER]
    assert len(files) > 100
    found = [hit for f in files for hit in parameter_sets(f.read_text(), f)]
    assert not found, "parameter sets written outside models/hapgate/configs.toml " \
                      "(use configs.get(name) or .replace(...)):\n" + "\n".join(found)
