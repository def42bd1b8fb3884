//! Test-only crate; the tests are in tests/. This library holds what they share.

pub mod builds;
pub mod tools;
