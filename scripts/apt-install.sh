#!/usr/bin/env bash
# Installs Debian packages for the setup scripts: refreshes the package lists (they may be
# missing or stale on a fresh machine), then installs without recommends; through sudo when
# not root. NAME prefixes the messages (the calling script's name).
#
#   scripts/apt-install.sh NAME PACKAGE...
set -euo pipefail
name=$1
shift
SUDO=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null 2>&1 || { echo "$name: need root (or sudo) to install: $*"; exit 1; }
  SUDO=(sudo)
fi
echo "$name: installing: $*"
"${SUDO[@]}" apt-get update -q
DEBIAN_FRONTEND=noninteractive "${SUDO[@]}" apt-get install -y -q --no-install-recommends "$@"
