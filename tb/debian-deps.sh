#!/usr/bin/env bash
# The Debian packages the tests need, in one place. As root: install the missing ones
# (apt-get update once, then apt-get install --no-install-recommends). Otherwise: name what is
# missing and exit 1. Called by `make deps` (and so by `make test` and .ci/run).
set -euo pipefail

PACKAGES=(
    # tb/view: the live view tested in a real browser (headless Chromium driven by selenium,
    # chromedriver at /usr/bin/chromedriver)
    chromium
    chromium-driver
    # make coverage: genhtml (lcov) makes the HTML report from build/reports/coverage/coverage.info
    lcov
    # tb/fw/test_cross.py (make -C dsp-fw cross): the firmware's freestanding Cortex-M4F build
    # with the Debian cross compiler and arm-none-eabi-size
    gcc-arm-none-eabi
    # the same build: libm for the Cortex-M4F (hard float) comes with newlib's multilibs
    libnewlib-arm-none-eabi
    # tb/soc (make -C dsp-fw riscv): the firmware for the SoC's soft RISC-V CPU (VexRiscv, RV32IM),
    # built with the Debian cross compiler and riscv64-unknown-elf-size
    gcc-riscv64-unknown-elf
    # the same build: the C library and libm for RV32IM/ilp32 (picolibc.specs; Debian has no newlib)
    picolibc-riscv64-unknown-elf
    # issue 36's `make flash`: loads the SoC board's bitstream over the board's USB (FTDI) JTAG
    openfpgaloader
    # (more packages: one line each, with the tests that need them above it)
)

missing=()
for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
    exit 0
fi
if [ "$(id -u)" -ne 0 ]; then
    echo "error: missing Debian packages: ${missing[*]}" >&2
    echo "       install them as root: tb/debian-deps.sh (or apt-get install ${missing[*]})" >&2
    exit 1
fi
echo "installing Debian packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"
