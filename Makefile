# hapgate — the people's entry points. Everything real lives in the `hapgate` Python
# package (models/hapgate/) and in pytest (tb/); this file only wires them together.
#
#   make          the venv, the C host library and the CHAI3D shims (build/host/lib/)
#   make demo     the main job (what it runs grows with each block)
#   make test     deps + lint + the docs site + the first tier of tests (pytest -n auto,
#                 Verilator and Icarus; ~10 min on 2 cores from a fresh clone)
#   make regress  the second tier: the long runs, second simulators and netlists
#                 (tb/conftest.py REGRESS lists them and why); CI runs it after make test
#   make deps     the Debian packages the tests need (tb/debian-deps.sh: installs them as root,
#                 else names the missing ones and fails)
#   make lint     ruff, verilator -Wall, Icarus elaboration, Yosys synthesis checks
#   make bench    benchmarks: tables on stdout and in docs/figures.md, CSV/PNG in build/reports/
#                 (BENCH_ARGS="--only sine fw" runs some parts, "--quick" smaller sizes)
#   make host     the C host library, the CHAI3D shims and the C example (host/, into build/host/)
#   make docs     the documentation site (MkDocs, strict: a broken link fails) into build/site/
#   make soak     10^9 ADC samples through the interpolator on Dask (scenes/sweeps/soak.toml)
#   make synth    Yosys resource table per block, then nextpnr place and route of the board tops
#                 (bitstreams; fails on a fit or timing failure)
#   make flash BOARD=ecp5-evn  write the board's bitstream (the newest `make synth` packed) with
#                 openFPGALoader; FLASH_ARGS="--flash" writes the SPI flash instead of the SRAM
#   make gatelevel the board tops' post-synthesis netlists beside their RTL (minutes)
#   make versions the tools in use, with their paths
#   make mutants  mutation testing: every bug in tb/mutants/mutants.toml must be killed (long)
#   make coverage code coverage of the RTL from the block tests on Verilator: table, summary.json,
#                 lcov and HTML in build/reports/coverage/, docs/coverage.md (long)
#                 (COVERAGE_ARGS="--only dac_sched" runs some block folders)
#   make formal   SymbiYosys proofs (tb/formal/) and the broken copies each must reject
#   make regs     regenerate the register header/document from rtl/regs/hapgate.rdl
SHELL   := bash
PYTHON  ?= python3
VENV    := .venv
STAMP   := $(VENV)/.installed
HG      := $(VENV)/bin/hapgate
PYTEST  := $(VENV)/bin/pytest
PYTEST_ARGS ?= -n auto --durations=15

.PHONY: all host venv deps demo test regress lint bench docs soak versions synth flash gatelevel formal regs mutants coverage clean distclean

all: venv host

host:
	$(MAKE) -C host BUILD=$(CURDIR)/build/host

# The venv is (re)built only when the pin file or the package metadata change.
$(STAMP): requirements.lock pyproject.toml
	@command -v $(PYTHON) >/dev/null || { echo "error: $(PYTHON) not found" >&2; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/python -m pip install --quiet --disable-pip-version-check -r requirements.lock
	$(VENV)/bin/python -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation -e .
	@touch $@

venv: $(STAMP)

versions: $(STAMP)
	$(HG) versions

lint: $(STAMP)
	$(VENV)/bin/ruff check models tb
	$(HG) lint

deps:
	bash tb/debian-deps.sh

test: deps lint docs host
	$(HG) check-sims
	$(PYTEST) $(PYTEST_ARGS) -m "not regress" tb

regress: deps $(STAMP) host
	$(PYTEST) $(PYTEST_ARGS) -m regress tb

demo: $(STAMP)
	$(HG) demo

bench: $(STAMP)
	$(VENV)/bin/python -m hapgate.commands.bench $(BENCH_ARGS)

docs: $(STAMP)
	$(VENV)/bin/mkdocs build --strict --quiet

# Mutation testing (not part of `make test`): MUTANTS_ARGS="--only NAME ..." or "--jobs 2"
mutants: $(STAMP)
	$(HG) mutants $(MUTANTS_ARGS)

# Code coverage (not part of `make test`; its builds are separate ones): genhtml needs deps
coverage: deps $(STAMP)
	$(HG) coverage $(COVERAGE_ARGS)

SOAK_WORKERS ?= 2
soak: $(STAMP)
	$(HG) sweep scenes/sweeps/soak.toml --workers $(SOAK_WORKERS)

synth: $(STAMP)
	$(HG) synth
	$(HG) pnr

flash: $(STAMP)
	@test -n "$(BOARD)" || { echo "error: make flash BOARD=NAME (ice40-hx8k, ecp5-evn, ecp5-soc)" >&2; exit 2; }
	$(HG) flash $(BOARD) $(FLASH_ARGS)

gatelevel: $(STAMP)
	$(PYTEST) -p no:xdist tb/boards/gatelevel_board_tops.py tb/top/gatelevel_top.py

formal: $(STAMP)
	$(VENV)/bin/python -m hapgate.flows.formal --mutants

# Regenerate the committed register header and document from rtl/regs/hapgate.rdl
# (tb/bus/test_regmap.py fails while they are stale).
regs: $(STAMP)
	$(VENV)/bin/python -m hapgate.flows.regmap

clean:
	rm -rf build

distclean: clean
	rm -rf $(VENV)
