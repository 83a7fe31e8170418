//! Real lenses: glasses against their data sheets, paraxial data against closed forms and
//! against real rays in the paraxial limit, real rays against exact constructions, and bad
//! prescriptions refused.

use optics_core::lens::thick_lens_focal_length;
use optics_core::prescription::glass::{
    catalogue_glass, Medium, LAMBDA_C_NM, LAMBDA_D_NM, LAMBDA_F_NM,
};
use optics_core::prescription::trace::{Loss, Ray, Traced};
use optics_core::prescription::{Prescription, Shape, Surface, ASPHERE_TERMS};
use optics_core::OpticsError;
use proptest::prelude::*;

fn glass(name: &str) -> Medium<f64> {
    catalogue_glass(name).unwrap().medium()
}

/// SCHOTT's data sheets (optical glass catalogue 2017): nd and Vd.
#[test]
fn catalogue_glasses_match_their_data_sheets() {
    for (name, nd, vd) in [
        ("N-BK7", 1.51680, 64.17),
        ("F2", 1.62004, 36.37),
        ("SF5", 1.67270, 32.21),
        ("N-SK16", 1.62041, 60.32),
        ("N-LAK9", 1.69100, 54.71),
        ("N-SF6", 1.80518, 25.36),
    ] {
        let (n, v) = glass(name).nd_vd().unwrap().unwrap();
        assert!((n - nd).abs() < 2e-5, "{name}: nd {n}, data sheet {nd}");
        assert!((v - vd).abs() < 0.02, "{name}: Vd {v}, data sheet {vd}");
    }
    for g in optics_core::prescription::catalogue::CATALOGUE {
        let m: Medium<f64> = g.medium();
        let mut last = f64::INFINITY;
        for nm in (400..=700).step_by(10) {
            let n = m.index(nm as f64).unwrap();
            assert!(n > 1.4 && n < 2.1 && n < last, "{}: n({nm}) = {n}", g.name);
            last = n;
        }
    }
    assert!(catalogue_glass("unobtainium").is_err());
}

#[test]
fn model_glass_has_its_nd_and_abbe_number() {
    let m = Medium::Model {
        nd: 1.7_f64,
        vd: 30.0,
    };
    let (nd, vd) = m.nd_vd().unwrap().unwrap();
    assert!((nd - 1.7).abs() < 1e-12 && (vd - 30.0).abs() < 1e-9);
    assert!(m.index(LAMBDA_F_NM).unwrap() > m.index(LAMBDA_D_NM).unwrap());
    assert!(m.index(LAMBDA_C_NM).unwrap() < m.index(LAMBDA_D_NM).unwrap());
    for bad in [
        Medium::Model { nd: 0.9, vd: 30.0 },
        Medium::Model { nd: 1.5, vd: 5.0 },
        Medium::Constant { n: f64::NAN },
    ] {
        assert!(bad.index(550.0).is_err());
    }
    assert!(Medium::<f64>::Air.index(200.0).is_err());
    assert!(Medium::<f64>::Air.index(f64::NAN).is_err());
}

fn singlet(r1: f64, r2: f64, d: f64, medium: Medium<f64>) -> [Surface<f64>; 2] {
    [
        Surface::new(Shape::sphere_radius(r1), 10.0, d, medium).stop(),
        Surface::new(Shape::sphere_radius(r2), 10.0, 40.0, Medium::Air),
    ]
}

#[test]
fn a_thick_singlet_matches_the_thick_lens_formulas() {
    let (r1, r2, d, n) = (40.0, -60.0, 6.0, 1.6);
    let s = singlet(r1, r2, d, Medium::Constant { n });
    let p = Prescription::new(&s).unwrap().paraxial(550.0).unwrap();
    let f = thick_lens_focal_length(n, r1, r2, d).unwrap();
    assert!((p.efl - f).abs() < 1e-10 * f, "efl {} vs {f}", p.efl);
    // Principal planes of a thick lens: h = -f (n - 1) d / (n r2) from the first vertex,
    // h' = -f (n - 1) d / (n r1) from the last.
    let h = -f * (n - 1.0) * d / (n * r2);
    let h2 = -f * (n - 1.0) * d / (n * r1);
    assert!((p.front_principal - h).abs() < 1e-10 * f);
    assert!((p.rear_principal - h2).abs() < 1e-10 * f);
    assert!((p.bfl - (f + h2)).abs() < 1e-10 * f);
    assert!((p.ffl - (h - f)).abs() < 1e-10 * f);
    // The stop at the first vertex is its own entrance pupil.
    assert_eq!(p.entrance_pupil.position, 0.0);
    assert_eq!(p.entrance_pupil.semi_diameter, 10.0);
    assert!((p.f_number - f / 20.0).abs() < 1e-12);
}

/// An ellipsoid of eccentricity `1/n` (`k = -1/n^2`) into glass of index `n` focuses a
/// collimated beam without aberration (Descartes' oval for an object at infinity), at
/// `n R / (n - 1)`.
#[test]
fn a_hyperbolic_surface_focuses_a_collimated_beam_exactly() {
    let n = 1.5_f64;
    let r = 20.0;
    let focus = n * r / (n - 1.0);
    let s = [Surface {
        shape: Shape::EvenAsphere {
            curvature: 1.0 / r,
            conic: -1.0 / (n * n),
            coefficients: [0.0; ASPHERE_TERMS],
        },
        semi_diameter: 12.0,
        thickness: focus,
        medium: Medium::Constant { n },
        is_stop: true,
    }];
    let lens = Prescription::new(&s).unwrap();
    for h in [0.001, 1.0, 5.0, 9.0, 11.9] {
        let ray = Ray {
            origin: [h, 0.0, -5.0],
            direction: [0.0, 0.0, 1.0],
            wavelength_nm: 550.0,
        };
        let Traced::Image { point, .. } = lens.trace(&ray).unwrap() else {
            panic!("lost at h {h}")
        };
        assert!(
            point[0].abs() < 1e-12 * focus,
            "h {h}: lands at {}",
            point[0]
        );
    }
    // The same with aspheric terms that vanish over the aperture's first digits: Newton's
    // iteration finds the surface (the ray lands where a sphere-free check puts it).
    let mut coefficients = [0.0; ASPHERE_TERMS];
    coefficients[0] = 1e-6;
    coefficients[1] = -2e-9;
    let s = [Surface {
        shape: Shape::EvenAsphere {
            curvature: 1.0 / r,
            conic: -1.0 / (n * n),
            coefficients,
        },
        ..s[0]
    }];
    let lens = Prescription::new(&s).unwrap();
    let ray = Ray {
        origin: [8.0, 0.0, -5.0],
        direction: [0.0, 0.0, 1.0],
        wavelength_nm: 550.0,
    };
    let Traced::Image { point, direction } = lens.trace(&ray).unwrap() else {
        panic!()
    };
    // Back along the ray to the height 8: that point must be on the aspheric sag.
    let t = (8.0 - point[0]) / direction[0];
    let z = point[2] + t * direction[2];
    let (sag, _) = s[0].shape.sag_and_slope(64.0).unwrap();
    assert!((z - sag).abs() < 1e-11, "z {z} sag {sag}");
}

#[test]
fn real_rays_stop_at_apertures_and_total_internal_reflection() {
    let bk7 = glass("N-BK7");
    let s = singlet(50.0, -50.0, 5.0, bk7);
    let lens = Prescription::new(&s).unwrap();
    let outside = Ray {
        origin: [10.5, 0.0, -5.0],
        direction: [0.0, 0.0, 1.0],
        wavelength_nm: 550.0,
    };
    assert_eq!(
        lens.trace(&outside).unwrap(),
        Traced::Lost {
            surface: 0,
            loss: Loss::Vignetted
        }
    );
    // A ray parallel to the axis at height 15 meets a convex exit face of radius 20 at
    // asin(0.75) = 48.6 degrees, beyond N-BK7's critical angle (41.3 degrees).
    let tir = [
        Surface::new(Shape::Flat, 20.0, 10.0, bk7).stop(),
        Surface::new(Shape::sphere_radius(-20.0), 16.0, 5.0, Medium::Air),
    ];
    let lens = Prescription::new(&tir).unwrap();
    let ray = Ray {
        origin: [15.0, 0.0, -1.0],
        direction: [0.0, 0.0, 1.0],
        wavelength_nm: 550.0,
    };
    assert_eq!(
        lens.trace(&ray).unwrap(),
        Traced::Lost {
            surface: 1,
            loss: Loss::TotalInternalReflection
        }
    );
    // At height 12 (36.9 degrees) it leaves.
    let ray = Ray {
        origin: [12.0, 0.0, -1.0],
        ..ray
    };
    assert!(matches!(lens.trace(&ray).unwrap(), Traced::Image { .. }));
}

#[test]
fn bad_prescriptions_are_refused() {
    let bk7 = glass("N-BK7");
    let ok = singlet(50.0, -50.0, 5.0, bk7);
    assert!(Prescription::new(&ok).is_ok());
    assert!(matches!(
        Prescription::<f64>::new(&[]),
        Err(OpticsError::BadPrescription { .. })
    ));
    let mut no_stop = ok;
    no_stop[0].is_stop = false;
    assert!(matches!(
        Prescription::new(&no_stop),
        Err(OpticsError::BadPrescription { problem }) if problem.contains("no aperture stop")
    ));
    let mut two = ok;
    two[1].is_stop = true;
    assert!(Prescription::new(&two).is_err());
    let mut negative = ok;
    negative[0].thickness = -1.0;
    assert!(matches!(
        Prescription::new(&negative),
        Err(OpticsError::BadSurface { surface: 0, .. })
    ));
    let mut too_wide = ok;
    too_wide[1].shape = Shape::sphere_radius(-8.0);
    assert!(matches!(
        Prescription::new(&too_wide),
        Err(OpticsError::BadSurface { surface: 1, .. })
    ));
    let mut nan = ok;
    nan[1].semi_diameter = f64::NAN;
    assert!(Prescription::new(&nan).is_err());
    let mut bad_glass = ok;
    bad_glass[0].medium = Medium::Model { nd: 5.0, vd: 40.0 };
    assert!(Prescription::new(&bad_glass).is_err());
    // A flat plate has no power: no focal length.
    let plate = [
        Surface::new(Shape::Flat, 10.0, 5.0, bk7).stop(),
        Surface::new(Shape::Flat, 10.0, 5.0, Medium::Air),
    ];
    assert_eq!(
        Prescription::new(&plate).unwrap().paraxial(550.0),
        Err(OpticsError::ZeroPower)
    );
    let lens = Prescription::new(&ok).unwrap();
    assert!(lens.paraxial(100.0).is_err());
    let ray = Ray {
        origin: [0.0, 0.0, f64::NAN],
        direction: [0.0, 0.0, 1.0],
        wavelength_nm: 550.0,
    };
    assert!(lens.trace(&ray).is_err());
    let ray = Ray {
        origin: [0.0; 3],
        direction: [0.0; 3],
        wavelength_nm: 550.0,
    };
    assert!(lens.trace(&ray).is_err());
}

#[test]
fn focusing_moves_the_lens_out_and_refuses_what_it_cannot_reach() {
    let s = singlet(50.0, -50.0, 5.0, glass("N-BK7"));
    let lens = Prescription::new(&s).unwrap();
    let p = lens.paraxial(LAMBDA_D_NM).unwrap();
    let far = lens.conjugate(f64::INFINITY, LAMBDA_D_NM).unwrap();
    assert!((far.image_distance - p.bfl).abs() < 1e-9);
    assert!((far.working_f_number - p.f_number).abs() < 1e-9);
    // Newton's equation about the focal points: x x' = -f^2.
    let near = lens.conjugate(1000.0, LAMBDA_D_NM).unwrap();
    let x = -1000.0 - p.ffl;
    let x2 = near.image_distance - p.bfl;
    assert!((x * x2 + p.efl * p.efl).abs() < 1e-6 * p.efl * p.efl);
    assert!((near.magnification - (-p.efl / -x)).abs() < 1e-9);
    let e = lens.focus_extension(1000.0, LAMBDA_D_NM, 10.0).unwrap();
    assert!((e - x2).abs() < 1e-12);
    assert!(lens.focus_extension(1000.0, LAMBDA_D_NM, 1.0).is_err());
    assert!(lens.focus_extension(30.0, LAMBDA_D_NM, 100.0).is_err());
    assert!(lens.conjugate(-5.0, LAMBDA_D_NM).is_err());
}

/// A random valid prescription: 2 to 6 spherical or flat surfaces, a stop somewhere, glasses
/// and air gaps alternating.
fn prescription() -> impl Strategy<Value = Vec<Surface<f64>>> {
    (2usize..7)
        .prop_flat_map(|n| {
            (
                proptest::collection::vec((-0.05f64..0.05, 0.5f64..40.0, 1.45f64..1.9), n),
                0..n,
            )
        })
        .prop_map(|(rows, stop)| {
            rows.iter()
                .enumerate()
                .map(|(i, &(c, t, n))| {
                    let medium = if i % 2 == 0 && i + 1 < rows.len() {
                        Medium::Model { nd: n, vd: 50.0 }
                    } else {
                        Medium::Air
                    };
                    let shape = if c.abs() < 0.002 {
                        Shape::Flat
                    } else {
                        Shape::Sphere { curvature: c }
                    };
                    Surface {
                        shape,
                        semi_diameter: 15.0,
                        thickness: t,
                        medium,
                        is_stop: i == stop,
                    }
                })
                .collect()
        })
}

proptest! {
    /// The matrix method's focal lengths and pupils against real rays in the paraxial limit
    /// (heights and angles of 1e-6: their error is of order 1e-12 relative).
    #[test]
    fn paraxial_data_match_real_rays_in_the_paraxial_limit(s in prescription()) {
        let Ok(lens) = Prescription::new(&s) else { return Ok(()); };
        let Ok(p) = lens.paraxial(LAMBDA_D_NM) else { return Ok(()); };
        prop_assume!(p.efl.abs() > 1.0 && p.efl.abs() < 1e5);
        let h = 1e-6;
        let ray = Ray { origin: [h, 0.0, -1.0], direction: [0.0, 0.0, 1.0], wavelength_nm: LAMBDA_D_NM };
        let Traced::Image { point, direction } = lens.trace(&ray).unwrap() else {
            return Err(TestCaseError::fail("a paraxial ray was lost"));
        };
        let slope = direction[0] / direction[2];
        let efl = -h / slope;
        prop_assert!((efl - p.efl).abs() <= 1e-5 * p.efl.abs(), "efl {} vs matrix {}", efl, p.efl);
        let last = lens.vertex_z(s.len() - 1);
        let crossing = point[2] - point[0] / slope - last;
        prop_assert!((crossing - p.bfl).abs() <= 1e-5 * p.efl.abs().max(p.bfl.abs()), "bfl {} vs {}", crossing, p.bfl);
        // The entrance pupil's rim images onto the stop's rim, and a ray through its centre
        // crosses the stop at the axis.
        let ep = p.entrance_pupil;
        let stop = lens.stop_index();
        let stop_z = lens.vertex_z(stop);
        let mut clipped = s.clone();
        for (i, surface) in clipped.iter_mut().enumerate() {
            if i >= stop { surface.thickness = if i == stop { 0.0 } else { surface.thickness }; }
        }
        let to_stop = Prescription::new(&clipped[..=stop]).unwrap();
        // Scaled so the ray enters at 1e-6 mm however large the pupil: a stop near the back
        // focal point images to a pupil thousands of millimetres wide, and a ray at 1e-6 of
        // that is no longer paraxial there (its spherical aberration, against the stop's small
        // distance from the focus, moved the rim by 2e-4 relative in a case CI found).
        let k = h / ep.semi_diameter.max(1.0);
        let rim = Ray { origin: [ep.semi_diameter * k, 0.0, -1.0], direction: [0.0, 0.0, 1.0], wavelength_nm: LAMBDA_D_NM };
        if let Traced::Image { point, .. } = to_stop.trace(&rim).unwrap() {
            prop_assert!((point[2] - stop_z).abs() < 1e-9);
            prop_assert!((point[0].abs() - s[stop].semi_diameter * k).abs() < 1e-5 * s[stop].semi_diameter * k,
                "rim lands at {} of {}", point[0] / k, s[stop].semi_diameter);
        }
        // The chief ray's slope likewise: a far pupil would otherwise send it through the
        // first surface far from the axis.
        let u = h / ep.position.abs().max(1.0);
        let chief = Ray { origin: [-u * (ep.position + 1.0), 0.0, -1.0], direction: [u, 0.0, 1.0], wavelength_nm: LAMBDA_D_NM };
        if let Traced::Image { point, .. } = to_stop.trace(&chief).unwrap() {
            prop_assert!(point[0].abs() < 1e-5 * u * (1.0 + ep.position.abs()), "chief at {}", point[0] / u);
        }
    }
}

/// The f32 path gives the f64 figures to f32's precision.
#[test]
fn the_f32_path_agrees_with_f64() {
    let s64 = singlet(50.0, -50.0, 5.0, glass("N-BK7"));
    let s32: Vec<Surface<f32>> = s64
        .iter()
        .map(|s| Surface {
            shape: Shape::sphere_radius(1.0 / s.shape.curvature() as f32),
            semi_diameter: s.semi_diameter as f32,
            thickness: s.thickness as f32,
            medium: match s.medium {
                Medium::Air => Medium::Air,
                _ => catalogue_glass("N-BK7").unwrap().medium(),
            },
            is_stop: s.is_stop,
        })
        .collect();
    let p64 = Prescription::new(&s64).unwrap().paraxial(550.0).unwrap();
    let p32 = Prescription::new(&s32).unwrap().paraxial(550.0).unwrap();
    assert!((f64::from(p32.efl) - p64.efl).abs() < 1e-5 * p64.efl);
    assert!((f64::from(p32.bfl) - p64.bfl).abs() < 1e-5 * p64.efl);
    let ray = Ray {
        origin: [5.0f32, 0.0, -1.0],
        direction: [0.0, 0.0, 1.0],
        wavelength_nm: 550.0,
    };
    let Traced::Image { point, .. } = Prescription::new(&s32).unwrap().trace(&ray).unwrap() else {
        panic!()
    };
    let ray = Ray {
        origin: [5.0f64, 0.0, -1.0],
        direction: [0.0, 0.0, 1.0],
        wavelength_nm: 550.0,
    };
    let Traced::Image { point: p, .. } = Prescription::new(&s64).unwrap().trace(&ray).unwrap()
    else {
        panic!()
    };
    assert!((f64::from(point[0]) - p[0]).abs() < 1e-4);
}

/// A ray that starts further than the radius in front of a surface concave towards it meets
/// the surface near its vertex (the root continuous with the plane's), not the sphere's far
/// side behind the ray: an air gap longer than the radius, as in a telephoto's rear group.
#[test]
fn a_long_gap_before_a_concave_surface_finds_the_near_root() {
    let bk7 = glass("N-BK7");
    for r in [-14.5, 14.5, -3.0] {
        let s = [
            Surface::new(Shape::Flat, 5.0, 26.0, Medium::Air).stop(),
            Surface::new(Shape::sphere_radius(r), 2.5, 2.0, bk7),
            Surface::new(Shape::Flat, 5.0, 10.0, Medium::Air),
        ];
        let lens = Prescription::new(&s).unwrap();
        let ray = Ray {
            origin: [0.0, 0.0, -1.0],
            direction: [0.0, 0.0, 1.0],
            wavelength_nm: 550.0,
        };
        let Traced::Image { point, .. } = lens.trace(&ray).unwrap() else {
            panic!("R {r}: the axial ray was lost")
        };
        assert_eq!(point, [0.0, 0.0, 38.0]);
        // Off axis: it meets the sphere where the sag says.
        let ray = Ray {
            origin: [2.0, 0.0, -1.0],
            ..ray
        };
        assert!(
            matches!(lens.trace(&ray).unwrap(), Traced::Image { .. }),
            "R {r}"
        );
    }
}

/// A biconvex N-BK7 singlet (f about 49 mm) with the stop `stop_gap` mm in front of it
/// (0: at its first vertex).
fn singlet_with_stop(stop_gap: f64) -> Vec<Surface<f64>> {
    let bk7 = glass("N-BK7");
    let mut s = Vec::new();
    if stop_gap > 0.0 {
        s.push(Surface::aperture_stop(4.0, stop_gap));
        s.push(Surface::new(Shape::sphere_radius(50.0), 15.0, 5.0, bk7));
    } else {
        s.push(Surface::new(Shape::sphere_radius(50.0), 15.0, 5.0, bk7).stop());
    }
    s.push(Surface::new(
        Shape::sphere_radius(-50.0),
        15.0,
        47.0,
        Medium::Air,
    ));
    s
}

#[test]
fn field_curves_behave_as_the_textbooks_say() {
    let front = singlet_with_stop(20.0);
    let lens = Prescription::new(&front).unwrap();
    let field = 15f64.to_radians();
    // A stop in front of a positive lens gives barrel distortion, vanishing towards the axis.
    let d = lens
        .distortion_percent(field, LAMBDA_D_NM)
        .unwrap()
        .unwrap();
    assert!(d < -0.1, "distortion {d} %");
    let d0 = lens.distortion_percent(1e-3, LAMBDA_D_NM).unwrap().unwrap();
    assert!(d0.abs() < 1e-4, "near the axis {d0} %");
    // Longitudinal colour of a thin lens: f(F) - f(C) = -f / Vd.
    let p = lens.paraxial(LAMBDA_D_NM).unwrap();
    let (_, vd) = glass("N-BK7").nd_vd().unwrap().unwrap();
    let shift = lens
        .chromatic_focal_shift(LAMBDA_F_NM, LAMBDA_C_NM)
        .unwrap();
    assert!(
        (shift + p.efl / vd).abs() < 0.05 * p.efl / vd,
        "shift {shift} mm, thin lens {}",
        -p.efl / vd
    );
    assert_eq!(
        lens.chromatic_focal_shift(LAMBDA_D_NM, LAMBDA_D_NM)
            .unwrap(),
        0.0
    );
    // Lateral colour: large with the stop away from the lens, small with it at the lens.
    let away = lens
        .lateral_colour(field, LAMBDA_F_NM, LAMBDA_C_NM, LAMBDA_D_NM)
        .unwrap()
        .unwrap();
    let at = singlet_with_stop(0.0);
    let at = Prescription::new(&at).unwrap();
    let near = at
        .lateral_colour(field, LAMBDA_F_NM, LAMBDA_C_NM, LAMBDA_D_NM)
        .unwrap()
        .unwrap();
    assert!(
        away.abs() > 5.0 * near.abs(),
        "stop away {away} mm, at the lens {near} mm"
    );
    // Relative illumination: 1 on the axis, below it off the axis (the cosine-fourth fall
    // before the lens's rim vignettes anything).
    let ri0 = lens
        .relative_illumination(0.0, LAMBDA_D_NM, 33)
        .unwrap()
        .unwrap();
    assert!((ri0 - 1.0).abs() < 1e-12);
    let ri = lens
        .relative_illumination(field, LAMBDA_D_NM, 33)
        .unwrap()
        .unwrap();
    assert!(ri < 1.0 && ri > 0.5, "relative illumination {ri}");
    // Wide enough, the lens's rim vignettes the beam: less light than at 15 degrees.
    let wide = lens
        .relative_illumination(30f64.to_radians(), LAMBDA_D_NM, 33)
        .unwrap();
    assert!(wide.is_none_or(|w| w < ri), "{wide:?}");
    // The spot grows off axis.
    let s0 = lens.rms_spot(0.0, LAMBDA_D_NM, 33).unwrap().unwrap();
    let s1 = lens.rms_spot(field, LAMBDA_D_NM, 33).unwrap().unwrap();
    assert!(
        s0 > 0.0 && s1 > s0,
        "spot {s0} mm on axis, {s1} mm at 15 degrees"
    );
    assert!(lens.rms_spot(0.0, LAMBDA_D_NM, 1).is_err());
    assert!(lens.aimed_ray(f64::NAN, [0.0; 2], LAMBDA_D_NM).is_err());
}

/// Descartes' ellipsoid focuses every ray of the axial beam on one point: its RMS spot is
/// zero to rounding.
#[test]
fn a_perfect_surface_has_a_zero_spot() {
    let n = 1.5_f64;
    let s = [Surface {
        shape: Shape::EvenAsphere {
            curvature: 1.0 / 20.0,
            conic: -1.0 / (n * n),
            coefficients: [0.0; ASPHERE_TERMS],
        },
        semi_diameter: 12.0,
        thickness: 60.0,
        medium: Medium::Constant { n },
        is_stop: true,
    }];
    let lens = Prescription::new(&s).unwrap();
    let spot = lens.rms_spot(0.0, 550.0, 65).unwrap().unwrap();
    assert!(spot < 1e-12, "{spot}");
}

/// Laikin's Tessar as `camsim/lenses/tessar-f4.5.toml` holds it.
fn tessar() -> Vec<Surface<f64>> {
    let s =
        |r: f64, t: f64, sd: f64, m: Medium<f64>| Surface::new(Shape::sphere_radius(r), sd, t, m);
    vec![
        s(33.85566, 7.08914, 16.36, glass("N-SK15")),
        s(-253.37516, 5.21716, 15.2, Medium::Air),
        s(-53.12918, 2.286, 10.71, glass("F2")),
        s(30.79242, 1.80086, 9.51, Medium::Air),
        Surface::aperture_stop(9.079866538191485, 3.89636),
        s(-191.0207, 2.286, 10.94, glass("K10")),
        s(33.0454, 8.60806, 13.0, glass("N-SK15")),
        s(-38.65372, 86.4235, 14.12, Medium::Air),
    ]
}

#[test]
fn corrections_derived_from_a_prescription_reproduce_it() {
    let surfaces = tessar();
    let lens = Prescription::new(&surfaces).unwrap();
    let d = LAMBDA_D_NM;
    let max = 20.5f64.to_radians();
    let efl = lens.paraxial(d).unwrap().efl;
    // The fitted Brown-Conrady model puts every chief ray within 0.2 um of where it lands.
    let [k1, k2, k3] = lens.fit_brown_conrady(max, d).unwrap();
    for i in 1..=40 {
        let field = max * i as f64 / 40.0;
        let h = lens.chief_height(field, d, d).unwrap().unwrap();
        let x = field.tan();
        let x2 = x * x;
        let model = efl * x * (1.0 + k1 * x2 + k2 * x2 * x2 + k3 * x2 * x2 * x2);
        assert!((model - h).abs() < 2e-4, "{field}: {model} against {h}");
    }
    // Field from height inverts the chief ray's height.
    let field = lens.field_at_height(20.0, d, d, max).unwrap().unwrap();
    assert!((lens.chief_height(field, d, d).unwrap().unwrap() - 20.0).abs() < 1e-9);
    assert_eq!(lens.field_at_height(60.0, d, d, max).unwrap(), None);
    // Lateral-colour scales: 1 at the reference; their difference times the height is the
    // lateral colour between the two wavelengths.
    let at = |nm: f64, h: f64| {
        lens.lateral_colour_scale(h, nm, d, d, max)
            .unwrap()
            .unwrap()
    };
    assert!((at(d, 15.0) - 1.0).abs() < 1e-12);
    let field = lens.field_at_height(15.0, d, d, max).unwrap().unwrap();
    let lc = lens
        .lateral_colour(field, LAMBDA_F_NM, LAMBDA_C_NM, d)
        .unwrap()
        .unwrap();
    let scaled = (at(LAMBDA_F_NM, 15.0) - at(LAMBDA_C_NM, 15.0)) * 15.0;
    assert!((scaled - lc).abs() < 1e-9, "{scaled} against {lc}");
    assert!(at(LAMBDA_F_NM, 0.0).is_finite());
    // Relative illumination from the film side: 1 on the axis, falling towards the corner,
    // near the entrance-pupil estimate of `analysis` (an approximation of the same thing).
    let mut scratch = surfaces.clone();
    let bfl = lens.paraxial(d).unwrap().bfl;
    let mut ri = |h: f64| {
        lens.illumination_at_height(h, bfl, d, 96, &mut scratch)
            .unwrap()
            .unwrap()
    };
    assert!((ri(0.0) - 1.0).abs() < 1e-12);
    let (mid, corner) = (ri(10.0), ri(21.6));
    assert!(corner < mid && mid < 1.0, "{mid} {corner}");
    let field = lens.field_at_height(21.6, d, d, max).unwrap().unwrap();
    let estimate = lens.relative_illumination(field, d, 64).unwrap().unwrap();
    assert!(
        (corner - estimate).abs() < 0.04,
        "{corner} against {estimate}"
    );
    let mut short = [surfaces[0]];
    assert!(lens
        .illumination_at_height(1.0, bfl, d, 16, &mut short)
        .is_err());
    // The curve traces the axis once and gives each radius's value to the bit.
    let heights = [0.0, 5.0, 10.0, 21.6];
    let mut curve = [None; 4];
    let mut curve_scratch = surfaces.clone();
    lens.illumination_curve(&heights, bfl, d, 96, &mut curve_scratch, &mut curve)
        .unwrap();
    for (&h, value) in heights.iter().zip(curve) {
        assert_eq!(value.unwrap().to_bits(), ri(h).to_bits(), "at {h} mm");
    }
    let mut too_short = [None; 3];
    assert!(lens
        .illumination_curve(&heights, bfl, d, 96, &mut curve_scratch, &mut too_short)
        .is_err());
    assert!(lens
        .illumination_curve(
            &[1.0, -1.0],
            bfl,
            d,
            96,
            &mut curve_scratch,
            &mut curve[..2]
        )
        .is_err());
}

/// The centroid fit: on the axis the image is centred; over the field the fitted model puts
/// each field's centroid (where a dot chart's dot is) within half a micrometre; the Tessar's
/// centroids lie near its chief rays; bad grids and planes are refused.
#[test]
fn the_centroid_fit_follows_where_the_light_lands() {
    let surfaces = tessar();
    let lens = Prescription::new(&surfaces).unwrap();
    let nm = 540.0;
    let p = lens.paraxial(nm).unwrap();
    let (efl, bfl) = (p.efl, p.bfl);
    assert!(
        lens.centroid_height(0.0, nm, bfl, 17)
            .unwrap()
            .unwrap()
            .abs()
            < 1e-12
    );
    let max = 20.5f64.to_radians();
    let fit = lens.fit_brown_conrady_centroid(max, nm, bfl, 65).unwrap();
    let ([k1, k2, k3], f) = (fit.k, fit.focal_length_mm);
    // The centroids' scale is the paraxial one's within a thousandth.
    assert!((f / efl - 1.0).abs() < 1e-3, "{f} against {efl}");
    let mut worst = 0.0f64;
    for i in 1..=20 {
        let field = max * i as f64 / 20.0;
        let c = lens.centroid_height(field, nm, bfl, 65).unwrap().unwrap();
        let chief = lens.chief_height(field, nm, nm).unwrap().unwrap();
        assert!(
            (c - chief).abs() < 0.02,
            "{field}: centroid {c}, chief {chief}"
        );
        let x = field.tan();
        let x2 = x * x;
        let model = f * x * (1.0 + k1 * x2 + k2 * x2 * x2 + k3 * x2 * x2 * x2);
        worst = worst.max((model - c).abs());
    }
    assert!(worst < 5e-4, "the fit is off a centroid by {worst} mm");
    assert!(lens.centroid_height(0.1, nm, bfl, 1).is_err());
    assert!(lens.centroid_height(0.1, nm, f64::NAN, 17).is_err());
    assert!(lens.fit_brown_conrady_centroid(0.0, nm, bfl, 17).is_err());
}
