//! Property 6 (points): optics-core's Brown-Conrady model against OpenCV's `projectPoints`
//! (forward) and `undistortPoints` (inverse, iterated to convergence), in normalised
//! coordinates, to 1e-6.

use camsim_tests::first_mismatch;
use camsim_tests::oracle::{oracle_arrays, Array};
use camsim_tests::strategies::distortion_coefficients;
use optics_core::distortion::BrownConrady;
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn forward_and_inverse_match_opencv(d in distortion_coefficients(), polar in proptest::collection::vec((0.0f64..0.6, 0.0f64..std::f64::consts::TAU), 64)) {
        let model = BrownConrady::from_opencv(d).unwrap();
        let ideal: Vec<[f64; 2]> = polar.iter().map(|(r, a)| [r * a.cos(), r * a.sin()]).collect();
        let flat = |p: &[[f64; 2]]| p.iter().flatten().copied().collect::<Vec<f64>>();
        let ours: Vec<[f64; 2]> = ideal.iter().map(|p| model.distort(*p).unwrap()).collect();
        let Some(cv) = oracle_arrays("project_points", serde_json::json!({}), &[
            Array::f64_shaped(flat(&ideal), &[ideal.len(), 2]), Array::f64(d.to_vec()),
        ]) else { return Ok(()) };
        let theirs = cv[0].to_f64();
        prop_assert_eq!(first_mismatch(&flat(&ours), &theirs, 0.0, 1e-6), None);

        let distorted: Vec<[f64; 2]> = theirs.chunks(2).map(|c| [c[0], c[1]]).collect();
        let ours: Vec<f64> = distorted.iter().flat_map(|p| model.undistort(*p).unwrap()).collect();
        let Some(cv) = oracle_arrays("undistort_points", serde_json::json!({}), &[
            Array::f64_shaped(flat(&distorted), &[distorted.len(), 2]), Array::f64(d.to_vec()),
        ]) else { return Ok(()) };
        prop_assert_eq!(first_mismatch(&ours, &cv[0].to_f64(), 0.0, 1e-6), None);
        // And both recover the ideal points.
        prop_assert_eq!(first_mismatch(&ours, &flat(&ideal), 0.0, 1e-9), None);
    }
}
