//! The compact scene stream (SPEC.md §5.12): golden bytes of the worked example, any
//! chunking, and corruption — flipped bytes, truncation, bad header fields, reserved ops —
//! each refused with a `SceneError`, never a panic or a silently different image.

mod common;

use common::{decode_compact as decode, TINY_COMPACT, TINY_IMAGE};
use gridrt_shared::scene::{SceneError, SceneHeader, Unpacker, COMPACT_HEADER_LEN};

#[test]
fn golden_worked_example_decodes_to_the_tiny_image_in_any_chunking() {
    assert_eq!(&TINY_COMPACT[..4], b"GRTZ");
    assert_eq!(&TINY_COMPACT[4..16], &[1, 0, 12, 0, 0x5C, 1, 0, 0, 0xA2, 0x82, 0x96, 0x2A]);
    for chunk in 1..=TINY_COMPACT.len() {
        assert_eq!(decode(&TINY_COMPACT, chunk).unwrap(), TINY_IMAGE, "chunks of {chunk}");
    }
}

#[test]
fn golden_ops_of_the_worked_example() {
    // SPEC.md §5.12 worked example: the ops after the header, as the spec's table lists them.
    let ops = &TINY_COMPACT[COMPACT_HEADER_LEN..];
    assert_eq!(&ops[..5], &[0x02, 0x47, 0x52, 0x54, 0x53]); // LIT 3: magic, version, nx …
    assert_eq!(&ops[13..15], &[0x60, 0x01]); // DELTA 1, zigzag 1 = −1: nz 1, pe_count 1
    let vnew = ops.len() - 3 - 33; // the triangle's three new vertices: VNEW × 3 (16 + 7 + 10 bytes)
    assert_eq!([ops[vnew], ops[vnew + 16], ops[vnew + 23]], [0xC0; 3]);
    let tail = &ops[ops.len() - 3..];
    assert_eq!(tail, &[0x69, 0x00, 0x20]); // DELTA 10 (prim id 0 = word 10 back), RUN 1 (material 0)
}

#[test]
fn a_raw_image_passes_through_unchanged() {
    for chunk in [1, 3, 4, 5, 64, 348] {
        assert_eq!(decode(&TINY_IMAGE, chunk).unwrap(), TINY_IMAGE);
    }
}

#[test]
fn every_flipped_byte_is_refused_or_decodes_to_the_same_image() {
    for i in 0..TINY_COMPACT.len() {
        for bit in [0x01u8, 0x80, 0xFF] {
            let mut s = TINY_COMPACT.to_vec();
            s[i] ^= bit;
            match decode(&s, 7) {
                Err(_) => {}
                // A broken magic makes it a raw image, passed through: the image parser then
                // refuses it (BadMagic), as the device does.
                Ok(image) if image == s => assert_eq!(SceneHeader::parse(&image), Err(SceneError::BadMagic)),
                Ok(image) => assert_eq!(image, TINY_IMAGE, "byte {i} ^ {bit:#x} decoded to another image"),
            }
        }
    }
}

#[test]
fn every_truncation_is_refused() {
    for n in 1..TINY_COMPACT.len() {
        assert!(decode(&TINY_COMPACT[..n], 5).is_err(), "cut at {n}");
    }
}

#[test]
fn header_fields_are_checked() {
    let with = |i: usize, v: u8| {
        let mut s = TINY_COMPACT.to_vec();
        s[i] = v;
        decode(&s, 16)
    };
    assert_eq!(with(4, 2), Err(SceneError::BadVersion)); // version 2
    assert_eq!(with(6, 13), Err(SceneError::BadCompact)); // 8192 entries > this decoder's 4096
    assert_eq!(with(7, 1), Err(SceneError::BadCompact)); // reserved byte
    assert_eq!(with(8, 0x5D), Err(SceneError::BadCompact)); // image_len not a multiple of 4
    assert_eq!(with(12, 0), Err(SceneError::BadCrc)); // image_crc
                                                      // A decoder without a cache refuses every compact stream.
    let mut u: Unpacker<0> = Unpacker::new();
    assert_eq!(u.feed(&TINY_COMPACT, &mut |_, _| Ok(())), Err(SceneError::BadCompact));
}

#[test]
fn bad_ops_are_refused() {
    let head = &TINY_COMPACT[..COMPACT_HEADER_LEN];
    let run = |ops: &[u8]| {
        let mut s = head.to_vec();
        s.extend_from_slice(ops);
        decode(&s, 3)
    };
    assert_eq!(run(&[0xE0]), Err(SceneError::BadCompact)); // kind 7 is reserved
    assert_eq!(run(&[0xC1, 0, 0, 0]), Err(SceneError::BadCompact)); // VNEW with p ≠ 0
    assert_eq!(run(&[0xA0, 0x00]), Err(SceneError::BadCompact)); // VREF to an empty cache
    assert_eq!(run(&[0x60, 0xFF, 0xFF, 0xFF, 0xFF, 0x7F]), Err(SceneError::BadCompact)); // varint past 32 bits
    assert_eq!(run(&[0x1F]), Err(SceneError::Truncated)); // LIT 32 without its words
                                                          // The image is 87 words: RUN 32 × 3 = 96 words runs past its end.
    assert_eq!(run(&[0x3F, 0x3F, 0x3F]), Err(SceneError::BadCompact));
}

#[test]
fn bytes_after_the_image_are_refused() {
    let mut s = TINY_COMPACT.to_vec();
    s.push(0x20); // RUN 1 past image_len
    assert_eq!(decode(&s, 9), Err(SceneError::BadCompact));
}
