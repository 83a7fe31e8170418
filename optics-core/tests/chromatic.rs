use glam::Vec2;
use optics_core::aperture::{ApertureShape, Disk, RegularPolygon};
use optics_core::camera::ThinLensCamera;
use optics_core::chromatic::ChromaticAberration;
use proptest::prelude::*;

proptest! {
    /// Strength 0: weights exactly (1, 1, 1) and the very lens point the plain aperture gives.
    #[test]
    fn strength_zero_is_exactly_neutral(fx in -1.0f32..1.0, fy in -1.0f32..1.0, ux in 0.0f32..1.0, uy in 0.0f32..1.0) {
        let ca = ChromaticAberration::new(0.0).unwrap();
        let u = Vec2::new(ux, uy);
        let s = ca.sample(&Disk, Vec2::new(fx, fy), u);
        prop_assert_eq!(s.throughput, [1.0, 1.0, 1.0]);
        prop_assert_eq!(s.lens_point, Disk.sample(u));
        // And the camera renders the same rays as without the model.
        let plain = ThinLensCamera::new(50.0, 36.0, 24.0).unwrap().with_aperture(8.0).unwrap().focused_at(3000.0).unwrap();
        let with = plain.with_chromatic_aberration(ca);
        let film = Vec2::new(fx * 18.0, fy * 12.0);
        prop_assert_eq!(plain.generate_ray(film, u, 0.3), with.generate_ray(film, u, 0.3));
    }

    /// At the image centre the three apertures coincide: weights exactly 1 at any strength.
    #[test]
    fn centre_is_neutral_at_any_strength(strength in -0.5f32..0.5, ux in 0.0f32..1.0, uy in 0.0f32..1.0, blades in 3u32..9) {
        let ca = ChromaticAberration::new(strength).unwrap();
        let shape = RegularPolygon::new(blades, 0.0).unwrap();
        prop_assert_eq!(ca.sample(&shape, Vec2::ZERO, Vec2::new(ux, uy)).throughput, [1.0, 1.0, 1.0]);
    }

    /// Off-centre, the weights are 3 [x in A_c] / #{apertures containing x}.
    #[test]
    fn weights_are_the_balance_heuristic(strength in 0.05f32..0.6, fx in -1.0f32..1.0, fy in -1.0f32..1.0, ux in 0.0f32..1.0, uy in 0.0f32..1.0) {
        let ca = ChromaticAberration::new(strength).unwrap();
        let film = Vec2::new(fx, fy);
        let s = ca.sample(&Disk, film, Vec2::new(ux, uy));
        let shifts = ca.shifts(film);
        let inside: Vec<bool> = shifts.iter().map(|d| Disk.contains(s.lens_point - *d)).collect();
        let count = inside.iter().filter(|b| **b).count() as f32;
        for c in 0..3 {
            // Points within rounding of an edge may go either way; skip those.
            let edge = ((s.lens_point - shifts[c]).length() - 1.0).abs() < 1e-4;
            if !edge {
                let expected = if inside[c] { 3.0 / count } else { 0.0 };
                prop_assert!((s.throughput[c] - expected).abs() < 1e-6, "channel {} {:?}", c, s.throughput);
            }
        }
    }
}

/// Unbiased for every channel: over many samples, channel c's weighted average of any function
/// g of the lens point equals g's average over that channel's own (shifted) aperture.
#[test]
fn estimator_is_unbiased_per_channel() {
    let ca = ChromaticAberration::new(0.4).unwrap();
    let film = Vec2::new(0.8, -0.5);
    let shifts = ca.shifts(film);
    let n = 400_000;
    let mut sum_w = [0.0f64; 3];
    let mut sum_wx = [0.0f64; 3];
    let mut state = 0x1234_5678_u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    for _ in 0..n {
        let s = ca.sample(&Disk, film, Vec2::new(next(), next()));
        for c in 0..3 {
            sum_w[c] += s.throughput[c] as f64;
            sum_wx[c] += s.throughput[c] as f64 * s.lens_point.x as f64;
        }
    }
    for c in 0..3 {
        // E[w_c] = 1 and E[w_c x] = centroid of A_c = shift_c.x (the disk is centred).
        let mean_w = sum_w[c] / n as f64;
        let mean_x = sum_wx[c] / n as f64;
        assert!((mean_w - 1.0).abs() < 0.01, "channel {c}: E[w] = {mean_w}");
        assert!(
            (mean_x - shifts[c].x as f64).abs() < 0.01,
            "channel {c}: E[w x] = {mean_x} vs {}",
            shifts[c].x
        );
    }
}
