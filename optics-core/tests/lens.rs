use optics_core::lens::*;
use optics_core::OpticsError;
use proptest::prelude::*;

#[test]
fn lensmaker_thin_and_thick() {
    assert!((lensmaker_focal_length(1.5_f64, 100.0, -100.0).unwrap() - 100.0).abs() < 1e-12);
    // Plano-convex, flat side second.
    assert!((lensmaker_focal_length(1.5_f64, 50.0, f64::INFINITY).unwrap() - 100.0).abs() < 1e-12);
    assert_eq!(
        lensmaker_focal_length(1.5_f64, 80.0, 80.0),
        Err(OpticsError::ZeroPower)
    );
    // Thick lens reduces to thin at d = 0; a ball lens (R1 = r, R2 = -r, d = 2r) has
    // f = n r / (2 (n - 1)).
    assert_eq!(
        thick_lens_power(1.5_f64, 100.0, -100.0, 0.0).unwrap(),
        lensmaker_power(1.5, 100.0, -100.0).unwrap()
    );
    let ball = thick_lens_focal_length(1.5_f64, 10.0, -10.0, 20.0).unwrap();
    assert!((ball - 1.5 * 10.0 / (2.0 * 0.5)).abs() < 1e-12);
    assert!(lensmaker_power(0.9_f64, 10.0, -10.0).is_err());
    assert!(thick_lens_power(1.5_f64, 10.0, -10.0, -1.0).is_err());
}

#[test]
fn gaussian_special_points() {
    let f = 50.0_f64;
    assert_eq!(
        image_distance(f, 2.0 * f).unwrap(),
        ImageDistance::Real(2.0 * f)
    );
    assert_eq!(unit_magnification_distance(f).unwrap(), 100.0);
    assert_eq!(lateral_magnification(f, 2.0 * f).unwrap(), -1.0);
    assert_eq!(image_distance(f, f).unwrap(), ImageDistance::Infinite);
    assert_eq!(
        image_distance(f, f64::INFINITY).unwrap(),
        ImageDistance::Real(f)
    );
    assert_eq!(
        image_distance(f, 25.0).unwrap(),
        ImageDistance::Virtual(50.0)
    );
    assert_eq!(lateral_magnification(f, 25.0).unwrap(), 2.0); // upright, enlarged
    assert_eq!(lateral_magnification(f, f64::INFINITY).unwrap(), 0.0);
    assert_eq!(
        lateral_magnification(f, f),
        Err(OpticsError::SubjectAtFocalLength)
    );
    // Diverging lens: always a virtual image.
    assert!(matches!(
        image_distance(-50.0_f64, 100.0).unwrap(),
        ImageDistance::Virtual(_)
    ));
    assert_eq!(sensor_distance_for_focus(f, f64::INFINITY).unwrap(), f);
    assert_eq!(
        sensor_distance_for_focus(f, f),
        Err(OpticsError::SubjectAtFocalLength)
    );
    assert_eq!(
        sensor_distance_for_focus(f, 10.0),
        Err(OpticsError::SubjectInsideFocalLength)
    );
    assert!((focus_extension(f, 2050.0).unwrap() - 2500.0 / 2000.0).abs() < 1e-12);
}

#[test]
fn power_in_dioptres() {
    assert_eq!(power_dioptres(50.0_f64).unwrap(), 20.0);
    assert_eq!(focal_length_from_dioptres(20.0_f64).unwrap(), 50.0);
    assert_eq!(
        focal_length_from_dioptres(0.0_f64),
        Err(OpticsError::ZeroPower)
    );
    assert_eq!(combined_power_dioptres(10.0_f64, 5.0, 0.0).unwrap(), 15.0);
    // Two +10 D lenses 100 mm apart: 10 + 10 - 0.1 * 100 = 10 D.
    assert!((combined_power_dioptres(10.0_f64, 10.0, 100.0).unwrap() - 10.0).abs() < 1e-12);
    assert!(power_dioptres(0.0_f64).is_err());
}

proptest! {
    /// The image distance satisfies 1/s_o + 1/s_i = 1/f, real beyond f and virtual inside it.
    #[test]
    fn gaussian_formula_holds(f in 1.0f64..800.0, k in 0.01f64..100.0) {
        let s_o = f * k;
        prop_assume!((k - 1.0).abs() > 1e-6);
        let s_i = image_distance(f, s_o).unwrap();
        let signed = s_i.signed().unwrap();
        prop_assert!((1.0 / s_o + 1.0 / signed - 1.0 / f).abs() <= 1e-9 / f);
        prop_assert_eq!(matches!(s_i, ImageDistance::Real(_)), k > 1.0);
        // Magnification is -s_i/s_o.
        let m = lateral_magnification(f, s_o).unwrap();
        prop_assert!((m + signed / s_o).abs() <= 1e-9 * m.abs().max(1.0));
        // The conjugate is symmetric: imaging s_i back gives s_o.
        if k > 1.0 {
            let back = image_distance(f, signed).unwrap().signed().unwrap();
            prop_assert!((back - s_o).abs() <= 1e-8 * s_o);
        }
    }

    /// Powers add for lenses in contact: f of the pair is 1/(1/f1 + 1/f2).
    #[test]
    fn powers_add_in_contact(f1 in 10.0f64..500.0, f2 in 10.0f64..500.0) {
        let p = combined_power_dioptres(power_dioptres(f1).unwrap(), power_dioptres(f2).unwrap(), 0.0).unwrap();
        let f = focal_length_from_dioptres(p).unwrap();
        prop_assert!((f - f1 * f2 / (f1 + f2)).abs() < 1e-9 * f);
    }

    /// Thick-lens power tends to the thin-lens power as the thickness goes to 0, linearly, with
    /// slope (n-1)^2 / (n R1 R2): thickness weakens a biconvex lens.
    #[test]
    fn thick_tends_to_thin(n in 1.3f64..2.0, r1 in 20.0f64..200.0, r2 in -200.0f64..-20.0, d in 1e-6f64..1.0) {
        let thin = lensmaker_power(n, r1, r2).unwrap();
        let thick = thick_lens_power(n, r1, r2, d).unwrap();
        let slope = (n - 1.0) * (n - 1.0) / (n * r1 * r2);
        prop_assert!(thick < thin);
        prop_assert!(((thick - thin) / d - slope).abs() < 1e-6 * slope.abs());
    }
}
