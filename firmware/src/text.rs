//! Text output without `core::fmt`: string pieces, decimal and `0x` hex integers.
//!
//! `core::fmt` (`write!`, `Formatter::pad`, the integer `Display`/`LowerHex` impls) costs
//! several KB of soft-core code, and the device's error texts, the banner and the trap/panic
//! reports need only these three shapes. [`TextOut::put_dec`] prints what `{v}` prints and
//! [`TextOut::put_hex`] what `{v:#0W$x}` (W = digits + 2) prints for a value that fits, so the
//! texts stay byte for byte what the `write!` versions sent.
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

/// One ASCII digit as a `&str`, indexed by its value (0..16).
const DIGITS: [&str; 16] = ["0", "1", "2", "3", "4", "5", "6", "7", "8", "9", "a", "b", "c", "d", "e", "f"];

/// The digit of value `d` (its low 4 bits).
fn digit(d: u32) -> &'static str {
    DIGITS.get((d & 15) as usize).copied().unwrap_or("?")
}

/// A text sink: everything else is built on [`TextOut::put`].
pub trait TextOut {
    /// Appends `s`.
    fn put(&mut self, s: &str);

    /// Appends `v` in decimal, as `{v}`.
    fn put_dec(&mut self, v: u64) {
        // u64::MAX has 20 digits; they are produced lowest first.
        let mut digits = [0u8; 20];
        let mut v = v;
        let mut len = 0;
        for (n, slot) in (1..).zip(digits.iter_mut()) {
            *slot = (v % 10) as u8;
            v /= 10;
            len = n;
            if v == 0 {
                break;
            }
        }
        for &d in digits.iter().take(len).rev() {
            self.put(digit(d.into()));
        }
    }

    /// Appends `0x` and the low `digits` (≤ 8) hex digits of `v`, lowercase, zero-padded:
    /// `{v:#010x}` is `put_hex(v, 8)`, `{v:#04x}` of a byte is `put_hex(v, 2)`.
    fn put_hex(&mut self, v: u32, digits: u32) {
        self.put("0x");
        for shift in (0..32).step_by(4).take(digits.min(8) as usize).rev() {
            self.put(digit((v >> shift) & 15));
        }
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::*;

    impl TextOut for String {
        fn put(&mut self, s: &str) {
            self.push_str(s);
        }
    }

    #[test]
    fn decimal_and_hex_match_core_fmt() {
        for v in [0u64, 1, 9, 10, 99, 100, 12_345, u32::MAX as u64, u64::MAX] {
            let mut s = String::new();
            s.put_dec(v);
            assert_eq!(s, format!("{v}"));
        }
        for v in [0u32, 1, 0xab, 0xdead_beef, u32::MAX] {
            let mut s = String::new();
            s.put_hex(v, 8);
            assert_eq!(s, format!("{v:#010x}"));
        }
        for v in [0u8, 7, 0x4f, 0xff] {
            let mut s = String::new();
            s.put_hex(v as u32, 2);
            assert_eq!(s, format!("{v:#04x}"));
        }
    }
}
