use glam::{Quat, Vec2, Vec3};
use optics_core::aperture::{Aperture, RegularPolygon};
use optics_core::camera::*;
use optics_core::lens::{lateral_magnification, sensor_distance_for_focus};
use proptest::prelude::*;

fn hit_plane(r: Ray, z: f32) -> Vec3 {
    r.origin + r.direction * ((z - r.origin.z) / r.direction.z)
}

proptest! {
    /// Every ray from one film point, whatever the lens sample, passes through one point on the
    /// plane of focus: the film point's conjugate, film * s_o / s_i (|m| = s_i / s_o).
    #[test]
    fn rays_from_a_film_point_meet_on_the_plane_of_focus(
        f in 10.0f32..200.0, n in 1.0f32..8.0, k in 5.0f32..200.0,
        fx in -0.5f32..0.5, fy in -0.5f32..0.5,
        u in proptest::collection::vec((0.0f32..1.0, 0.0f32..1.0), 8),
        blades in 0u32..9,
    ) {
        let s = f * k;
        let mut cam = ThinLensCamera::new(f, 36.0, 24.0).unwrap().with_f_number(n).unwrap().focused_at(s).unwrap();
        if blades >= 3 {
            cam = cam.with_shape(Aperture::Polygon(RegularPolygon::new(blades, 0.2).unwrap()));
        }
        let film = Vec2::new(fx * 36.0, fy * 24.0);
        let m = lateral_magnification(f as f64, s as f64).unwrap().abs() as f32;
        let expected = Vec3::new(film.x / m, film.y / m, -s);
        for (ux, uy) in u {
            let r = cam.generate_ray(film, Vec2::new(ux, uy), 0.0).ray;
            prop_assert!((r.direction.length() - 1.0).abs() < 1e-5);
            prop_assert!(r.origin.length() <= cam.aperture_radius_mm() * 1.0001);
            let p = hit_plane(r, -s);
            prop_assert!((p - expected).length() <= 2e-4 * s, "{:?} vs {:?}", p, expected);
        }
    }

    /// Aperture radius 0 is the pinhole camera exactly: origin at the lens centre, direction
    /// along (x, y, -s_i), bit for bit and independent of the lens sample.
    #[test]
    fn zero_aperture_is_the_pinhole(f in 5.0f32..300.0, k in 2.0f32..1000.0, fx in -18.0f32..18.0, fy in -12.0f32..12.0, ux in 0.0f32..1.0, uy in 0.0f32..1.0) {
        let cam = ThinLensCamera::new(f, 36.0, 24.0).unwrap().focused_at(f * k).unwrap();
        let film = Vec2::new(fx, fy);
        let r = cam.generate_ray(film, Vec2::new(ux, uy), 0.5).ray;
        let s_i = sensor_distance_for_focus(f, f * k).unwrap();
        prop_assert_eq!(r.origin, Vec3::ZERO);
        prop_assert_eq!(r.direction, Vec3::new(fx, fy, -s_i).normalize());
        // A vanishing aperture converges to it.
        let tiny = cam.with_aperture(1e-4).unwrap().generate_ray(film, Vec2::new(ux, uy), 0.5).ray;
        prop_assert!((tiny.direction - r.direction).length() < 1e-5);
    }
}

#[test]
fn field_of_view_matches_corner_rays() {
    let cam = ThinLensCamera::new(50.0, 36.0, 24.0).unwrap();
    let fov = cam.field_of_view();
    assert!((fov.x as f64 - field_of_view(36.0_f64, 50.0).unwrap()).abs() < 1e-6);
    let edge = cam
        .generate_ray(cam.film_point(1000.0, 500.0, 1000, 1000), Vec2::ZERO, 0.0)
        .ray;
    let angle = edge.direction.x.atan2(-edge.direction.z);
    assert!((angle - fov.x / 2.0).abs() < 1e-6);
    // Raster top-left is film top-left (+y up).
    let tl = cam.film_point(0.0, 0.0, 640, 480);
    assert_eq!(tl, Vec2::new(-18.0, 12.0));
    // Focusing closer moves the sensor back and narrows the view.
    let close = cam.focused_at(500.0).unwrap();
    assert!(close.field_of_view().x < fov.x);
    assert!(close.image_distance_mm() > 50.0);
}

#[test]
fn shutter_and_motion() {
    let shutter = Shutter::new(0.0, 0.5).unwrap();
    assert_eq!(shutter.sample_time(0.0), 0.0);
    assert_eq!(shutter.sample_time(1.0), 0.5);
    assert_eq!(shutter.sample_time(f32::NAN), 0.0);
    assert!(Shutter::new(1.0, 0.0).is_err());
    let start = Pose::default();
    let end = Pose {
        translation: Vec3::new(100.0, 0.0, 0.0),
        rotation: Quat::from_rotation_y(0.2),
    };
    let motion = CameraMotion::linear(start, end).unwrap();
    assert!(motion.is_moving());
    assert_eq!(motion.at(0.0), start);
    let at_end = motion.at(1.0);
    assert!((at_end.translation - end.translation).length() < 1e-4);
    assert!(at_end.rotation.angle_between(end.rotation) < 1e-3);
    let cam = ThinLensCamera::new(50.0, 36.0, 24.0)
        .unwrap()
        .with_shutter(shutter)
        .with_motion(motion);
    let early = cam.generate_ray(Vec2::ZERO, Vec2::ZERO, 0.0).ray;
    let late = cam.generate_ray(Vec2::ZERO, Vec2::ZERO, 1.0).ray;
    let mid = cam.generate_ray(Vec2::ZERO, Vec2::ZERO, 0.5).ray;
    assert_eq!(early.time, 0.0);
    assert_eq!(late.time, 0.5);
    assert!((late.origin - Vec3::new(100.0, 0.0, 0.0)).length() < 1e-3);
    assert!((mid.origin - Vec3::new(50.0, 0.0, 0.0)).length() < 1e-3);
    assert!(CameraMotion::fixed(end).at(0.7) == end);
}

#[test]
fn look_at_and_world_scale() {
    let pose = Pose::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y).unwrap();
    let cam = ThinLensCamera::new(50.0, 36.0, 24.0)
        .unwrap()
        .with_motion(CameraMotion::fixed(pose));
    let r = cam.generate_ray(Vec2::ZERO, Vec2::ZERO, 0.0).ray;
    assert!((r.direction - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
    assert!(Pose::look_at(Vec3::ZERO, Vec3::ZERO, Vec3::Y).is_err());
    assert!(Pose::look_at(Vec3::ZERO, Vec3::Y, Vec3::Y).is_err());
    // Lens in mm, scene in metres: origins shrink by 1000, directions do not change.
    let lens = ThinLensCamera::new(50.0, 36.0, 24.0)
        .unwrap()
        .with_aperture(10.0)
        .unwrap()
        .focused_at(1000.0)
        .unwrap();
    let metres = lens.with_world_units_per_mm(1e-3).unwrap();
    let a = lens
        .generate_ray(Vec2::new(3.0, 2.0), Vec2::new(0.9, 0.5), 0.0)
        .ray;
    let b = metres
        .generate_ray(Vec2::new(3.0, 2.0), Vec2::new(0.9, 0.5), 0.0)
        .ray;
    assert_eq!(a.direction, b.direction);
    assert!((a.origin * 1e-3 - b.origin).length() < 1e-7);
    assert!(ThinLensCamera::new(0.0, 36.0, 24.0).is_err());
    assert!(lens.focused_at(50.0).is_err());
    assert!(lens.with_aperture(-1.0).is_err());
}
