//! Shared pieces of the cross-crate tests.
//!
//! [`oracle`] runs the differential-test oracle (OpenCV, colour-science, colour-demosaicing in a
//! long-lived Python process).
//!
//! [`fuzz_bodies`] holds the body of every fuzz target, so the same code runs under libFuzzer
//! (`fuzz/`, nightly, `cargo fuzz run TARGET`) and, on random bytes, in the ordinary test suite
//! (`tests/tests/fuzz_bodies.rs`), which keeps the targets compiling and exercised in CI.

use std::path::{Path, PathBuf};

pub mod fuzz_bodies;
pub mod isp_reference;
pub mod oracle;
pub mod strategies;

/// Index of the first element of `ours` that differs from `theirs` by more than
/// `rel * |theirs| + abs`, with both values; `None` when all agree (and the lengths match).
pub fn first_mismatch(
    ours: &[f64],
    theirs: &[f64],
    rel: f64,
    abs: f64,
) -> Option<(usize, f64, f64)> {
    if ours.len() != theirs.len() {
        return Some((ours.len().min(theirs.len()), f64::NAN, f64::NAN));
    }
    // NaN on either side compares false, so it counts as a mismatch.
    let within = |a: f64, b: f64| (a - b).abs() <= rel * b.abs() + abs;
    ours.iter()
        .zip(theirs)
        .position(|(a, b)| !within(*a, *b))
        .map(|i| (i, ours[i], theirs[i]))
}

/// The PNG images of a vendored data set (`data/NAME`), sorted; panics (a test setup error)
/// when the folder is missing or empty.
pub fn dataset(name: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data")
        .join(name);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no images in {}", dir.display());
    files
}
