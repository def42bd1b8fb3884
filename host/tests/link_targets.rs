//! The link's targets at the bench's default frame (320×240), checked here rather than by
//! `gridrt bench link`, which only reports (a small frame pays the fixed per-frame overhead):
//! raw RGB888 spans use at least 95 % of the line for pixels, and RLE carries at least 2.5×
//! the raw pixel rate, on both bunnies; and RLE is lossless.

use std::path::Path;

use gridrt_host::bench::link::{link_rows, measure, FirmwareModel};
use gridrt_host::grid::GridParams;
use gridrt_host::render_settings::RenderSettings;
use gridrt_host::scene_image::PreparedScene;
use gridrt_shared::msg::{PixelEncoding, RenderRequest};

#[test]
fn raw_payload_efficiency_and_rle_rate_meet_their_targets_at_320x240() {
    for name in ["bun_zipper_res4.obj", "stanford-bunny.obj"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes").join(name);
        let mesh = gridrt_host::scene::load(&path).unwrap();
        let params = GridParams { pe_count: 4, pe_mem_words: 1 << 20, ..Default::default() };
        let prepared = PreparedScene::new(mesh, &params).unwrap();
        let base = RenderSettings::default_for(&prepared.grid.mesh_bounds).with_size(320, 240).to_request(1);
        let fw = FirmwareModel::RV32IMAFC;
        let raw = measure(name, &prepared, &RenderRequest { encoding: PixelEncoding::Rgb888, ..base }, &fw).unwrap();
        let rle = measure(name, &prepared, &RenderRequest { encoding: PixelEncoding::Rle, ..base }, &fw).unwrap();
        assert_eq!(raw.rgb, rle.rgb, "{name}: RLE must be lossless");
        let raw_row = link_rows(&raw, raw.wire_rx).into_iter().next().unwrap();
        let rle_row = link_rows(&rle, raw.wire_rx).into_iter().next().unwrap();
        assert!(
            raw_row.payload_efficiency >= 0.95,
            "{name}: raw payload efficiency {:.3} < 95 %",
            raw_row.payload_efficiency
        );
        assert!(
            rle_row.pixel_rate_vs_raw >= 2.5,
            "{name}: RLE gives {:.2}× the raw pixel rate (< 2.5)",
            rle_row.pixel_rate_vs_raw
        );
    }
}
