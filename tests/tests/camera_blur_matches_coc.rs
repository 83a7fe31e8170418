//! optics-core's camera and its depth-of-field equations agree: the bundle of rays a thin-lens
//! camera traces from one film point, cut at a distance d and projected back onto the film,
//! is a disk whose diameter is the circle of confusion for d.

use optics_core::camera::ThinLensCamera;
use optics_core::dof::circle_of_confusion;
use optics_core::glam::{Vec2, Vec3};
use proptest::prelude::*;

proptest! {
    #[test]
    fn blur_disk_is_the_circle_of_confusion(
        f in 20.0f32..200.0, n in 1.4f32..16.0, k in 10.0f32..100.0, ratio in 0.3f32..3.0,
        fx in -10.0f32..10.0, fy in -8.0f32..8.0,
    ) {
        let s = f * k;
        let d = s * ratio;
        prop_assume!((ratio - 1.0).abs() > 0.05 && d > 2.0 * f);
        let cam = ThinLensCamera::new(f, 36.0, 24.0).unwrap().with_f_number(n).unwrap().focused_at(s).unwrap();
        let film = Vec2::new(fx, fy);
        // Lens samples on the edge of the unit square map to the rim of the disk.
        let mut hits: Vec<Vec3> = Vec::new();
        for i in 0..64 {
            let t = i as f32 / 64.0;
            for u in [Vec2::new(0.0, t), Vec2::new(0.999_999, t), Vec2::new(t, 0.0), Vec2::new(t, 0.999_999)] {
                let r = cam.generate_ray(film, u, 0.0).ray;
                hits.push(r.origin + r.direction * ((-d - r.origin.z) / r.direction.z));
            }
        }
        let mut diameter: f32 = 0.0;
        for a in &hits {
            for b in &hits {
                diameter = diameter.max((*a - *b).length());
            }
        }
        let on_film = diameter * cam.image_distance_mm() / d;
        let coc = circle_of_confusion(f as f64, n as f64, s as f64, d as f64).unwrap() as f32;
        prop_assert!((on_film - coc).abs() <= 2e-3 * coc, "blur {} vs CoC {}", on_film, coc);
    }
}
