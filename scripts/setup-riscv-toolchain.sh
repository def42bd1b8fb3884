#!/usr/bin/env bash
# Make a bare-metal RISC-V Rust toolchain available for the soft-core images,
# without touching the system toolchain.
#
#   scripts/setup-riscv-toolchain.sh [--debian] [--rustup-only] [--check]
#
# Strategy (first that works wins):
#   1. `rustup target add riscv32imac-unknown-none-elf riscv32imafc-unknown-none-elf
#      riscv32im-unknown-none-elf` (the last: the SoC's VexRiscv `full+cfu`, no C, no A)
#      for the active rustup toolchain. Plain `cargo build --target ...` then works.
#   2. Fallback: Debian's rustc-web (+ its std sources, LLVM and lld) unpacked with
#      `apt-get download` + `dpkg -x` into <repo>/.toolchain/ (git-ignored). The xtask
#      then builds `core` from source with -Zbuild-std (see firmware/image/README.md).
#
# --debian       skip step 1 and (also) prepare the Debian toolchain
# --rustup-only  only try step 1; fail if it does not work
# --check        change nothing; exit 0 if some toolchain is ready, 1 otherwise
#
# Idempotent: each step is skipped when its result is already there.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
TOOLCHAIN_DIR="$ROOT/.toolchain"
TARGETS=(riscv32imac-unknown-none-elf riscv32imafc-unknown-none-elf riscv32im-unknown-none-elf)
# Pinned so that the std sources always match the compiler that builds them.
RUST_DEB_VERSION="1.96.0+dfsg1-1~deb12u2"
LLVM_MAJOR=22
DEB_PACKAGES=(
  "rustc-web=$RUST_DEB_VERSION"
  "rust-web-src=$RUST_DEB_VERSION"
  # Holds librustc_driver-*.so, which the rustc binary is linked against.
  "libstd-rust-web-1.96=$RUST_DEB_VERSION"
  # The host (x86_64) std rlibs: build scripts and proc macros are compiled for the host.
  "libstd-rust-web-dev=$RUST_DEB_VERSION"
  "libllvm$LLVM_MAJOR"
  "lld-$LLVM_MAJOR"
)
STAMP="$TOOLCHAIN_DIR/.installed-$RUST_DEB_VERSION"

mode=auto
check_only=0
for arg in "$@"; do
  case "$arg" in
    --debian) mode=debian ;;
    --rustup-only) mode=rustup ;;
    --check) check_only=1 ;;
    -h|--help) sed -n '2,20p' "$0"; exit 0 ;;
    *) echo "setup-riscv-toolchain: unknown argument '$arg'" >&2; exit 2 ;;
  esac
done

say() { echo "setup-riscv-toolchain: $*"; }

rustup_has_targets() {
  command -v rustup >/dev/null 2>&1 || return 1
  local installed
  installed="$(cd "$ROOT" && rustup target list --installed 2>/dev/null)" || return 1
  for t in "${TARGETS[@]}"; do
    grep -qx "$t" <<<"$installed" || return 1
  done
}

debian_ready() {
  [[ -f "$STAMP" && -x "$TOOLCHAIN_DIR/usr/bin/rustc" \
     && -d "$TOOLCHAIN_DIR/usr/lib/rustlib/x86_64-unknown-linux-gnu/lib" \
     && -x "$TOOLCHAIN_DIR/usr/lib/llvm-$LLVM_MAJOR/bin/ld.lld" ]]
}

debian_rustc() {
  LD_LIBRARY_PATH="$TOOLCHAIN_DIR/usr/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" \
    "$TOOLCHAIN_DIR/usr/bin/rustc" "$@"
}

if [[ $check_only == 1 ]]; then
  if [[ $mode != debian ]] && rustup_has_targets; then say "ready: rustup targets ${TARGETS[*]}"; exit 0; fi
  if [[ $mode != rustup ]] && debian_ready; then say "ready: Debian toolchain in .toolchain/"; exit 0; fi
  say "no RISC-V toolchain ready"; exit 1
fi

# ---- Step 1: rustup -------------------------------------------------------------
if [[ $mode != debian ]]; then
  if rustup_has_targets; then
    say "rustup targets already installed: ${TARGETS[*]} (nothing to do)"
    exit 0
  fi
  if command -v rustup >/dev/null 2>&1; then
    say "trying: rustup target add ${TARGETS[*]}"
    # rustup may hang on a network that drops packets instead of refusing them.
    if (cd "$ROOT" && timeout 300 rustup target add "${TARGETS[@]}"); then
      say "installed rustup targets: ${TARGETS[*]}"
      exit 0
    fi
    say "rustup target add failed; falling back to Debian packages"
  else
    say "rustup not found; falling back to Debian packages"
  fi
  if [[ $mode == rustup ]]; then exit 1; fi
fi

# ---- Step 2: Debian packages unpacked into .toolchain/ --------------------------
if debian_ready; then
  say "Debian toolchain already in .toolchain/ ($(debian_rustc --version))"
  exit 0
fi

for tool in apt-get dpkg; do
  command -v "$tool" >/dev/null 2>&1 || { say "'$tool' not found: cannot unpack the Debian toolchain"; exit 1; }
done

DEB_DIR="$TOOLCHAIN_DIR/debs"
mkdir -p "$DEB_DIR"
# apt-get download drops privileges to _apt, which cannot write into a root-owned
# folder; a world-writable download dir avoids the warning and the fallback.
chmod 0777 "$DEB_DIR" 2>/dev/null || true

download() {
  (cd "$DEB_DIR" && apt-get download -q "$@")
}

say "downloading: ${DEB_PACKAGES[*]}"
if ! download "${DEB_PACKAGES[@]}"; then
  say "package(s) not found; running apt-get update and retrying"
  apt-get update -q
  download "${DEB_PACKAGES[@]}"
fi

unpack_all() {
  local deb
  for deb in "$DEB_DIR"/*.deb; do
    dpkg -x "$deb" "$TOOLCHAIN_DIR"
  done
}
say "unpacking into .toolchain/"
unpack_all

# ---- Shared libraries the unpacked binaries need but the system lacks -------------
missing_libs() {
  LD_LIBRARY_PATH="$TOOLCHAIN_DIR/usr/lib/x86_64-linux-gnu" \
    ldd "$TOOLCHAIN_DIR/usr/bin/rustc" "$TOOLCHAIN_DIR/usr/lib/llvm-$LLVM_MAJOR/bin/ld.lld" \
        "$TOOLCHAIN_DIR"/usr/lib/x86_64-linux-gnu/*.so* 2>/dev/null \
    | awk '/not found/ {print $1}' | sort -u
}

missing="$(missing_libs)"
if [[ -n "$missing" ]]; then
  say "missing shared libraries: $(echo $missing)"
  # Fetch the direct dependencies of our packages that are not installed system-wide.
  extra=()
  for pkg in "${DEB_PACKAGES[@]}"; do
    name="${pkg%%=*}"
    while read -r dep; do
      [[ -z "$dep" || "$dep" == \<* ]] && continue
      if ! dpkg-query -W -f='${Status}' "$dep" 2>/dev/null | grep -q "install ok installed"; then
        extra+=("$dep")
      fi
    done < <(apt-cache depends --no-recommends --no-suggests --no-conflicts --no-breaks \
               --no-replaces --no-enhances "$name" | awk '/Depends:/ {print $2}')
  done
  if [[ ${#extra[@]} -gt 0 ]]; then
    mapfile -t extra < <(printf '%s\n' "${extra[@]}" | sort -u)
    say "downloading dependencies not installed on this system: ${extra[*]}"
    download "${extra[@]}"
    unpack_all
  fi
  missing="$(missing_libs)"
  if [[ -n "$missing" ]]; then
    say "still missing after unpacking dependencies: $(echo $missing)"
    say "install them with apt-get, or run this script with the rustup path available"
    exit 1
  fi
fi

version="$(debian_rustc --version)"
touch "$STAMP"
say "Debian toolchain ready in .toolchain/: $version, $(LD_LIBRARY_PATH="$TOOLCHAIN_DIR/usr/lib/x86_64-linux-gnu" \
  "$TOOLCHAIN_DIR/usr/lib/llvm-$LLVM_MAJOR/bin/ld.lld" --version 2>/dev/null | head -1)"
# The stamp marks the unpacked tree complete; the archives are no longer needed.
rm -rf "$DEB_DIR"
