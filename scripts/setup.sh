#!/usr/bin/env bash
# One-stop setup for a fresh machine: the emulated board (QEMU, socat), the RISC-V
# cross toolchain (rustup target, else Debian's rustc-web unpacked into .toolchain/), and the
# LiteX SoC's tools (Verilator, LiteX and the ECP5 open flow in .toolchain/soc-venv/).
# Idempotent; the host tool itself needs only cargo.
#
#   bash scripts/setup.sh
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
bash "$here/setup-qemu.sh"
bash "$here/setup-riscv-toolchain.sh"
bash "$here/setup-soc.sh"
