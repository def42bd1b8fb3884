#!/usr/bin/env bash
# Tests scripts/check-tool-tests.sh on synthetic `cargo test` logs (run by .ci/run).
#
#   bash scripts/test_check_tool_tests.sh
set -uo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
check="$here/check-tool-tests.sh"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
unset GRIDRT_SKIP_TOOLS
failed=0

# expect NAME STATUS PATTERN -- COMMAND...: the command's exit status and a line of its output.
expect() {
  local name=$1 want=$2 pattern=$3
  shift 4
  local out status
  out=$("$@" 2>&1)
  status=$?
  if [[ $status -eq $want ]] && grep -qF -- "$pattern" <<<"$out"; then
    echo "ok: $name"
  else
    echo "FAILED: $name (exit $status, wanted $want and a line with '$pattern'):"
    sed 's/^/    /' <<<"$out"
    failed=1
  fi
}

cat >"$tmp/all.log" <<'LOG'
running 3 tests
test qemu_boots ... qemu_boots: uses tool qemu-system-riscv32: QEMU emulator version 7.2.15
ok
socat_pty_device_renders: uses tool socat: socat version 1.7.4.4
test socat_pty_device_renders ... ok
cosim_frame: uses tool verilator: Verilator 5.006 2023-01-22
soc_frame: uses tool verilator: Verilator 5.006 2023-01-22
soc_frame: uses tool scripts/setup-soc.sh: litex 2023.12
view_page_shows_the_stream: uses tool chromium: Chromium 156.0.8078.108 built on Debian GNU/Linux 12 (bookworm)
test result: ok. 3 passed; 0 failed; 0 ignored; 0 measured; 0 filtered out
LOG
# The same run split over two logs (the SoC test runs on its own).
grep -v "soc_frame" "$tmp/all.log" >"$tmp/workspace.log"
grep "soc_frame" "$tmp/all.log" >"$tmp/soc.log"
grep -v "uses tool socat" "$tmp/all.log" >"$tmp/no-socat.log"
sed 's/^socat_pty_device_renders: uses tool socat: .*/socat_pty_device_renders: SKIPPED by opt-out GRIDRT_SKIP_TOOLS=socat: not run with socat/' \
  "$tmp/all.log" >"$tmp/skipped.log"
: >"$tmp/empty.log"

expect "every tool ran: passes" 0 "tests with socat: 1 ran, 0 skipped" -- bash "$check" "$tmp/all.log"
expect "two logs together: pass" 0 "tests with scripts/setup-soc.sh: 1 ran" -- bash "$check" "$tmp/workspace.log" "$tmp/soc.log"
expect "the workspace log alone: no LiteX test ran" 1 "no test ran with scripts/setup-soc.sh" -- bash "$check" "$tmp/workspace.log"
expect "a tool's tests ran zero times: fails" 1 "no test ran with socat" -- bash "$check" "$tmp/no-socat.log"
expect "a test skipped by opt-out: fails" 1 "1 test(s) skipped by opt-out instead of running with socat" -- bash "$check" "$tmp/skipped.log"
expect "an empty log: fails" 1 "no test ran with qemu-system-riscv32" -- bash "$check" "$tmp/empty.log"
expect "GRIDRT_SKIP_TOOLS set: fails" 1 "GRIDRT_SKIP_TOOLS is set" -- env GRIDRT_SKIP_TOOLS=all bash "$check" "$tmp/all.log"
expect "GRIDRT_SKIP_TOOLS set but empty: fails" 1 "GRIDRT_SKIP_TOOLS is set" -- env GRIDRT_SKIP_TOOLS= bash "$check"
expect "no log, variable unset: passes" 0 "" -- bash "$check"
expect "a missing log: an error" 2 "cannot read log" -- bash "$check" "$tmp/missing.log"

if [[ $failed -ne 0 ]]; then
  echo "check-tool-tests.sh: some checks failed"
  exit 1
fi
echo "check-tool-tests.sh: all checks passed"
