#!/usr/bin/env python3
"""Longest register-to-register paths of a placed (not yet routed) nextpnr-ecp5 netlist.

nextpnr prints a critical path only after routing, which takes hours for the 4-PE design on
this machine. This script estimates the paths from the placement alone, so a timing fix can
be aimed before routing:

    nextpnr-ecp5 ... --no-route --write placed.json
    scripts/pnr-paths.py placed.json [--top 20] [--freq 50]

Net delays are nextpnr-ecp5's own placement estimate (`Arch::predictDelay`, speed grade 6:
26 ps x (6 + max(dx-5,0) + max(dy-5,0) + 2(min(dx,5) + min(dy,5))), 0 for carry chains and
within a tile). Cell delays are round figures for speed grade 6 (the constants below), not
nextpnr's timing database, so the sums rank paths and show their shape; they are not
nextpnr's numbers (on one 4-PE placement: 27 ns here, 40 ns in nextpnr's estimate). Output:
the worst path to each of the --top worst (end module, start module) pairs, hop by hop (arrival,
the wire's delay, the driving cell's type, pin, tile, module and HDL line); then the worst
path per (start module -> end module) pair.
"""
import argparse
import collections
import re
import sys

import nextpnr_placed

# Round cell delays in ns (speed grade 6): clock to output per sequential cell type, then
# the combinational arcs.
CLK_TO_Q = {"TRELLIS_FF": 0.40, "DP16KD": 4.20, "MULT18X18D": 0.0, "TRELLIS_COMB": 0.50}
LUT_NS = 0.45           # A..D -> F of a LUT4
MUX_NS = 0.20           # PFUMX / L6MUX21 level (OFX)
CARRY_NS = 0.06         # FCI -> FCO of a CCU2C (two bits)
MULT_NS = 4.60          # MULT18X18D with no internal registers, A/B -> P
SETUP_NS = 0.10
PS_PER_UNIT = 80 - 9 * 6


def net_delay(src, dst, src_pin, dst_pin):
    if src_pin == "FCO" and dst_pin == "FCI":
        return 0.0
    if src is None or dst is None:
        return 0.0
    dx, dy = abs(src[0] - dst[0]), abs(src[1] - dst[1])
    # Same tile: a LUT into its flip-flop, or any slice output into a LUT input (local wires).
    if dx == 0 and dy == 0 and ((src_pin == "F" and dst_pin in ("DI", "M")) or dst_pin in ("A", "B", "C", "D")):
        return 0.0
    units = 6 + max(dx - 5, 0) + max(dy - 5, 0) + 2 * (min(dx, 5) + min(dy, 5))
    return PS_PER_UNIT * units / 1000.0


def module_of(name):
    """The instance path without the last element, generate-block indices kept."""
    name = name.split("$")[0]
    parts = name.split(".")
    keep = [p for p in parts[:-1] if p.startswith(("g_", "u_"))]
    return ".".join(keep) or "(top)"


def source_of(cell):
    """The cell's first HDL source location, file name and line only."""
    src = cell.get("attributes", {}).get("src", "").split("|")[0]
    m = re.match(r".*/([^/]+\.s?v):(\d+)", src)
    return f"{m.group(1)}:{m.group(2)}" if m else ""


def is_sequential_input(cell, pin):
    t = cell["type"]
    if t == "TRELLIS_FF":
        return True
    if t in ("DP16KD",):
        return True
    if t == "TRELLIS_COMB" and cell["parameters"].get("MODE") in ("DPRAM", "RAMW_BLOCK"):
        return pin.startswith(("WD", "WAD", "WRE", "DI"))
    if t in ("TRELLIS_IO", "DCCA", "TRELLIS_RAMW"):
        return True
    return False


def comb_delay(cell, in_pin, out_pin):
    t = cell["type"]
    if t == "MULT18X18D":
        return MULT_NS
    if t == "TRELLIS_COMB":
        if in_pin == "FCI":
            return CARRY_NS if out_pin == "FCO" else 0.30
        if out_pin == "FCO":
            return 0.40
        if out_pin == "OFX":
            # FXA/FXB: the previous mux level; M: the mux select; A..D: through the LUT.
            return MUX_NS if in_pin in ("FXA", "FXB", "M") else LUT_NS + MUX_NS
        return LUT_NS
    if t == "TRELLIS_RAMW":
        return 0.0
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("placed", help="nextpnr --write output of a placed design")
    ap.add_argument("--top", type=int, default=15, help="paths to print")
    ap.add_argument("--freq", type=float, default=50.0, help="clock target in MHz (for slack)")
    args = ap.parse_args()

    print(f"reading {args.placed} ...", file=sys.stderr)
    cells = nextpnr_placed.load_cells(args.placed, "pnr-paths")
    driver = {}                     # bit -> (cell, pin)
    sinks = collections.defaultdict(list)
    for name, c in cells.items():
        for pin, bits in c["connections"].items():
            d = c["port_directions"].get(pin)
            for b in bits:
                if isinstance(b, str):
                    continue
                if d == "output":
                    driver[b] = (name, pin)
                else:
                    sinks[b].append((name, pin))
    xy = {n: nextpnr_placed.tile_xy(c) for n, c in cells.items()}

    # Node = (cell, output pin). Arrival = longest delay from a register's clock edge.
    outs = collections.defaultdict(list)    # cell -> its output pins with loads
    for b, (n, p) in driver.items():
        outs[n].append((p, b))
    ins = collections.defaultdict(list)     # cell -> [(pin, bit)]
    for name, c in cells.items():
        for pin, bits in c["connections"].items():
            if c["port_directions"].get(pin) != "output":
                for b in bits:
                    if not isinstance(b, str) and b in driver:
                        ins[name].append((pin, b))

    sys.setrecursionlimit(100000)
    arrival = {}    # (cell, out pin) -> (ns, predecessor (cell, out pin) or None, hop ns)
    clock_nets = set()
    for name, c in cells.items():
        if c["type"] == "TRELLIS_FF":
            clock_nets.update(c["connections"].get("CLK", []))

    def arr(node):
        if node in arrival:
            return arrival[node][0]
        name, pin = node
        c = cells[name]
        t = c["type"]
        if name.startswith("$PACKER_") or t == "TRELLIS_IO":
            # Constants, and inputs (unconstrained: nextpnr times clk only).
            arrival[node] = (-1e9, None, 0.0)
            return arrival[node][0]
        if t in ("TRELLIS_FF", "DP16KD", "DCCA") or (
                t == "TRELLIS_COMB" and c["parameters"].get("MODE") == "RAMW_BLOCK"):
            arrival[node] = (CLK_TO_Q.get(t, 0.0), None, 0.0)
            return arrival[node][0]
        arrival[node] = (0.0, None, 0.0)    # breaks combinational loops
        best = (0.0, None, 0.0)
        for ipin, b in ins[name]:
            if b in clock_nets:
                continue
            cd = comb_delay(c, ipin, pin)
            if cd is None:
                continue
            src = driver[b]
            nd = net_delay(xy[src[0]], xy[name], src[1], ipin)
            a = arr(src) + nd + cd
            if a > best[0]:
                best = (a, src, nd)
        arrival[node] = best
        return best[0]

    # Endpoints: sequential inputs.
    ends = []
    for name, c in cells.items():
        for ipin, b in ins[name]:
            if b in clock_nets or not is_sequential_input(c, ipin) or c["type"] == "TRELLIS_IO":
                continue
            src = driver[b]
            if cells[src[0]]["type"] in ("TRELLIS_IO", "DCCA"):
                continue
            nd = net_delay(xy[src[0]], xy[name], src[1], ipin)
            ends.append((arr(src) + nd + SETUP_NS, name, ipin, src, nd))
    ends.sort(reverse=True)
    period = 1000.0 / args.freq
    fails = sum(1 for e in ends if e[0] > period)
    print(f"{len(ends)} endpoints; {fails} over {period:.1f} ns; worst {ends[0][0]:.2f} ns "
          "(this script's estimate, not nextpnr's)")

    def trace(src):
        hops = []
        node = src
        while node is not None:
            a, pred, nd = arrival[node]
            hops.append((node, a, nd))
            node = pred
        return list(reversed(hops))

    shown = set()
    printed = 0
    for total, name, ipin, src, nd in ends:
        key = (module_of(name), module_of(trace(src)[0][0][0]))
        if key in shown:
            continue
        shown.add(key)
        printed += 1
        print(f"\n{total:6.2f} ns -> {name} ({ipin})")
        for (cn, cp), a, hop in trace(src):
            x = xy[cn]
            print(f"   {a:6.2f}  +{hop:4.2f} net  {cells[cn]['type']:<11} {cp:<4} X{x[0]:>3} Y{x[1]:>3}  "
                  f"{module_of(cn):<28} {source_of(cells[cn])}")
        print(f"   +{nd:4.2f} net to X{xy[name][0]} Y{xy[name][1]}")
        if printed >= args.top:
            break

    worst = {}
    for total, name, ipin, src, nd in ends:
        key = (module_of(trace(src)[0][0][0]), module_of(name))
        if key not in worst:
            worst[key] = total
        if len(worst) > 60:
            break
    print("\nworst path per (start module -> end module):")
    for (a, b), t in sorted(worst.items(), key=lambda kv: -kv[1])[:40]:
        print(f"  {t:6.2f} ns  {a} -> {b}")


if __name__ == "__main__":
    main()
