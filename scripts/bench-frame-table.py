#!/usr/bin/env python3
"""Writes the BENCHMARKS.md table of `gridrt bench frame` (issue 10) from its JSON reports,
one per scene, with GridRT's and ViRAY's published figures beside them.

Every cell says what it is: measured (QEMU instruction counts, host wall time, image
comparison), modelled (the frame-time model of `host/src/bench/frame/`), published (the
seeds' figures: ViRAY, seed 000, and GridRT, seed 004; ARCHITECTURE.md "Where each seed lives") or a bound derived from a published rate.

    python3 scripts/bench-frame-table.py out/frame-res4.json out/frame-bunny.json out/frame-viray.json
"""

import json
import sys
from pathlib import Path

# Seed 004 (GridRT, Nery 2010) §6.3.2: 648 cycles per intersection, 4 PEs at 50 MHz; no
# full-frame time is reported.
GRIDRT_CYCLES_PER_TEST = 648
GRIDRT_PES = 4
GRIDRT_HZ = 50e6
GRIDRT_TESTS_PER_S = GRIDRT_PES * GRIDRT_HZ / GRIDRT_CYCLES_PER_TEST
# Seed 000 (ViRAY, Jurgielewicz 2018): 1920×1080 in 52.4 ms at 320 MHz, 4 rays per pixel,
# quoted as 158.29 M rays/s; a constant 8 cycles per pixel (II = 8), whatever the scene.
VIRAY_RAYS_PER_S = 158.29e6
VIRAY_FRAME_MS_1080P = 52.4
VIRAY_HZ = 320e6
VIRAY_CYCLES_PER_PIXEL = 8


def num(v, digits=1):
    """A number with thin-space thousands, as BENCHMARKS.md writes them."""
    s = f"{v:,.{digits}f}"
    return s.replace(",", " ")


def image(row):
    if row["identical"]:
        return "identical"
    return f"{row['psnr_db']:.1f} dB" if row["psnr_db"] is not None else "?"


def cpu_profiles(r):
    """How each target's soft-core time was charged: the report's CPI model, or the CPI per
    stage measured on the SoC (`--cpu-measured`, rows with `cpu_source` = "rtl")."""
    parts = []
    for target in dict.fromkeys(row["target"] for row in r["rows"] if row["target"].startswith("riscv")):
        row = next(x for x in r["rows"] if x["target"] == target)
        if row.get("cpu_source") == "rtl" and row.get("cpi_by_stage"):
            stages = ", ".join(f"{k} {v:.2f}" for k, v in sorted(row["cpi_by_stage"].items()))
            parts.append(f"{target}: {row['cpu_profile']}, CPI per stage measured in the SoC simulation: {stages}")
        else:
            parts.append(f"{target}: {r['cpu_profile']}, CPI {r['cpi']}")
    return "; ".join(parts) or f"{r['cpu_profile']}, CPI {r['cpi']}"


def scene_table(r):
    name = Path(r["scene"]).name
    out = []
    out.append(
        f"**{name}** ({r['triangles']} triangles, grid {'×'.join(map(str, r['grid']))}, {r['pe_count']} PEs, "
        f"plan [{', '.join(r['plan'])}]), {r['width']}×{r['height']}, soft-core at {num(r['clock_mhz'], 0)} MHz "
        f"({cpu_profiles(r)}), {num(r['baud'], 0)} baud, `{r['encoding']}`; "
        f"upload {num(r['upload_bytes'] or 0, 0)} B = {num((r['upload_ms'] or 0) / 1e3, 2)} s, not in the frame:"
    )
    out.append("")
    out.append(
        "| configuration | target | kernel | instr./primary ray (measured, QEMU) | soft-core ms (modelled) "
        "| co-processor ms (modelled) | link ms (modelled) | **frame ms** | fps | image vs f64 reference (measured) |"
    )
    out.append("|---|---|---|---:|---:|---:|---:|---:|---:|---|")
    rays = None
    pe_tests = None
    for row in r["rows"]:
        measured = row["frame_ms_source"] == "measured"
        ipr = row["instructions_per_primary_ray"]
        cop = row["coproc_ms"]
        if row.get("coproc_profile"):
            clock = row.get("coproc_clock_mhz") or r["clock_mhz"]  # reports before the rtl row: one clock
            cop_cell = f"{num(cop)} ({row['coproc_profile']}, {row['coproc_test_cycles']} cy/test, {num(clock, 0)} MHz)"
        else:
            cop_cell = "—"
        out.append(
            "| {} | {} | {} | {} | {} | {} | {} | **{}**{} | {} | {} |".format(
                row["config"],
                row["target"],
                row.get("kernel") or f"{r['kernel']}/{r['number_format']}",
                num(ipr, 0) if ipr is not None else "—",
                f"{num(row['cpu_ms'])} (measured wall time)" if measured else num(row["cpu_ms"]),
                cop_cell,
                "—" if measured else num(row["link_ms"]),
                num(row["frame_ms"]),
                " (measured)" if measured else " (modelled)",
                num(row["fps"], 3 if row["fps"] < 1 else 2),
                image(row),
            )
        )
        if rays is None:
            rays = row["primary_rays"] + row["shadow_rays"] + row.get("reflection_rays", 0)
        if row["config"] == "gridrt":
            pe_tests = row["intersection_tests"]
    # Published figures beside them.
    if pe_tests is not None:
        ms = pe_tests / GRIDRT_TESTS_PER_S * 1e3
        out.append(
            f"| GridRT, published (seed 004) | Virtex-5, MicroBlaze | Cramer f32, {GRIDRT_CYCLES_PER_TEST} cy/test | — | no frame time published "
            f"| {num(ms)} = this frame's {num(pe_tests, 0)} PE tests ÷ {num(GRIDRT_TESTS_PER_S / 1e3)} k tests/s (bound from the published rate) "
            f"| — | — | — | — |"
        )
    px = r["width"] * r["height"]
    viray_px_ms = px * VIRAY_CYCLES_PER_PIXEL / VIRAY_HZ * 1e3
    if r["triangles"] == 0 and rays is not None:
        bound_ms = rays / VIRAY_RAYS_PER_S * 1e3
        out.append(
            f"| ViRAY, published (seed 000) | KCU116, HLS pipeline | analytic, f32 | — | — | — | — "
            f"| **{num(viray_px_ms, 2)}** (published {VIRAY_FRAME_MS_1080P} ms at 1920×1080, scaled by its constant "
            f"{VIRAY_CYCLES_PER_PIXEL} cycles/pixel at 320 MHz) | {num(1e3 / viray_px_ms, 0)} | — |"
        )
        out.append(
            f"| ray-count bound at ViRAY's rate | — | — | — | — | — | — "
            f"| **{num(bound_ms, 2)}** (bound: this frame's {num(rays, 0)} rays ÷ published 158.29 M rays/s) "
            f"| {num(1e3 / bound_ms, 0)} | — |"
        )
    else:
        out.append(
            "| ViRAY, published (seed 000) | KCU116, HLS pipeline | — | — | — | — | — "
            "| no triangles or acceleration structure: not comparable on a mesh | — | — |"
        )
    return "\n".join(out)


def main(paths):
    if not paths:
        print(__doc__, file=sys.stderr)
        return 2
    reports = [json.loads(Path(p).read_text()) for p in paths]
    print("\n\n".join(scene_table(r) for r in reports))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
