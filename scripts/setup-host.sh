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

bash "$(dirname "$0")/apt-install.sh" setup-host "${need[@]}"
say "installed: libembree-dev $(dpkg-query -W -f='${Version}' libembree-dev)"
