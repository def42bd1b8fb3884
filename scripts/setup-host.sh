#!/usr/bin/env bash
# Install what the host tool's optional features need: libembree-dev (Embree 3) for
# `--features embree` (`gridrt bench rays --vs-embree`; CI lints that feature). Skips what is
# already installed. Needs root (or sudo) for apt-get.
#
#   scripts/setup-host.sh
set -euo pipefail

say() { echo "setup-host: $*"; }

installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }

need=()
installed libembree-dev || need+=(libembree-dev)

if [[ ${#need[@]} -eq 0 ]]; then
  say "already installed: libembree-dev $(dpkg-query -W -f='${Version}' libembree-dev)"
  exit 0
fi

SUDO=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null 2>&1 || { say "need root (or sudo) to install: ${need[*]}"; exit 1; }
  SUDO=(sudo)
fi

say "installing: ${need[*]}"
# The package lists may be missing or stale on a fresh machine.
"${SUDO[@]}" apt-get update -q
DEBIAN_FRONTEND=noninteractive "${SUDO[@]}" apt-get install -y -q --no-install-recommends "${need[@]}"
say "installed: libembree-dev $(dpkg-query -W -f='${Version}' libembree-dev)"
