use super::*;

mod common {
    include!("../../../shared/tests/common/tiny.rs");
    include!("../../../shared/tests/common/compact_decode.rs");
}
use common::decode_compact as decode;

use crate::grid::GridParams;
use crate::scene_image::PreparedScene;

fn bunny() -> Vec<u8> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/scenes/bun_zipper_res4.obj");
    let scene = crate::scene::load(std::path::Path::new(path)).unwrap();
    PreparedScene::new(scene, &GridParams::default()).unwrap().image
}

#[test]
fn encodes_the_worked_example_to_its_golden_bytes() {
    let stream = encode(&common::TINY_IMAGE, CACHE_LOG2).unwrap();
    assert_eq!(stream, common::TINY_COMPACT);
    assert_eq!(decode(&stream, 7).unwrap(), common::TINY_IMAGE);
}

#[test]
fn bunny_decodes_byte_exact_in_any_chunking_and_at_most_40_percent() {
    let image = bunny();
    let stream = encode(&image, CACHE_LOG2).unwrap();
    for chunk in [1, 3, 2044, usize::MAX] {
        assert!(decode(&stream, chunk).unwrap() == image, "chunks of {chunk}");
    }
    println!("bunny res4: image {} bytes, compact {} bytes", image.len(), stream.len());
    assert!(stream.len() * 10 <= image.len() * 4, "{} of {}", stream.len(), image.len());
}

#[test]
fn a_smaller_cache_still_decodes_exactly() {
    let image = bunny();
    for log2 in [0, 4, 8] {
        assert!(decode(&encode(&image, log2).unwrap(), 1000).unwrap() == image, "cache_log2 {log2}");
    }
}

#[test]
fn unreadable_layouts_round_trip_word_by_word_and_unaligned_images_are_not_coded() {
    assert_eq!(encode(&[1, 2, 3], CACHE_LOG2), None);
    assert_eq!(encode(&[], CACHE_LOG2), None);
    let mut odd = common::TINY_IMAGE.to_vec();
    odd[0] = b'X'; // not a scene image: no layout, every word coded alone
    assert_eq!(decode(&encode(&odd, CACHE_LOG2).unwrap(), 5).unwrap(), odd);
}
