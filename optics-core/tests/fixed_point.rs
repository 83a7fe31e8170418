use optics_core::fixed_point::*;
use optics_core::{Distance, OpticsError};
use proptest::prelude::*;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

/// One output step of Mm, as a relative allowance at value `x`.
fn mm_step(x: f64) -> f64 {
    2f64.powi(-32) / x
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// The error bound stated in the module docs, over the stated domain.
    #[test]
    fn fixed_point_matches_float(
        f in 1.0f64..800.0, n in 0.95f64..32.0, c in 0.001f64..0.1,
        // Subject from 2f to infinity, uniform in vergence.
        t in 0.0f64..1.0,
        point_t in 0.0f64..1.0,
    ) {
        let (fq, nq, cq) = (Mm::from_num(f), FNumber::from_num(n), Mm::from_num(c));
        let vmax = 1000.0 / (2.0 * f);
        let vq = Dioptres::from_num(vmax * t);
        // Float reference on the same quantised inputs.
        let (f, n, c, v) = (fq.to_num::<f64>(), nq.to_num::<f64>(), cq.to_num::<f64>(), vq.to_num::<f64>());
        let margin = 1.0 - f * v / 1000.0;

        let s_i = sensor_distance(fq, vq).unwrap().to_num::<f64>();
        prop_assert!(rel(s_i, f / margin) <= 1e-9 + mm_step(s_i));

        let h = f * f / (n * c) + f;
        let Distance::Finite(hq) = hyperfocal(fq, nq, cq).unwrap() else { panic!("finite c") };
        prop_assert!(rel(hq.to_num::<f64>(), h) <= 1e-9 + mm_step(h));

        let dof = depth_of_field(fq, nq, cq, vq).unwrap();
        let spread = 1000.0 * margin / (h - f);
        prop_assert!((dof.near.to_num::<f64>() - (v + spread)).abs() <= 1e-12);
        prop_assert!((dof.far.to_num::<f64>() - (v - spread).max(0.0)).abs() <= 1e-12);
        // The far limit is at infinity exactly when focused at or beyond H (within rounding).
        if (v - spread).abs() > 1e-12 {
            prop_assert_eq!(dof.far == Dioptres::ZERO, v <= spread);
        }

        let vd = Dioptres::from_num(vmax * 2.0 * point_t);
        let vdf = vd.to_num::<f64>();
        let coc = circle_of_confusion(fq, nq, vq, vd).unwrap().to_num::<f64>();
        let coc_ref = f * f / n * (v - vdf).abs() / 1000.0 / margin;
        prop_assert!((coc - coc_ref).abs() <= 1e-9 * coc_ref + 2f64.powi(-32));
    }
}

#[test]
fn vergence_round_trip_and_infinity() {
    assert_eq!(vergence(Distance::Infinite).unwrap(), Dioptres::ZERO);
    assert_eq!(distance(Dioptres::ZERO).unwrap(), Distance::Infinite);
    let v = vergence(Distance::Finite(Mm::from_num(2000))).unwrap();
    assert_eq!(v, Dioptres::from_num(0.5));
    assert_eq!(distance(v).unwrap(), Distance::Finite(Mm::from_num(2000)));
    assert!(vergence(Distance::Finite(Mm::ZERO)).is_err());
    // Vergence of a distance below 1000/65536 mm does not fit Q16.48.
    assert_eq!(
        vergence(Distance::Finite(Mm::from_num(0.01))),
        Err(OpticsError::Overflow)
    );
    // Focus at infinity: sensor at f; far limit at infinity.
    assert_eq!(
        sensor_distance(Mm::from_num(50), Dioptres::ZERO).unwrap(),
        Mm::from_num(50)
    );
    let dof = depth_of_field(
        Mm::from_num(50),
        FNumber::from_num(2.8),
        Mm::from_num(0.03),
        Dioptres::ZERO,
    )
    .unwrap();
    assert_eq!(dof.far, Dioptres::ZERO);
}

#[test]
fn stability_edges() {
    let f = Mm::from_num(50);
    // Subject exactly at f (20 D) and inside it.
    assert_eq!(
        sensor_distance(f, Dioptres::from_num(20)),
        Err(OpticsError::SubjectAtFocalLength)
    );
    assert_eq!(
        sensor_distance(f, Dioptres::from_num(30)),
        Err(OpticsError::SubjectInsideFocalLength)
    );
    assert!(sensor_distance(Mm::ZERO, Dioptres::ZERO).is_err());
    // c = 0: hyperfocal infinite, near = far = focus.
    assert_eq!(
        hyperfocal(f, FNumber::from_num(2), Mm::ZERO).unwrap(),
        Distance::Infinite
    );
    let v = Dioptres::from_num(1);
    let sharp = depth_of_field(f, FNumber::from_num(2), Mm::ZERO, v).unwrap();
    assert_eq!((sharp.near, sharp.far), (v, v));
    assert!(hyperfocal(f, FNumber::ZERO, Mm::from_num(0.03)).is_err());
    // N very large: the hyperfocal distance approaches f.
    let Distance::Finite(h) =
        hyperfocal(f, FNumber::from_num(1_000_000), Mm::from_num(0.03)).unwrap()
    else {
        panic!()
    };
    assert!((h.to_num::<f64>() - 50.083_333).abs() < 1e-3);
    // Values out of range report overflow, never wrap.
    assert_eq!(
        hyperfocal(Mm::MAX, FNumber::from_num(1), Mm::from_num(0.001)),
        Err(OpticsError::Overflow)
    );
}
