#!/usr/bin/env bash
# Runs every cargo-fuzz target (fuzz/fuzz_targets/) for a bounded time each, starting from the
# seed corpus committed in fuzz/corpus/<target>/ (new inputs go to fuzz/corpus-run/, crashes to
# fuzz/artifacts/; both ignored by git).
#
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]     (default 60 s, all targets)
#
# Needs a nightly toolchain (libFuzzer + AddressSanitizer); installs it and cargo-fuzz when
# missing. Without a nightly it falls back to the stable toolchain with RUSTC_BOOTSTRAP=1 and
# no sanitizer. Exit status is non-zero if any target crashes.
set -euo pipefail
cd "$(dirname "$0")/.."

secs="${1:-60}"
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    targets=(host_frames device_commands scene_image ply)
fi

toolchain=(+nightly)
sanitizer=()
if ! rustup run nightly rustc --version >/dev/null 2>&1; then
    rustup toolchain install nightly --profile minimal >/dev/null 2>&1 || true
fi
if ! rustup run nightly rustc --version >/dev/null 2>&1; then
    echo "fuzz.sh: no nightly toolchain; using stable with RUSTC_BOOTSTRAP=1 and no sanitizer" >&2
    toolchain=()
    sanitizer=(--sanitizer none)
    export RUSTC_BOOTSTRAP=1
fi
if ! cargo fuzz --version >/dev/null 2>&1; then
    cargo "${toolchain[@]}" install cargo-fuzz --locked
fi

status=0
for t in "${targets[@]}"; do
    mkdir -p "fuzz/corpus-run/$t"
    echo "== fuzzing $t for ${secs}s"
    if ! (cd fuzz && cargo "${toolchain[@]}" fuzz run "${sanitizer[@]}" "$t" "corpus-run/$t" "corpus/$t" -- \
        -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1); then
        echo "fuzz.sh: $t FAILED (see fuzz/artifacts/$t)" >&2
        status=1
    fi
done
exit $status
