#!/usr/bin/env bash
# One-stop setup for a fresh machine: the emulated board (QEMU, socat), the RISC-V
# cross toolchain (rustup target, else Debian's rustc-web unpacked into .toolchain/), the HDL
# tools (Verilator; Yosys and nextpnr-ecp5 from pip) and the LiteX SoC's (LiteX and its
# simulation libraries in .toolchain/soc-venv/), the host tool's optional Embree
# (libembree-dev, for `--features embree`), and Chromium (headless, for the `--view` page's
# browser test).
# Idempotent; the host tool itself needs only cargo.
#
#   bash scripts/setup.sh
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
bash "$here/setup-qemu.sh"
bash "$here/setup-riscv-toolchain.sh"
bash "$here/setup-hdl.sh"
bash "$here/setup-soc.sh"
bash "$here/setup-host.sh"
bash "$here/setup-browser.sh"
