"""A placed nextpnr-ecp5 design (`nextpnr-ecp5 ... --write placed.json`), for the scripts
that read one (pnr-congestion.py --placement, pnr-paths.py)."""
import json
import re
import sys

_TILE = re.compile(r"X(\d+)/Y(\d+)/")


def load_cells(path, tool):
    """The top module's cells, {name: cell}; exits with `tool: path: reason` when the file
    is not a placed design."""
    try:
        with open(path) as f:
            design = json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"{tool}: {path}: {e}")
    top = next(iter(design.get("modules", {}).values()), {})
    cells = top.get("cells", {})
    if not any(tile_xy(c) for c in cells.values()):
        sys.exit(f"{tool}: no placed cells in {path}")
    return cells


def tile_xy(cell):
    """(x, y) of the tile a cell is placed in, or None."""
    m = _TILE.match(cell.get("attributes", {}).get("NEXTPNR_BEL", ""))
    return (int(m.group(1)), int(m.group(2))) if m else None
