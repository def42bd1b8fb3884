#!/usr/bin/env bash
# Install what the live view's browser test needs: Debian's chromium, run headless by
# tests/e2e/tests/view.rs to load `gridrt render --view`'s page during a stream and read its
# pixels. Skips what is already installed. Needs root (or sudo) for apt-get.
#
#   scripts/setup-browser.sh
set -euo pipefail

say() { echo "setup-browser: $*"; }

if command -v chromium >/dev/null 2>&1; then
  say "already installed: $(chromium --version 2>/dev/null | head -1)"
  exit 0
fi

bash "$(dirname "$0")/apt-install.sh" setup-browser chromium
say "installed: $(chromium --version 2>/dev/null | head -1)"
