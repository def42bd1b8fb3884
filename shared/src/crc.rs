//! CRC-32/ISO-HDLC (the zlib/Ethernet CRC), table-driven, with fast paths for what the
//! firmware checksums per pixel: one RGB888 pixel ([`Crc32Digest::update_rgb`], three bytes in
//! one step, "slicing by 3") and a run of one pixel ([`Crc32Digest::update_rgb_run`], 16
//! pixels in one step). Tables: 3 KiB + 512 B, built at compile time.
//!
//! The register update is linear: the register after bytes `D` from register `s` is
//! `Z(s) ^ R(D)`, with `Z` the effect of as many zero bytes and `R(D)` the register after `D`
//! from 0. Both fast paths rest on that.

#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

/// CRC-32/ISO-HDLC polynomial, reflected.
const POLY: u32 = 0xEDB8_8320;

/// Pixels a run step takes at once.
const RUN_STEP: usize = 16;

/// `TABLES[k][b]`: the register after byte `b` and `k` zero bytes, from register 0.
static TABLES: [[u32; 256]; 3] = tables();

/// `ZEROS[j][v]`: the register after `3 · RUN_STEP` zero bytes from register `v << 4j`.
static ZEROS: [[u32; 16]; 8] = zeros();

#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // const evaluation: small constant bounds
const fn tables() -> [[u32; 256]; 3] {
    let mut t = [[0u32; 256]; 3];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 == 1 { (c >> 1) ^ POLY } else { c >> 1 };
            k += 1;
        }
        t[0][i] = c;
        i += 1;
    }
    let mut k = 1;
    while k < 3 {
        let mut i = 0;
        while i < 256 {
            let c = t[k - 1][i];
            t[k][i] = (c >> 8) ^ t[0][(c & 0xFF) as usize];
            i += 1;
        }
        k += 1;
    }
    t
}

#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // const evaluation: small constant bounds
const fn zeros() -> [[u32; 16]; 8] {
    let t0 = tables()[0];
    let mut z = [[0u32; 16]; 8];
    let mut j = 0;
    while j < 8 {
        let mut v = 0;
        while v < 16 {
            let mut c = (v as u32) << (4 * j);
            let mut k = 0;
            while k < 3 * RUN_STEP {
                c = (c >> 8) ^ t0[(c & 0xFF) as usize];
                k += 1;
            }
            z[j][v] = c;
            v += 1;
        }
        j += 1;
    }
    z
}

#[inline(always)]
fn table(k: usize, i: u32) -> u32 {
    // `i & 0xFF` < 256: the `None` arm is never taken (and compiled out).
    TABLES.get(k).and_then(|t| t.get((i & 0xFF) as usize)).copied().unwrap_or(0)
}

#[inline(always)]
fn byte_step(s: u32, b: u8) -> u32 {
    table(0, s ^ u32::from(b)) ^ (s >> 8)
}

#[inline(always)]
fn rgb_step(s: u32, [r, g, b]: [u8; 3]) -> u32 {
    let w = s ^ u32::from_le_bytes([r, g, b, 0]);
    (s >> 24) ^ table(2, w) ^ table(1, w >> 8) ^ table(0, w >> 16)
}

/// The register after `3 · RUN_STEP` zero bytes from register `s`.
#[inline(always)]
fn zeros_step(s: u32) -> u32 {
    let (mut r, mut s) = (0, s);
    for z in &ZEROS {
        r ^= z.get((s & 0xF) as usize).copied().unwrap_or(0);
        s >>= 4;
    }
    r
}

/// CRC-32/ISO-HDLC of `data`.
pub fn crc32(data: &[u8]) -> u32 {
    let mut d = Crc32Digest::default();
    d.update(data);
    d.finalize()
}

/// Incremental CRC-32/ISO-HDLC, for data that arrives in pieces.
#[derive(Clone, Copy)]
pub struct Crc32Digest {
    reg: u32,
    /// The last run pixel (bit 24 set) and `R` of `RUN_STEP` copies of it.
    run_key: u32,
    run_reg: u32,
}

impl Default for Crc32Digest {
    fn default() -> Self {
        Self { reg: !0, run_key: 0, run_reg: 0 }
    }
}

impl core::fmt::Debug for Crc32Digest {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("Crc32Digest")
    }
}

impl Crc32Digest {
    /// Adds bytes to the running checksum.
    pub fn update(&mut self, data: &[u8]) {
        let mut s = self.reg;
        let mut chunks = data.chunks_exact(3);
        for c in &mut chunks {
            if let [r, g, b] = *c {
                s = rgb_step(s, [r, g, b]);
            }
        }
        for &b in chunks.remainder() {
            s = byte_step(s, b);
        }
        self.reg = s;
    }

    /// Adds the three bytes of one pixel: `update(&rgb)`, in one table step.
    #[inline]
    pub fn update_rgb(&mut self, rgb: [u8; 3]) {
        self.reg = rgb_step(self.reg, rgb);
    }

    /// Adds `n` copies of the pixel `rgb`: `n` calls of [`update_rgb`](Self::update_rgb),
    /// 16 pixels per step.
    pub fn update_rgb_run(&mut self, rgb: [u8; 3], n: usize) {
        let mut s = self.reg;
        let mut left = n;
        if left >= RUN_STEP {
            let key = u32::from_le_bytes([rgb[0], rgb[1], rgb[2], 1]);
            if self.run_key != key {
                let mut r = 0;
                for _ in 0..RUN_STEP {
                    r = rgb_step(r, rgb);
                }
                (self.run_key, self.run_reg) = (key, r);
            }
            let k = self.run_reg;
            // Bounded by `n / RUN_STEP` rounds.
            while left >= RUN_STEP {
                s = zeros_step(s) ^ k;
                left = left.saturating_sub(RUN_STEP);
            }
        }
        for _ in 0..left {
            s = rgb_step(s, rgb);
        }
        self.reg = s;
    }

    /// The checksum of everything added so far, without ending the digest.
    pub fn value(&self) -> u32 {
        !self.reg
    }

    /// Returns the checksum of everything added so far.
    pub fn finalize(self) -> u32 {
        !self.reg
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::*;

    const REFERENCE: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

    #[test]
    fn check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
    }

    proptest::proptest! {
        /// Every length modulo 3, split anywhere, equals the `crc` crate's CRC.
        #[test]
        fn update_matches_the_crc_crate(data in proptest::collection::vec(proptest::num::u8::ANY, 0..200), cut in 0usize..200) {
            let cut = cut.min(data.len());
            let mut d = Crc32Digest::default();
            d.update(&data[..cut]);
            d.update(&data[cut..]);
            proptest::prop_assert_eq!(d.value(), REFERENCE.checksum(&data));
            proptest::prop_assert_eq!(d.finalize(), REFERENCE.checksum(&data));
        }

        /// Pixels and runs of pixels checksum as their bytes do; the run cache follows the colour.
        #[test]
        fn pixels_and_runs_match_their_bytes(
            lead in proptest::collection::vec(proptest::num::u8::ANY, 0..7),
            runs in proptest::collection::vec((proptest::prop_oneof![proptest::strategy::Just([9u8, 9, 9]), proptest::prelude::any::<[u8; 3]>()], 0usize..70), 0..6),
        ) {
            let mut d = Crc32Digest::default();
            d.update(&lead);
            let mut bytes = lead.clone();
            for (i, &(rgb, n)) in runs.iter().enumerate() {
                if i % 2 == 0 {
                    d.update_rgb_run(rgb, n);
                } else {
                    (0..n).for_each(|_| d.update_rgb(rgb));
                }
                (0..n).for_each(|_| bytes.extend_from_slice(&rgb));
            }
            proptest::prop_assert_eq!(d.finalize(), REFERENCE.checksum(&bytes));
        }
    }
}
