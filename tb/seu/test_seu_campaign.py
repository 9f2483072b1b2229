"""The injection campaign at scale (second tier, tb/conftest.py REGRESS): the first 10^3 jobs of
scenes/sweeps/seu.toml on two workers. Every block is drawn in proportion to its bits, every
record is classified and its class follows from its flags, the metric is in range, and 20 jobs
rerun without the cache give the same records (the campaign is a function of its seeds)."""

from __future__ import annotations

import argparse
import csv

from hapgate.base.paths import ROOT
from hapgate.commands import sweep as sweep_cmd
from hapgate.device import seu, sweep

SPEC = ROOT / "scenes" / "sweeps" / "seu.toml"
RUNS = 1000


def test_thousand_injections(tmp_path):
    args = argparse.Namespace(spec=SPEC, scheduler=None, workers=2, out=tmp_path,
                              no_cache=False, limit=RUNS, compare=[])
    assert sweep_cmd.main(args) == 0
    rows = list(csv.DictReader((tmp_path / "results.csv").open()))
    assert len(rows) == RUNS
    _sc, design, _clk = seu.setup()
    bits = design.bits_per_block()
    for blk, n in bits.items():             # drawn in proportion to the bits (binomial, 5 sigma)
        k = sum(r["block"] == blk for r in rows)
        p = n / len(design.sites)
        assert abs(k - RUNS * p) <= 5 * (RUNS * p * (1 - p)) ** 0.5 + 1, blk
    assert {r["class"] for r in rows} <= set(seu.CLASSES)
    for r in rows:
        if r["class"] == "silent":
            assert r["violation"] == "True" and r["latched"] == "False"
        if r["class"] in ("masked", "latched"):
            assert r["violation"] == "False" and r["dangerous"] == "False"
    dangerous = sum(r["dangerous"] == "True" for r in rows)
    assert 0.0 <= seu.spfm(dangerous, RUNS) <= 1.0
    spec = sweep.load(SPEC)
    jobs = spec.jobs()[:20]
    again = sweep.run(spec, workers=2, cache=None, jobs=jobs, progress=False)
    first = [{k: v for k, v in r.items() if k not in sweep.VOLATILE}
             for r in csv.DictReader((tmp_path / "results.csv").open())][:20]
    rerun = sweep.write(again, tmp_path / "rerun")
    second = [{k: v for k, v in r.items() if k not in sweep.VOLATILE}
              for r in csv.DictReader(rerun[0].open())]
    assert first == second
