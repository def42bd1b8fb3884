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

--function prints that function's instructions with their execution counts. --inclusive
counts each function with everything it calls, and --callers NAME splits a function's own
instructions by its caller; both follow a call stack kept from the log: a block whose last
instruction is `jal`/`jalr` writing `ra` is a call (its return address is pushed), a block
that starts at one of the six newest return addresses is a return (the frames above it are
dropped). Estimates where code leaves a function other than by its return address.

--laps splits the run at every `csrr …, minstret` (the firmware's stage laps, and the
qemu-virt link's reads around the model) and lists the most-executed spans from one such
read to the next: instructions per pass, and per function inside. A stage's cost per ray,
cut where the stopwatch cuts it.
"""

import argparse
import bisect
import collections
import re
import subprocess
import sys


CALL = re.compile(rb"\bjalr?\s+ra,")


def executions(path):
    """Each execution of a translated block, in order: its host key and its instructions,
    a list of (pc, size, is_call), or None when the log did not show its translation."""
    blocks = {}  # host address of a translated block -> its guest instructions
    pending = []
    with open(path, "rb") as f:
        for line in f:
            if line.startswith(b"Trace"):
                # "Trace 0: 0x7f… [cpu/pc/flags/…] symbol": the block's host address is the key.
                key = line[9 : line.index(b"[")].strip()
                if pending:
                    blocks[key] = pending
                    pending = []
                yield key, blocks.get(key)
            elif line.startswith(b"0x"):
                # "0x80000000:  00000297          auipc t0,0": 8 hex digits of code are 4 bytes.
                rest = line[11:].strip()
                code = rest.split()[0] if rest else b""
                pending.append((int(line[2:10], 16), 2 if len(code) == 4 else 4, bool(CALL.search(rest))))


def read_log(path):
    """Executions per instruction address."""
    runs = collections.Counter()
    blocks = {}
    for key, block in executions(path):
        runs[key] += 1
        if block:
            blocks[key] = block
    counts = collections.Counter()
    for key, n in runs.items():
        for pc, _, _ in blocks.get(key, ()):
            counts[pc] += n
    return counts


def read_blocks(path):
    """The executed blocks in order: each a list of (pc, size, is_call) of its instructions."""
    return (block for _, block in executions(path) if block)


def inclusive_counts(blocks, function_of, depth=6):
    """Per function: (inclusive, own) instructions, and per (function, caller) the function's
    own instructions, from executed `blocks` (lists of (pc, size, is_call)) and `function_of`
    (pc -> function name)."""
    inclusive = collections.Counter()
    own = collections.Counter()
    by_caller = collections.Counter()
    stack = []  # (return address, caller)
    for block in blocks:
        start = block[0][0]
        for k in range(len(stack) - 1, max(len(stack) - 1 - depth, -1), -1):
            if stack[k][0] == start:
                del stack[k:]
                break
        here = function_of(start)
        n = len(block)
        for name in {here, *(caller for _, caller in stack)}:
            inclusive[name] += n
        own[here] += n
        if stack:
            by_caller[(here, stack[-1][1])] += n
        pc, size, is_call = block[-1]
        if is_call:
            stack.append((pc + size, here))
    return inclusive, own, by_caller


def lap_points(elf):
    """Addresses of the ELF's `csrr …, minstret` instructions (the counter reads)."""
    dis = subprocess.run(["llvm-objdump", "-d", "--no-show-raw-insn", elf], capture_output=True, text=True, check=True).stdout
    return {int(m.group(1), 16) for m in re.finditer(r"^\s*([0-9a-f]+):\s+csrr\s+\w+, minstret", dis, re.M)}


def lap_spans(blocks, laps, function_of):
    """Splits executed `blocks` at each instruction whose pc is in `laps`. Per span (lap pc,
    next lap pc): its passes, and its instructions per function (the first read's own
    counted in its span, the second's in the next)."""
    passes = collections.Counter()
    per_function = collections.defaultdict(collections.Counter)
    names = {}
    prev, span = None, collections.Counter()
    for block in blocks:
        for pc, _, _ in block:
            if pc in laps:
                if prev is not None:
                    passes[(prev, pc)] += 1
                    per_function[(prev, pc)].update(span)
                prev, span = pc, collections.Counter()
            name = names.get(pc)
            if name is None:
                name = names[pc] = function_of(pc)
            span[name] += 1
    return passes, per_function


def symbols(elf):
    """(start, size, name) of the ELF's functions, sorted; local labels left out."""
    out = subprocess.run(["nm", "-C", "--defined-only", "-n", "-S", elf], capture_output=True, text=True, check=True)
    syms = []
    for line in out.stdout.splitlines():
        parts = line.split(" ", 3)
        if len(parts) == 4 and parts[2] in "tTwW" and not parts[3].startswith((".L", "$")):
            syms.append((int(parts[0], 16), int(parts[1], 16), parts[3]))
    return sorted(syms)


def function_lookup(syms):
    """pc -> the name of the function of `syms` (from `symbols`) holding it, or "(no symbol)"."""
    starts = [s for s, _, _ in syms]

    def function_of(pc):
        i = bisect.bisect_right(starts, pc) - 1
        return syms[i][2] if i >= 0 and pc < syms[i][0] + max(syms[i][1], 1) else "(no symbol)"

    return function_of


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], epilog="See the module docstring for how to record the log.")
    ap.add_argument("log", help="QEMU log written with -d in_asm,exec,nochain -D LOG")
    ap.add_argument("elf", help="the firmware image QEMU ran")
    ap.add_argument("--top", type=int, default=40, help="functions to list (default 40)")
    ap.add_argument("--function", help="print the instructions of the function whose name contains this, with counts")
    ap.add_argument("--inclusive", action="store_true", help="count each function with what it calls (see above)")
    ap.add_argument("--callers", metavar="NAME", help="split the own instructions of functions named like this by caller")
    ap.add_argument("--laps", action="store_true", help="the spans between counter reads (stage laps), per pass (see above)")
    args = ap.parse_args()

    syms = symbols(args.elf)
    function_of = function_lookup(syms)
    if args.laps:
        passes, per_function = lap_spans(read_blocks(args.log), lap_points(args.elf), function_of)
        if not passes:
            sys.exit(f"qemu-profile: {args.log} passes no two counter reads of {args.elf}")
        total = {k: sum(c.values()) for k, c in per_function.items()}
        print(f"{'instructions':>12} {'passes':>8} {'per pass':>9}  from -> to (counter reads)")
        for k in sorted(total, key=total.get, reverse=True)[: args.top]:
            a, b = k
            print(f"{total[k]:12d} {passes[k]:8d} {total[k] / passes[k]:9.1f}  {a:#x} {function_of(a)[:50]} -> {b:#x} {function_of(b)[:50]}")
            for name, n in per_function[k].most_common(6):
                print(f"{'':32}{n / passes[k]:9.1f}  {name[:100]}")
        return
    if args.inclusive or args.callers:
        inclusive, own, by_caller = inclusive_counts(read_blocks(args.log), function_of)
        if not own:
            sys.exit(f"qemu-profile: {args.log} holds no executed block (was it written with -d in_asm,exec,nochain?)")
        print(f"{sum(own.values())} instructions executed")
        if args.inclusive:
            print(f"{'inclusive':>12} {'own':>12}  function")
            for name, n in inclusive.most_common(args.top):
                print(f"{n:12d} {own[name]:12d}  {name[:150]}")
        if args.callers:
            for (name, caller), n in by_caller.most_common():
                if args.callers in name:
                    print(f"{n:12d}  {name[:60]} <- {caller[:100]}")
        return

    counts = read_log(args.log)
    if not counts:
        sys.exit(f"qemu-profile: {args.log} holds no executed block (was it written with -d in_asm,exec,nochain?)")
    per_function = collections.Counter()
    for pc, n in counts.items():
        per_function[function_of(pc)] += n
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
