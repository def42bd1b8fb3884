#!/usr/bin/env python3
"""Tests of scripts/qemu-profile.py's call stack (run by .ci/run): inclusive counts and
callers from a synthetic run, a return that skips a frame, and a log parsed into blocks and
counted per address.

    python3 scripts/test_qemu_profile.py
"""

import importlib.util
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
spec = importlib.util.spec_from_file_location("qemu_profile", ROOT / "scripts" / "qemu-profile.py")
qp = importlib.util.module_from_spec(spec)
spec.loader.exec_module(qp)

# Functions by address: main 0x100.., f 0x200.., g 0x300...
def function_of(pc):
    return {1: "main", 2: "f", 3: "g"}[pc >> 8]


def block(start, n, call=False):
    """n 4-byte instructions from `start`, the last a call when `call`."""
    return [(start + 4 * i, 4, call and i == n - 1) for i in range(n)]


def check(cond, what):
    if not cond:
        raise SystemExit(f"test_qemu_profile: FAILED: {what}")


# main (3, calls f) -> f (2, calls g) -> g (5) -> back in f (1) -> back in main (4).
run = [block(0x100, 3, True), block(0x200, 2, True), block(0x300, 5), block(0x208, 1), block(0x10C, 4)]
inclusive, own, by_caller = qp.inclusive_counts(run, function_of)
check(own == {"main": 7, "f": 3, "g": 5}, f"own counts {own}")
check(inclusive["main"] == 15 and inclusive["f"] == 8 and inclusive["g"] == 5, f"inclusive {inclusive}")
check(by_caller[("g", "f")] == 5 and by_caller[("f", "main")] == 3, f"callers {by_caller}")

# g returns straight to main (f's frame skipped): the instructions after count for main only.
run = [block(0x100, 3, True), block(0x200, 2, True), block(0x300, 5), block(0x10C, 4)]
inclusive, own, _ = qp.inclusive_counts(run, function_of)
check(inclusive["f"] == 7 and inclusive["main"] == 14, f"skipped frame {inclusive}")

# A compressed call (2 bytes): the return address is the next halfword.
run = [[(0x100, 4, False), (0x104, 2, True)], block(0x200, 3), block(0x106, 2)]
inclusive, own, by_caller = qp.inclusive_counts(run, function_of)
check(inclusive["f"] == 3 and inclusive["main"] == 7 and own["main"] == 4, f"compressed call {inclusive}")
# Returned: main's instructions after the call have no caller (a stale frame would be main's).
check(("main", "main") not in by_caller, f"compressed call's return {by_caller}")

# A QEMU log: a block translated once and run twice, its last instruction a call.
log = (
    "Trace 0: 0x7f00 [00000000/80000000/0/00000000] \n"
    "0x80000000:  00000297          auipc                   t0,0\n"
    "0x80000004:  4501              addi                    a0,zero,0\n"
    "0x80000006:  008000ef          jal                     ra,8\n"
    "Trace 0: 0x7f00 [00000000/80000000/0/00000000] \n"
    "Trace 0: 0x7f80 [00000000/80000010/0/00000000] \n"
    "0x80000010:  00008067          ret                     \n"
)
# In QEMU's log a block's instructions come before its first Trace line.
lines = log.splitlines(keepends=True)
log = "".join([lines[1], lines[2], lines[3], lines[0], lines[4], lines[6], lines[5]])
with tempfile.NamedTemporaryFile("w", suffix=".log", delete=False) as f:
    f.write(log)
blocks = list(qp.read_blocks(f.name))
counts = qp.read_log(f.name)
Path(f.name).unlink()
check(counts == {0x80000000: 2, 0x80000004: 2, 0x80000006: 2, 0x80000010: 1}, f"counts per pc {counts}")
check(len(blocks) == 3, f"blocks {blocks}")
check(blocks[0] == [(0x80000000, 4, False), (0x80000004, 2, False), (0x80000006, 4, True)], f"block {blocks[0]}")
check(blocks[2] == [(0x80000010, 4, False)], f"ret block {blocks[2]}")
# Laps at 0x104 (in main) and 0x304 (in g): main 0x104.. -> f -> g up to 0x304, twice.
laps = {0x104, 0x304}
run = [block(0x100, 3, True), block(0x200, 2, True), block(0x300, 3), block(0x100, 3, True), block(0x200, 2, True), block(0x300, 3)]
passes, per_function = qp.lap_spans(run, laps, function_of)
check(passes == {(0x104, 0x304): 2, (0x304, 0x104): 1}, f"lap passes {passes}")
# From main's read: main's 2 (the read and the call), f's 2, g's 1 before its read; twice.
check(per_function[(0x104, 0x304)] == {"main": 4, "f": 4, "g": 2}, f"lap span {per_function[(0x104, 0x304)]}")
check(per_function[(0x304, 0x104)] == {"g": 2, "main": 1}, f"lap span back {per_function[(0x304, 0x104)]}")

print("test_qemu_profile: all checks passed")
