//! Shared pieces of the cross-crate tests.
//!
//! [`fuzz_bodies`] holds the body of every fuzz target, so the same code runs under libFuzzer
//! (`fuzz/`, nightly, `cargo fuzz run TARGET`) and, on random bytes, in the ordinary test suite
//! (`tests/tests/fuzz_bodies.rs`), which keeps the targets compiling and exercised in CI.

pub mod fuzz_bodies;
