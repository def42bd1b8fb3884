//! The CPU's floating-point Custom Function Unit (`rtl/hdl/gridrt_cfu_f32.sv`, spec in
//! `rtl/README.md` §7): f32 add, sub and mul as custom-0 instructions of the VexRiscv
//! `full+cfu` core.
//!
//! [`execute`] is the unit's bit-exact twin: the co-simulation (`rtl/tests/units.rs`) checks
//! every response word of the RTL against it. The instruction is
//! `.insn r 0x0B, funct3, funct7, rd, rs1, rs2`; the CPU hands the unit
//! `function_id = {funct7, funct3}` (10 bits, funct3 in bits 2..0), rs1 and rs2.

/// The major opcode of the instructions (custom-0).
pub const OPCODE: u32 = 0x0B;

/// funct7 of every operation of the unit.
pub const FUNCT7: u8 = 0;
/// funct3 of `rd = rs1 + rs2`.
pub const FUNCT3_ADD: u8 = 0;
/// funct3 of `rd = rs1 - rs2`.
pub const FUNCT3_SUB: u8 = 1;
/// funct3 of `rd = rs1 * rs2`.
pub const FUNCT3_MUL: u8 = 2;

/// The 10-bit function id the CPU sends for an instruction's funct7 and funct3:
/// `funct7 << 3 | funct3` (bits above each field's width are dropped, as the encoding does).
pub const fn function_id(funct7: u8, funct3: u8) -> u16 {
    ((funct7 as u16 & 0x7F) << 3) | (funct3 as u16 & 0x7)
}

/// function_id of f32 add.
pub const ADD: u16 = function_id(FUNCT7, FUNCT3_ADD);
/// function_id of f32 sub.
pub const SUB: u16 = function_id(FUNCT7, FUNCT3_SUB);
/// function_id of f32 mul.
pub const MUL: u16 = function_id(FUNCT7, FUNCT3_MUL);

/// The unit's only NaN: every NaN result, and the answer to an unknown function id.
pub const CANONICAL_NAN: u32 = 0x7FC0_0000;

/// The word the unit answers for `function_id` with operands `a` (rs1) and `b` (rs2), as
/// f32 bit patterns: IEEE-754 binary32 rounded to nearest even with subnormals, every NaN
/// [`CANONICAL_NAN`]; any id other than [`ADD`], [`SUB`] and [`MUL`] answers
/// [`CANONICAL_NAN`]. Only the low 10 bits of `function_id` are used (the bus's width).
///
/// ```
/// use gridrt_shared::cfu::{execute, ADD, CANONICAL_NAN, MUL, SUB};
/// assert_eq!(execute(ADD, 0x3FC0_0000, 0x4010_0000), 0x4070_0000); // 1.5 + 2.25 = 3.75
/// assert_eq!(execute(SUB, 0x3FC0_0000, 0x4010_0000), 0xBF40_0000); // 1.5 - 2.25 = -0.75
/// assert_eq!(execute(MUL, 0x3FC0_0000, 0x4010_0000), 0x4058_0000); // 1.5 * 2.25 = 3.375
/// // rtl/README.md §7's worked example: 0.1f and 0.2f.
/// assert_eq!(execute(ADD, 0x3DCC_CCCD, 0x3E4C_CCCD), 0x3E99_999A);
/// assert_eq!(execute(SUB, 0x3DCC_CCCD, 0x3E4C_CCCD), 0xBDCC_CCCD);
/// assert_eq!(execute(MUL, 0x3DCC_CCCD, 0x3E4C_CCCD), 0x3CA3_D70B);
/// assert_eq!(execute(MUL, 0x7F80_0000, 0), CANONICAL_NAN); // inf * 0
/// assert_eq!(execute(3, 0x3FC0_0000, 0x4010_0000), CANONICAL_NAN); // unknown id
/// ```
pub fn execute(function_id: u16, a: u32, b: u32) -> u32 {
    let (x, y) = (f32::from_bits(a), f32::from_bits(b));
    let r = match function_id & 0x3FF {
        ADD => x + y,
        SUB => x - y,
        MUL => x * y,
        _ => return CANONICAL_NAN,
    };
    if r.is_nan() {
        CANONICAL_NAN
    } else {
        r.to_bits()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn function_ids_are_funct7_then_funct3() {
        assert_eq!((ADD, SUB, MUL), (0, 1, 2));
        assert_eq!(function_id(0x7F, 0x7), 0x3FF);
        assert_eq!(function_id(1, 0), 8);
        assert_eq!(function_id(0xFF, 0xF), 0x3FF);
    }

    #[test]
    fn operations_round_like_rust_f32() {
        let (a, b) = (0.1f32, 0.2f32);
        assert_eq!(execute(ADD, a.to_bits(), b.to_bits()), (a + b).to_bits());
        assert_eq!(execute(SUB, a.to_bits(), b.to_bits()), (a - b).to_bits());
        assert_eq!(execute(MUL, a.to_bits(), b.to_bits()), (a * b).to_bits());
    }

    #[test]
    fn sub_is_rs1_minus_rs2() {
        assert_eq!(execute(SUB, 3.0f32.to_bits(), 1.0f32.to_bits()), 2.0f32.to_bits());
        assert_eq!(execute(SUB, 1.0f32.to_bits(), 3.0f32.to_bits()), (-2.0f32).to_bits());
    }

    #[test]
    fn subnormals_are_kept_in_and_out() {
        let tiny = 1; // the smallest subnormal
        assert_eq!(execute(ADD, tiny, tiny), 2);
        assert_eq!(execute(SUB, 3, tiny), 2);
        assert_eq!(execute(MUL, 0x0040_0000, 0x4000_0000), 0x0080_0000); // 2⁻¹²⁷ · 2 = 2⁻¹²⁶
        assert_eq!(execute(MUL, f32::MIN_POSITIVE.to_bits(), 0x3F00_0000), 0x0040_0000);
    }

    #[test]
    fn signed_zeros_follow_ieee() {
        let (pz, nz) = (0u32, 0x8000_0000u32);
        assert_eq!(execute(ADD, nz, nz), nz);
        assert_eq!(execute(ADD, pz, nz), pz);
        assert_eq!(execute(SUB, pz, pz), pz);
        assert_eq!(execute(SUB, nz, pz), nz);
        assert_eq!(execute(MUL, nz, pz), nz);
        assert_eq!(execute(SUB, 1.0f32.to_bits(), 1.0f32.to_bits()), pz);
    }

    #[test]
    fn every_nan_result_is_the_canonical_nan() {
        let (inf, ninf) = (f32::INFINITY.to_bits(), f32::NEG_INFINITY.to_bits());
        for nan in [0x7FC0_0000, 0xFFC0_0000, 0x7F80_0001, 0xFFBF_FFFF, 0x7FC1_2345] {
            for f in [ADD, SUB, MUL] {
                assert_eq!(execute(f, nan, 1.0f32.to_bits()), CANONICAL_NAN);
                assert_eq!(execute(f, 1.0f32.to_bits(), nan), CANONICAL_NAN);
            }
        }
        assert_eq!(execute(ADD, inf, ninf), CANONICAL_NAN);
        assert_eq!(execute(SUB, inf, inf), CANONICAL_NAN);
        assert_eq!(execute(MUL, ninf, 0x8000_0000), CANONICAL_NAN);
        assert_eq!(execute(ADD, inf, inf), inf);
    }

    #[test]
    fn overflow_rounds_to_infinity() {
        let max = f32::MAX.to_bits();
        assert_eq!(execute(ADD, max, max), f32::INFINITY.to_bits());
        assert_eq!(execute(MUL, max, 0xC000_0000), f32::NEG_INFINITY.to_bits());
    }

    #[test]
    fn unknown_function_ids_answer_the_canonical_nan() {
        let one = 1.0f32.to_bits();
        for id in (3..8).chain([8, 9, 10, 0x3F8, 0x3FF]) {
            assert_eq!(execute(id, one, one), CANONICAL_NAN, "function id {id:#x}");
        }
    }

    #[test]
    fn only_the_low_ten_bits_of_the_function_id_count() {
        let (a, b) = (1.5f32.to_bits(), 2.25f32.to_bits());
        assert_eq!(execute(0x400 | MUL, a, b), execute(MUL, a, b));
        assert_eq!(execute(0xFC00 | SUB, a, b), execute(SUB, a, b));
    }
}
