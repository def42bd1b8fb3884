#!/usr/bin/env bash
# Install what the emulated board needs: qemu-system-riscv32 (Debian qemu-system-misc)
# to boot the soft-core images, and socat for linked pseudo-terminal pairs in the
# serial tests. Skips what is already installed. Needs root (or sudo) for apt-get.
#
#   scripts/setup-qemu.sh
set -euo pipefail

say() { echo "setup-qemu: $*"; }

need=()
command -v qemu-system-riscv32 >/dev/null 2>&1 || need+=(qemu-system-misc)
command -v socat >/dev/null 2>&1 || need+=(socat)

if [[ ${#need[@]} -eq 0 ]]; then
  say "already installed: $(qemu-system-riscv32 --version | head -1); $(socat -V 2>/dev/null | grep -m1 'socat version' || echo socat)"
  exit 0
fi

bash "$(dirname "$0")/apt-install.sh" setup-qemu "${need[@]}"
say "installed: $(qemu-system-riscv32 --version | head -1)"
