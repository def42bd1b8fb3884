#!/usr/bin/env bash
# Checks that CI ran the tests that need a tool (QEMU, socat, Verilator, LiteX, Chromium): fails (exit 1,
# saying why) when GRIDRT_SKIP_TOOLS is set, when a log shows a test skipped by that opt-out, or
# when any tool's tests ran zero times. The logs are `cargo test` output: each such test writes
# one line (tests/e2e/src/tools.rs, rtl/src/sim.rs), "TEST: uses tool PROGRAM: VERSION" when it
# ran, "TEST: SKIPPED by opt-out GRIDRT_SKIP_TOOLS=…: not run with PROGRAM" when it did not.
#
#   scripts/check-tool-tests.sh [LOG ...]      # no LOG: only the GRIDRT_SKIP_TOOLS check
set -euo pipefail

TOOLS=(qemu-system-riscv32 socat verilator scripts/setup-soc.sh chromium)
say() { echo "check-tool-tests: $*"; }

bad=0
if [[ -n "${GRIDRT_SKIP_TOOLS+set}" ]]; then
  say "GRIDRT_SKIP_TOOLS is set (='${GRIDRT_SKIP_TOOLS}'): CI runs every tool's tests; unset it (the setup scripts install the tools)"
  bad=1
fi
if [[ $# -gt 0 ]]; then
  for log in "$@"; do
    [[ -r "$log" ]] || { say "cannot read log $log"; exit 2; }
  done
  for tool in "${TOOLS[@]}"; do
    ran=$(cat "$@" | grep -cF ": uses tool $tool:" || true)
    skipped=$(cat "$@" | grep -F ": SKIPPED by opt-out " | grep -cF ": not run with $tool" || true)
    echo "tests with $tool: $ran ran, $skipped skipped by opt-out"
    if [[ $ran -eq 0 ]]; then
      say "no test ran with $tool"
      bad=1
    fi
    if [[ $skipped -gt 0 ]]; then
      say "$skipped test(s) skipped by opt-out instead of running with $tool"
      bad=1
    fi
  done
fi
if [[ $bad -ne 0 ]]; then
  say "FAILED: the tool tests did not all run"
  exit 1
fi
exit 0
