"""The DSP bus (rtl/bus/emif_slave.v): its timing rules and the records of its accesses (plain
Python; the cocotb master and monitor that produce them are hapgate.runners.cocotb_emif).

Timing rules, in FPGA clocks T = 1/CLK_HZ (the slave synchronises CE, RE and WE with two flip-flops
and captures address and data at the third clock edge after the strobe falls):

- setup (address, CE, write data valid before the strobe falls): >= 0 T; they are captured
  2..3 clocks after the fall;
- strobe (RE or WE low): >= 5 T. The access is served iff the strobe is still low at the capture
  edge (< 3 T after the fall); read data are valid < 3 T + t_co after the fall; +1 T for a
  metastable first stage, +1 T of read-data setup at the DSP;
- data and address stable through the strobe (captured before it ends: hold >= 0);
- recovery (strobe high between two strobes, hold + next setup): >= 3 T, so the synchroniser
  sees the strobe high and `ready` falls.

A strobe that ends before the capture edge is dropped (nothing is written) and sets
STATUS.PROTO_ERR, as do read and write strobes low together; a strobe shorter than one clock may
not be seen at all. Read data drivers (`data_oe`) follow CE and RE combinationally, like an
SRAM's OE#. `ready` rises when the access has been served (3..4 T after the fall): a master that
waits for it needs no strobe length.
"""

from __future__ import annotations

import random
from dataclasses import dataclass

SYNC_STAGES = 2
CAPTURE_EDGE = 3          # the access is captured at the 3rd clock edge after the strobe falls
MIN_SETUP_CLOCKS = 0
MIN_STROBE_CLOCKS = 5
MIN_RECOVERY_CLOCKS = 3


@dataclass
class Timing:
    """One access's phases in ps: setup (CE/address before the strobe), strobe, hold (after the
    strobe, CE still low) and idle (CE high before the next access)."""
    setup: int
    strobe: int
    hold: int
    idle: int = 0


def random_timing(rng: random.Random, period_ps: int, min_strobe_clocks: float = MIN_STROBE_CLOCKS
                  ) -> Timing:
    """EMIF-like timing: a bus clock of random period (0.2 .. 2.5 FPGA clocks), whole bus cycles
    per phase, strobe >= min_strobe_clocks and recovery >= MIN_RECOVERY_CLOCKS FPGA clocks."""
    eclk = int(period_ps * rng.uniform(0.2, 2.5))
    setup = rng.randint(0, 3) * eclk
    n_strobe = -(-int(min_strobe_clocks * period_ps) // eclk)
    strobe = (n_strobe + rng.choice((0, 0, 0, 1, 2, 5))) * eclk
    n_rec = -(-(MIN_RECOVERY_CLOCKS * period_ps + 1) // eclk)
    hold_cycles = rng.randint(0, 2)
    idle = max(0, n_rec - hold_cycles) * eclk + rng.choice((0, 0, 1)) * eclk  # (next setup: bonus)
    return Timing(setup=setup, strobe=strobe, hold=hold_cycles * eclk, idle=idle)


@dataclass
class Access:
    we: bool
    word: int
    wdata: int = 0
    rdata: int | None = None       # what the master sampled at the end of the strobe
    oe: int = 0                    # data_oe at the end of the strobe
    ready: int = 0                 # ready at the end of the strobe
    t_fall: int = 0                # ps


@dataclass
class Committed:
    edge: int                      # clock edge (index from the reset edge) that applied it
    we: bool
    word: int
    wdata: int
