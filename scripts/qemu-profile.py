#!/usr/bin/env python3
"""Instructions per function of a firmware run on QEMU, from QEMU's own execution log.

QEMU logs each translated block once (`-d in_asm`: its instructions) and each execution of
one (`-d exec`; `nochain` so that chained blocks are logged too). This script counts every
instruction of every executed block and sums them per function of the ELF's symbol table:
exact counts, like `-icount shift=0`'s, not samples.

Record (the co-processor model runs on the same hart on qemu-virt; its functions appear too):

    qemu-system-riscv32 -machine virt -bios none -m 128M -smp 1 -display none -monitor none \\
        -icount shift=0 -serial pty -kernel APP.elf -d in_asm,exec,nochain -D qemu.log
    gridrt render --port /dev/pts/N --scene … --width 80 --height 60 --out q.png

(the log grows by about 20 bytes per instruction: 3.8 GB for an 80×60 frame of
bun_zipper_res4), then

    python3 scripts/qemu-profile.py qemu.log APP.elf [--top 40] [--function NAME]

--function prints that function's instructions with their execution counts.
"""

import argparse
import bisect
import collections
import re
import subprocess
import sys


def read_log(path):
    """Executions per instruction address."""
    blocks = {}  # host address of a translated block -> its guest instruction addresses
    runs = collections.Counter()
    pending = []
    with open(path, "rb") as f:
        for line in f:
            if line.startswith(b"Trace"):
                # "Trace 0: 0x7f… [cpu/pc/flags/…] symbol": the block's host address is the key.
                key = line[9 : line.index(b"[")].strip()
                if pending:
                    blocks[key] = pending
                    pending = []
                runs[key] += 1
            elif line.startswith(b"0x"):
                pending.append(int(line[2:10], 16))
    counts = collections.Counter()
    for key, n in runs.items():
        for pc in blocks.get(key, ()):
            counts[pc] += n
    return counts


def symbols(elf):
    """(start, size, name) of the ELF's functions, sorted; local labels left out."""
    out = subprocess.run(["nm", "-C", "--defined-only", "-n", "-S", elf], capture_output=True, text=True, check=True)
    syms = []
    for line in out.stdout.splitlines():
        parts = line.split(" ", 3)
        if len(parts) == 4 and parts[2] in "tTwW" and not parts[3].startswith((".L", "$")):
            syms.append((int(parts[0], 16), int(parts[1], 16), parts[3]))
    return sorted(syms)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], epilog="See the module docstring for how to record the log.")
    ap.add_argument("log", help="QEMU log written with -d in_asm,exec,nochain -D LOG")
    ap.add_argument("elf", help="the firmware image QEMU ran")
    ap.add_argument("--top", type=int, default=40, help="functions to list (default 40)")
    ap.add_argument("--function", help="print the instructions of the function whose name contains this, with counts")
    args = ap.parse_args()

    counts = read_log(args.log)
    if not counts:
        sys.exit(f"qemu-profile: {args.log} holds no executed block (was it written with -d in_asm,exec,nochain?)")
    syms = symbols(args.elf)
    starts = [s for s, _, _ in syms]
    per_function = collections.Counter()
    for pc, n in counts.items():
        i = bisect.bisect_right(starts, pc) - 1
        inside = i >= 0 and pc < syms[i][0] + max(syms[i][1], 1)
        per_function[syms[i][2] if inside else "(no symbol)"] += n
    total = sum(per_function.values())
    print(f"{total} instructions executed")
    for name, n in per_function.most_common(args.top):
        print(f"{n:12d} {100 * n / total:5.1f} %  {name[:150]}")

    if args.function:
        match = [s for s in syms if args.function in s[2]]
        if not match:
            sys.exit(f"qemu-profile: no function named like {args.function!r}")
        start, size, name = match[0]
        dis = subprocess.run(
            ["llvm-objdump", "-d", "--no-show-raw-insn", f"--start-address={start:#x}", f"--stop-address={start + size:#x}", args.elf],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        print(f"\n{name}")
        for line in dis.splitlines():
            m = re.match(r"\s*([0-9a-f]+):\s+(.*)", line)
            if m:
                print(f"{counts.get(int(m.group(1), 16), 0):10d}  {m.group(1)}  {m.group(2)}")


if __name__ == "__main__":
    main()
