//! SPEC.md §7 (the registry of feature bits, flags, options and stat keys) against the code:
//! every constant the code defines has its row, with the same bit or key, and every row names
//! a constant the code has. The §7 table is what an outside client implements from.

use std::collections::BTreeMap;

use gridrt_shared::msg::{feature, region_options, render_flags, stat, FEATURE_BOOTLOADER, STAT_HARTS};
use gridrt_shared::scene::scene_flags;

/// `(field, bit or key as written, names)` of each row of SPEC.md §7's table.
fn spec_rows() -> Vec<(String, String, Vec<String>)> {
    let spec = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/SPEC.md")).unwrap();
    let start = spec.find("## 7. Registry").expect("SPEC.md has §7");
    let end = start + spec[start..].find("\n## 8.").expect("§8 follows §7");
    spec[start..end]
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| field") && !l.starts_with("|---"))
        .map(|l| {
            let cols: Vec<String> = l.split('|').map(|c| c.trim().replace('`', "")).collect();
            let names = cols[3].split(" / ").map(|n| n.trim().to_string()).collect();
            (cols[1].clone(), cols[2].clone(), names)
        })
        .collect()
}

/// The single bit of `mask`.
fn bit(mask: u32) -> String {
    assert_eq!(mask.count_ones(), 1, "{mask:#x} is not one bit");
    mask.trailing_zeros().to_string()
}

/// `key` as §7 writes it: decimal below 0x20, else `0xNN`.
fn key(k: u8) -> String {
    if k < 0x20 {
        k.to_string()
    } else {
        format!("0x{k:02X}")
    }
}

/// Every constant the code defines, as (field, bit or key, name).
fn code_rows() -> Vec<(&'static str, String, &'static str)> {
    let mut rows = Vec::new();
    let f = "Version.features";
    for (name, v) in [
        ("SHADOWS", feature::SHADOWS),
        ("PRIM_IDS", feature::PRIM_IDS),
        ("RENDER_REGION", feature::RENDER_REGION),
        ("RGB565", feature::RGB565),
        ("RLE", feature::RLE),
        ("WINDOWED", feature::WINDOWED),
        ("COMPACT_SCENE", feature::COMPACT_SCENE),
        ("REQUEST_QUEUE", feature::REQUEST_QUEUE),
        ("REFLECTIONS", feature::REFLECTIONS),
        ("TEXTURES", feature::TEXTURES),
        ("SPECULAR", feature::SPECULAR),
        ("INTERP", feature::INTERP),
        ("ANALYTIC_PRIMITIVES", feature::ANALYTIC_PRIMITIVES),
        ("SPLATS", feature::SPLATS),
        ("FEATURE_BOOTLOADER", FEATURE_BOOTLOADER),
    ] {
        rows.push((f, bit(v), name));
    }
    let f = "RenderRequest.flags";
    for (name, v) in [
        ("SHADOWS", render_flags::SHADOWS),
        ("PRIM_IDS", render_flags::PRIM_IDS),
        ("REFLECTIONS", render_flags::REFLECTIONS),
        ("TEXTURES", render_flags::TEXTURES),
        ("SPECULAR", render_flags::SPECULAR),
        ("INTERP_ADAPTIVE", render_flags::INTERP_ADAPTIVE),
        ("SPLAT_PIXEL_DEPTH", render_flags::SPLAT_PIXEL_DEPTH),
        ("SPLATS", render_flags::SPLATS),
    ] {
        rows.push((f, bit(v.into()), name));
    }
    let field = |mask: u16, shift: u32| format!("{}..{}", 15 - mask.leading_zeros(), shift);
    rows.push((f, field(render_flags::INTERP_STEP_MASK, render_flags::INTERP_STEP_SHIFT), "INTERP_STEP"));
    rows.push((f, field(render_flags::INTERP_EPS_MASK, render_flags::INTERP_EPS_SHIFT), "INTERP_EPS"));
    let f = "RenderRegion.options";
    for (name, v) in [
        ("CRC_ONLY", region_options::CRC_ONLY),
        ("NO_STATS", region_options::NO_STATS),
        ("SPAN_BYTES", region_options::SPAN_BYTES),
    ] {
        rows.push((f, bit(v.into()), name));
    }
    rows.push(("scene header flags", bit(scene_flags::POINTS.into()), "POINTS"));
    let f = "Stats key";
    for (name, k) in [
        ("PRIMARY_RAYS", stat::PRIMARY_RAYS),
        ("SHADOW_RAYS", stat::SHADOW_RAYS),
        ("COPROC_RAYS", stat::COPROC_RAYS),
        ("CULLED_RAYS", stat::CULLED_RAYS),
        ("FSL_WORDS_OUT", stat::FSL_WORDS_OUT),
        ("FSL_WORDS_IN", stat::FSL_WORDS_IN),
        ("INTERSECTION_TESTS", stat::INTERSECTION_TESTS),
        ("COPROC_CYCLES", stat::COPROC_CYCLES),
        ("PIXELS", stat::PIXELS),
        ("LIST_ENTRIES", stat::LIST_ENTRIES),
        ("REFLECTION_RAYS", stat::REFLECTION_RAYS),
        ("INTERPOLATED_PIXELS", stat::INTERPOLATED_PIXELS),
        ("INTERP_RETRACES", stat::INTERP_RETRACES),
        ("PLAN", stat::PLAN),
        ("FSL_WORDS_PRIMARY", stat::FSL_WORDS_PRIMARY),
        ("FSL_WORDS_SHADOW", stat::FSL_WORDS_SHADOW),
        ("FSL_WORDS_REFLECTION", stat::FSL_WORDS_REFLECTION),
        ("RAYS_IN_FLIGHT", stat::RAYS_IN_FLIGHT),
        ("MODEL_INSTRUCTIONS", stat::MODEL_INSTRUCTIONS),
        ("LINK_WRAPPER_INSTRUCTIONS", stat::LINK_WRAPPER_INSTRUCTIONS),
        ("FRAME_CYCLES", stat::FRAME_CYCLES),
        ("LINK_CYCLES", stat::LINK_CYCLES),
        ("FRAME_TX_BYTES", stat::FRAME_TX_BYTES),
        ("UPLOAD_CYCLES", stat::UPLOAD_CYCLES),
        ("UPLOAD_FEED_CYCLES", stat::UPLOAD_FEED_CYCLES),
        ("UPLOAD_PARSE_CYCLES", stat::UPLOAD_PARSE_CYCLES),
        ("SPLAT_POINTS", stat::SPLAT_POINTS),
        ("SPLAT_CODEWORDS", stat::SPLAT_CODEWORDS),
        ("SPLAT_CULLED", stat::SPLAT_CULLED),
        ("SPLAT_CLAMPED", stat::SPLAT_CLAMPED),
        ("SPLAT_COMMANDS", stat::SPLAT_COMMANDS),
        ("SPLAT_FRAGMENTS", stat::SPLAT_FRAGMENTS),
    ] {
        rows.push((f, key(k), name));
    }
    rows
}

#[test]
fn every_bit_and_key_of_the_code_has_its_row_in_spec_section_7() {
    let spec = spec_rows();
    assert!(spec.len() > 40, "§7's table was not found whole: {} rows", spec.len());
    for (field, value, name) in code_rows() {
        let row = spec.iter().find(|(f, _, names)| f == field && names.iter().any(|n| n == name));
        let Some((_, spec_value, _)) = row else { panic!("SPEC.md §7 has no row for {field} {name}") };
        assert_eq!(spec_value, &value, "SPEC.md §7 gives {field} {name} as {spec_value}, the code as {value}");
    }
    // The per-stage keys: instructions at 0x40 + 2s, cycles at 0x41 + 2s; the splat stages at
    // s = 5 and 6.
    assert_eq!((stat::STAGE_BASE, stat::STAGE_SPLAT_CODEGEN, stat::STAGE_SPLAT_STAGE), (0x40, 0x4A, 0x4C));
    assert!(spec.iter().any(|(f, v, _)| f == "Stats key" && v == "0x40 + 2s"));
    // The per-hart keys: base + h for harts h = 0..=3.
    for (base, name) in [
        (stat::HART_ROWS_BASE, "HART_ROWS_BASE"),
        (stat::HART_BUSY_BASE, "HART_BUSY_BASE"),
        (stat::HART_WAIT_BASE, "HART_WAIT_BASE"),
    ] {
        let row =
            spec.iter().find(|(f, _, names)| f == "Stats key" && names.iter().any(|n| n == &format!("{name} + h")));
        let Some((_, value, _)) = row else { panic!("SPEC.md §7 has no row for Stats key {name} + h") };
        assert_eq!(value, &format!("{} + h", key(base)), "SPEC.md §7 gives {name} as {value}");
    }
    assert_eq!(
        (stat::HART_ROWS_BASE + STAT_HARTS, stat::HART_BUSY_BASE + STAT_HARTS),
        (stat::HART_BUSY_BASE, stat::HART_WAIT_BASE)
    );
}

#[test]
fn every_row_of_spec_section_7_names_a_constant_of_the_code() {
    let code: BTreeMap<(String, String), &str> =
        code_rows().into_iter().map(|(f, v, n)| ((f.to_string(), n.to_string()), v.leak() as &str)).collect();
    for (field, value, names) in spec_rows() {
        if value.contains(" + ") {
            continue; // the per-stage and per-hart rows: a formula over the stage or hart number
        }
        let known = names.iter().any(|n| code.contains_key(&(field.clone(), n.clone())));
        assert!(known, "SPEC.md §7 lists {field} {value} {names:?}, which the code does not define");
    }
}

/// Each `pub const NAME: uN` of the registry's modules is in [`code_rows`], so a new bit or key
/// cannot skip the table.
#[test]
fn the_registry_test_lists_every_constant_of_those_modules() {
    let root = env!("CARGO_MANIFEST_DIR");
    let listed: Vec<&str> = code_rows().into_iter().map(|(_, _, n)| n).collect();
    let skip = ["INTERP_STEP_SHIFT", "INTERP_STEP_MASK", "INTERP_EPS_SHIFT", "INTERP_EPS_MASK"];
    let skip_stage = [
        "STAGE_BASE",
        "STAGE_SPLAT_CODEGEN",
        "STAGE_SPLAT_STAGE",
        "HART_ROWS_BASE",
        "HART_BUSY_BASE",
        "HART_WAIT_BASE",
    ];
    for (file, module) in [
        ("src/msg/device.rs", "pub mod feature"),
        ("src/msg/render.rs", "pub mod render_flags"),
        ("src/msg/render.rs", "pub mod region_options"),
        ("src/msg/stats.rs", "pub mod stat"),
        ("src/scene/points.rs", "pub mod scene_flags"),
    ] {
        let src = std::fs::read_to_string(format!("{root}/{file}")).unwrap();
        let at = src.find(module).unwrap_or_else(|| panic!("{file} has no `{module}`"));
        let body = &src[at..at + src[at..].find("\n}").unwrap()];
        for line in body.lines().map(str::trim).filter(|l| l.starts_with("pub const ") && l.contains(": u")) {
            let name = line["pub const ".len()..].split(':').next().unwrap().trim();
            if !name.chars().all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_') {
                continue; // a `const fn`
            }
            if skip.contains(&name) || skip_stage.contains(&name) {
                continue;
            }
            assert!(listed.contains(&name), "{file} `{module}` defines {name}, which registry.rs does not check");
        }
    }
}
