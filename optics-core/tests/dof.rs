use optics_core::dof::*;
use optics_core::exposure::*;
use optics_core::{Distance, OpticsError};
use proptest::prelude::*;

fn h(f: f64, n: f64, c: f64) -> f64 {
    f * f / (n * c) + f
}

#[test]
fn hyperfocal_near_far() {
    let (f, n, c) = (50.0, 2.8, 0.03);
    let d = depth_of_field(f, n, c, 3000.0).unwrap();
    let hh = h(f, n, c);
    assert_eq!(d.hyperfocal, Distance::Finite(hh));
    assert!((d.near - 3000.0 * (hh - f) / (hh + 3000.0 - 2.0 * f)).abs() < 1e-9);
    let far = d.far.finite().unwrap();
    assert!((far - 3000.0 * (hh - f) / (hh - 3000.0)).abs() < 1e-9);
    assert!((d.total.finite().unwrap() - (far - d.near)).abs() < 1e-12);
    // Far limit infinite at and beyond H; near limit at H is H/2 (classic rule, exact: s(H-f)/(2H-2f)).
    let at_h = depth_of_field(f, n, c, hh).unwrap();
    assert_eq!(at_h.far, Distance::Infinite);
    assert!((at_h.near - hh / 2.0).abs() < 1e-9);
    assert_eq!(
        depth_of_field(f, n, c, 2.0 * hh).unwrap().far,
        Distance::Infinite
    );
    let inf = depth_of_field(f, n, c, f64::INFINITY).unwrap();
    assert_eq!(inf.far, Distance::Infinite);
    assert!((inf.near - (hh - f)).abs() < 1e-9);
}

#[test]
fn exposure_and_stops() {
    assert_eq!(f_number(50.0_f64, 25.0).unwrap(), 2.0);
    assert_eq!(stops_between(2.0_f64, 4.0).unwrap(), 2.0);
    assert_eq!(exposure_ratio(2.0_f64, 4.0).unwrap(), 0.25);
    assert!((stops_between(1.4_f64, 2.0).unwrap() - 1.0).abs() < 0.03);
    assert!(f_number(50.0_f64, 0.0).is_err());
}

proptest! {
    /// Stops add along a chain of f-numbers, and each stop halves the exposure.
    #[test]
    fn stops_add_and_halve_exposure(a in 0.7f64..64.0, b in 0.7f64..64.0, c in 0.7f64..64.0) {
        let ab = stops_between(a, b).unwrap();
        let bc = stops_between(b, c).unwrap();
        prop_assert!((ab + bc - stops_between(a, c).unwrap()).abs() < 1e-12);
        prop_assert!((exposure_ratio(a, b).unwrap() - 2f64.powf(-ab)).abs() < 1e-12 * exposure_ratio(a, b).unwrap().max(1.0));
        let pupil = entrance_pupil_diameter(50.0, a).unwrap();
        prop_assert!((f_number(50.0, pupil).unwrap() - a).abs() < 1e-12 * a);
    }

    /// Points at the near and far limits blur to exactly c; points between blur less.
    #[test]
    fn limits_are_where_blur_equals_c(f in 5.0f64..300.0, n in 1.0f64..22.0, c in 0.005f64..0.05, k in 2.0f64..1e4) {
        let s = f * k;
        let d = depth_of_field(f, n, c, s).unwrap();
        let at_near = circle_of_confusion(f, n, s, d.near).unwrap();
        prop_assert!((at_near - c).abs() < 1e-9 * c);
        if let Distance::Finite(far) = d.far {
            let at_far = circle_of_confusion(f, n, s, far).unwrap();
            prop_assert!((at_far - c).abs() < 1e-7 * c);
            let mid = circle_of_confusion(f, n, s, (d.near + far) / 2.0).unwrap();
            prop_assert!(mid < c);
        } else {
            // Far infinite: even infinity blurs no more than c.
            prop_assert!(circle_of_confusion(f, n, s, f64::INFINITY).unwrap() <= c * (1.0 + 1e-12));
            prop_assert!(s >= d.hyperfocal.finite().unwrap());
        }
        prop_assert!(circle_of_confusion(f, n, s, s).unwrap() == 0.0);
    }

    /// The approximation 2u^2Nc/f^2 is accurate far from f and far below H.
    #[test]
    fn approximation_error_small_in_its_domain(f in 20.0f64..200.0, n in 1.4f64..16.0, c in 0.01f64..0.04) {
        let hh = h(f, n, c);
        let u = (30.0 * f).max(hh / 1000.0);
        prop_assume!(u < hh / 20.0);
        let err = depth_of_field_approx_error(f, n, c, u).unwrap();
        prop_assert!(err.abs() < 0.08, "relative error {}", err);
        let approx = depth_of_field_approx(f, n, c, u).unwrap().finite().unwrap();
        prop_assert!((approx - 2.0 * u * u * n * c / (f * f)).abs() <= 1e-12 * approx);
    }
}

#[test]
fn approximation_error_undefined_where_exact_is_infinite() {
    let hh = h(50.0, 2.8, 0.03);
    assert!(depth_of_field_approx_error(50.0_f64, 2.8, 0.03, hh * 2.0).is_err());
    assert!(depth_of_field_approx_error(50.0_f64, 2.8, 0.0, 3000.0).is_err());
    assert_eq!(
        depth_of_field_approx(50.0_f64, 2.8, 0.03, f64::INFINITY).unwrap(),
        Distance::Infinite
    );
    assert_eq!(
        depth_of_field(50.0_f64, 2.8, 0.03, 50.0),
        Err(OpticsError::SubjectAtFocalLength)
    );
}
