//! Where the equations break: subject at or inside f, focus at infinity, huge N, aperture 0,
//! c = 0, zero, negative and non-finite inputs. Each gives a defined result or an error, never
//! a panic, a NaN, or an infinity the caller did not ask for.

use optics_core::dof::*;
use optics_core::exposure::*;
use optics_core::lens::*;
use optics_core::refraction::*;
use optics_core::{Distance, OpticsError, Result};
use proptest::prelude::*;

fn finite_or_err(r: Result<f64>) -> bool {
    r.map_or(true, f64::is_finite)
}

fn image_ok(r: Result<ImageDistance<f64>>) -> bool {
    r.map_or(true, |d| d.signed().is_none_or(f64::is_finite))
}

fn distance_ok(d: Distance<f64>) -> bool {
    d.finite().is_none_or(f64::is_finite)
}

fn any_value() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0),
        Just(-0.0),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(f64::NAN),
        Just(f64::MAX),
        Just(f64::MIN_POSITIVE),
        Just(1e-300),
        -1e3f64..1e3,
        proptest::num::f64::ANY,
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    #[test]
    fn every_scalar_function_is_total(a in any_value(), b in any_value(), c in any_value(), d in any_value()) {
        prop_assert!(finite_or_err(lensmaker_power(a, b, c)));
        prop_assert!(finite_or_err(lensmaker_focal_length(a, b, c)));
        prop_assert!(finite_or_err(thick_lens_power(a, b, c, d)));
        prop_assert!(finite_or_err(thick_lens_focal_length(a, b, c, d)));
        prop_assert!(finite_or_err(power_dioptres(a)));
        prop_assert!(finite_or_err(focal_length_from_dioptres(a)));
        prop_assert!(finite_or_err(combined_power_dioptres(a, b, c)));
        prop_assert!(image_ok(image_distance(a, b)));
        prop_assert!(finite_or_err(lateral_magnification(a, b)));
        prop_assert!(finite_or_err(sensor_distance_for_focus(a, b)));
        prop_assert!(finite_or_err(focus_extension(a, b)));
        prop_assert!(finite_or_err(unit_magnification_distance(a)));
        prop_assert!(finite_or_err(f_number(a, b)));
        prop_assert!(finite_or_err(entrance_pupil_diameter(a, b)));
        prop_assert!(finite_or_err(stops_between(a, b)));
        prop_assert!(finite_or_err(exposure_ratio(a, b)));
        prop_assert!(hyperfocal_distance(a, b, c).map_or(true, distance_ok));
        if let Ok(dof) = depth_of_field(a, b, c, d) {
            prop_assert!(dof.near.is_finite() && distance_ok(dof.far) && distance_ok(dof.total) && distance_ok(dof.hyperfocal));
        }
        prop_assert!(finite_or_err(circle_of_confusion(a, b, c, d)));
        prop_assert!(depth_of_field_approx(a, b, c, d).map_or(true, distance_ok));
        prop_assert!(finite_or_err(depth_of_field_approx_error(a, b, c, d)));
        prop_assert!(snell_angle(a, b, c).map_or(true, |t| t.is_none_or(f64::is_finite)));
        prop_assert!(finite_or_err(paraxial_angle(a, b, c)));
        prop_assert!(refract([a, b, c], [d, a, b], c).map_or(true, |t| t.is_none_or(|v| v.iter().all(|x| x.is_finite()))));
        prop_assert!(image_ok(paraxial_surface_image(a, b, c, d)));
        if let Ok(e) = paraxial_error(a, b, c, d, a / 2.0) {
            prop_assert!(e.longitudinal.is_none_or(f64::is_finite));
        }
    }
}

#[test]
fn named_edge_cases() {
    let (f, n, c) = (50.0_f64, 2.8, 0.03);
    // Subject exactly at f: image at infinity, as a variant.
    assert_eq!(image_distance(f, f).unwrap(), ImageDistance::Infinite);
    assert_eq!(
        depth_of_field(f, n, c, f),
        Err(OpticsError::SubjectAtFocalLength)
    );
    assert_eq!(
        circle_of_confusion(f, n, f, 1000.0),
        Err(OpticsError::SubjectAtFocalLength)
    );
    // Subject inside f: virtual image, never a negative number.
    assert!(matches!(image_distance(f, 30.0).unwrap(), ImageDistance::Virtual(d) if d > 0.0));
    assert_eq!(
        depth_of_field(f, n, c, 30.0),
        Err(OpticsError::SubjectInsideFocalLength)
    );
    // Focus at infinity.
    assert_eq!(sensor_distance_for_focus(f, f64::INFINITY).unwrap(), f);
    assert!(depth_of_field(f, n, c, f64::INFINITY)
        .unwrap()
        .near
        .is_finite());
    // N very large (a pinhole): H tends to f and everything is sharp, near limit -> 0.
    let huge = depth_of_field(f, 1e12, c, 1000.0).unwrap();
    assert_eq!(huge.far, Distance::Infinite);
    assert!(huge.near >= 0.0 && huge.near < 1e-3, "near {}", huge.near);
    // Aperture 0 (N infinite) is a parameter error; a pupil of 0 likewise.
    assert!(depth_of_field(f, f64::INFINITY, c, 1000.0).is_err());
    assert!(f_number(f, 0.0).is_err());
    // c = 0: H infinite, zero depth of field around the focus.
    let sharp = depth_of_field(f, n, 0.0, 1000.0).unwrap();
    assert_eq!(sharp.hyperfocal, Distance::Infinite);
    assert_eq!(
        (sharp.near, sharp.far, sharp.total),
        (1000.0, Distance::Finite(1000.0), Distance::Finite(0.0))
    );
    assert!(depth_of_field(f, n, 0.0, f64::INFINITY).is_err());
    // Zero and negative inputs.
    for bad in [0.0, -1.0, f64::NAN] {
        assert!(matches!(
            depth_of_field(bad, n, c, 1000.0),
            Err(OpticsError::InvalidParameter {
                name: "focal_length",
                ..
            })
        ));
        assert!(matches!(
            depth_of_field(f, bad, c, 1000.0),
            Err(OpticsError::InvalidParameter {
                name: "f_number",
                ..
            })
        ));
        assert!(matches!(
            depth_of_field(f, n, c, bad),
            Err(OpticsError::InvalidParameter {
                name: "focus_distance",
                ..
            })
        ));
    }
    assert!(depth_of_field(f, n, -0.01, 1000.0).is_err());
    // Every error explains itself.
    let msg = OpticsError::InvalidParameter {
        name: "f_number",
        allowed: "finite and > 0",
    }
    .to_string();
    assert_eq!(msg, "invalid f_number: must be finite and > 0");
}
