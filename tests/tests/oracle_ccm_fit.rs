//! Property 7: colour-correction matrix fitting from ColorChecker patches (least squares,
//! 3 terms) equals colour-science's `matrix_colour_correction(..., method='Cheung 2004')` to
//! 1e-6 relative on the same patch data. The patches are the 24 ColorChecker reflectances
//! seen by a real camera's sensitivities under a CIE illuminant, with random exposure and
//! per-patch noise, fitted to their XYZ.

use camsim_tests::first_mismatch;
use camsim_tests::oracle::{oracle_arrays, Array};
use host_tracer::spectra::{self, CAMERAS};
use isp_core::ccm::fit;
use proptest::prelude::*;

const ILLUMINANTS: [&str; 6] = ["A", "D50", "D65", "FL2", "FL11", "LED-B3"];

fn flat(v: &[[f64; 3]]) -> Vec<f64> {
    v.iter().flatten().copied().collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn fit_matches_colour_science_cheung_2004(
        camera in 0usize..3,
        illuminant in 0usize..6,
        exposure in 0.05f64..4.0,
        noise in proptest::collection::vec(-0.03f64..0.03, 72),
    ) {
        let (xyz, rgb) = spectra::colorchecker(ILLUMINANTS[illuminant], CAMERAS[camera].0).unwrap();
        let rgb: Vec<[f64; 3]> = rgb
            .iter()
            .enumerate()
            .map(|(i, p)| std::array::from_fn(|c| p[c] * exposure * (1.0 + noise[3 * i + c])))
            .collect();
        let ours = fit(&rgb, &xyz).unwrap();
        let Some(theirs) = oracle_arrays("matrix_colour_correction", serde_json::json!({}), &[
            Array::f64_shaped(flat(&rgb), &[24, 3]),
            Array::f64_shaped(flat(&xyz), &[24, 3]),
        ]) else { return Ok(()) };
        let theirs = theirs[0].to_f64();
        let ours = flat(&ours);
        // Relative to the matrix's scale: a coefficient near 0 is judged against the others.
        let scale = theirs.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        prop_assert_eq!(first_mismatch(&ours, &theirs, 1e-6, 1e-6 * scale), None);
    }
}

/// The fitted camera-to-XYZ matrix is a good one: on the patches without noise, the mean
/// CIE 2000 error after the fit is small (a 3x3 matrix cannot be exact for a real camera).
#[test]
fn fitted_matrix_reproduces_the_chart() {
    for (camera, _) in CAMERAS {
        let (xyz, rgb) = spectra::colorchecker("D65", camera).unwrap();
        let m = fit(&rgb, &xyz).unwrap();
        let white = isp_core::colour::xy_to_xyz(isp_core::colour::D65_XY).unwrap();
        let mut total = 0.0;
        for (c, r) in rgb.iter().zip(&xyz) {
            let fitted = isp_core::colour::mat3_mul_vec(&m, *c);
            let lab = |v: [f64; 3]| isp_core::colour::xyz_to_lab(v, white).unwrap();
            total += isp_core::colour::delta_e_2000(lab(fitted), lab(*r));
        }
        let mean = total / 24.0;
        println!("{camera}: mean CIE 2000 error after a 3x3 fit under D65: {mean:.2}");
        assert!(mean < 4.0, "{camera}: {mean}");
    }
}
