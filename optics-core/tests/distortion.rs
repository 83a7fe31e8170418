use optics_core::distortion::BrownConrady;
use optics_core::OpticsError;
use proptest::prelude::*;

/// OpenCV's forward model written out independently, term by term as in its documentation.
fn opencv_forward(d: [f64; 5], x: f64, y: f64) -> (f64, f64) {
    let [k1, k2, p1, p2, k3] = d;
    let r2 = x * x + y * y;
    let r4 = r2 * r2;
    let r6 = r4 * r2;
    let radial = 1.0 + k1 * r2 + k2 * r4 + k3 * r6;
    let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
    let yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
    (xd, yd)
}

fn coeffs() -> impl Strategy<Value = [f64; 5]> {
    (
        -0.3f64..0.3,
        -0.1f64..0.1,
        -0.01f64..0.01,
        -0.01f64..0.01,
        -0.05f64..0.05,
    )
        .prop_map(|(a, b, c, d, e)| [a, b, c, d, e])
}

proptest! {
    #[test]
    fn forward_matches_opencv_formula(d in coeffs(), x in -1.0f64..1.0, y in -1.0f64..1.0) {
        let m = BrownConrady::from_opencv(d).unwrap();
        prop_assert_eq!(m.to_opencv(), d);
        let p = m.distort([x, y]).unwrap();
        let (xd, yd) = opencv_forward(d, x, y);
        prop_assert!((p[0] - xd).abs() < 1e-14 && (p[1] - yd).abs() < 1e-14);
    }

    /// Inverse then forward returns the input within the stated bound, and inverse recovers the
    /// original point, over realistic coefficients and the central field (r < 0.6).
    #[test]
    fn inverse_round_trips(d in coeffs(), r in 0.0f64..0.6, angle in 0.0f64..std::f64::consts::TAU) {
        let m = BrownConrady::from_opencv(d).unwrap();
        let ideal = [r * angle.cos(), r * angle.sin()];
        let distorted = m.distort(ideal).unwrap();
        let back = m.undistort(distorted).unwrap();
        prop_assert!((back[0] - ideal[0]).abs() < 1e-12 && (back[1] - ideal[1]).abs() < 1e-12, "{:?} vs {:?}", back, ideal);
        let again = m.distort(back).unwrap();
        let bound = 16.0 * f64::EPSILON * 1.0f64.max(distorted[0].abs()).max(distorted[1].abs());
        prop_assert!((again[0] - distorted[0]).abs() <= bound && (again[1] - distorted[1]).abs() <= bound);
    }

    #[test]
    fn f32_inverse_meets_its_bound(d in coeffs(), r in 0.0f32..0.6, angle in 0.0f32..std::f32::consts::TAU) {
        let d32 = d.map(|c| c as f32);
        let m = BrownConrady::from_opencv(d32).unwrap();
        let distorted = m.distort([r * angle.cos(), r * angle.sin()]).unwrap();
        let back = m.undistort(distorted).unwrap();
        let again = m.distort(back).unwrap();
        let bound = 16.0 * f32::EPSILON * 1.0f32.max(distorted[0].abs()).max(distorted[1].abs());
        prop_assert!((again[0] - distorted[0]).abs() <= bound && (again[1] - distorted[1]).abs() <= bound);
    }
}

#[test]
fn identity_and_failures() {
    let id = BrownConrady::<f64>::default();
    assert!(id.is_identity());
    assert_eq!(id.undistort([0.3, -0.2]).unwrap(), [0.3, -0.2]);
    // Strong barrel: r (1 - r^2) peaks at 0.385 for r = 1/sqrt(3); 0.5 has no preimage.
    let barrel = BrownConrady::new(-1.0_f64, 0.0, 0.0, 0.0, 0.0).unwrap();
    assert_eq!(
        barrel.undistort([0.5, 0.0]),
        Err(OpticsError::DidNotConverge)
    );
    // Beyond the fold the model is not invertible, even where a root exists.
    let folded = barrel.distort([0.9, 0.0]).unwrap();
    match barrel.undistort(folded) {
        Ok(p) => assert!(p[0] < 1.0 / 3f64.sqrt(), "returned the folded branch {p:?}"),
        Err(e) => assert_eq!(e, OpticsError::DidNotConverge),
    }
    assert!(BrownConrady::new(f64::NAN, 0.0, 0.0, 0.0, 0.0).is_err());
    assert!(id.distort([f64::INFINITY, 0.0]).is_err());
    let big = BrownConrady::new(1.0_f64, 1.0, 1.0, 0.0, 0.0).unwrap();
    assert_eq!(big.distort([1e200, 1e200]), Err(OpticsError::Overflow));
}
