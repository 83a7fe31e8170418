//! The warps the path tracer draws directions with, and its random numbers: every pixel has
//! its own [`Rng`] stream ([`crate::random`]), seeded from the render seed and the pixel's
//! index, so an image is the same for a seed whatever the thread count or tile order.

use glam::{Vec2, Vec3};

pub use crate::random::Rng;

/// An orthonormal basis around unit `n` (Duff et al. 2017, "Building an orthonormal basis,
/// revisited"): returns `(t, b)` with `t x b = n`.
#[inline]
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// A cosine-distributed direction around unit `n` (Malley's method) and its cosine with `n`;
/// the density is `cos / pi`.
#[inline]
pub fn cosine_hemisphere(n: Vec3, u: Vec2) -> (Vec3, f32) {
    let r = u.x.sqrt();
    let (sin, cos) = optics_core::math::sin_cos_turns(u.y);
    let (x, y) = (r * cos, r * sin);
    let z = (1.0 - u.x).max(0.0).sqrt();
    let (t, b) = basis(n);
    (t * x + b * y + n * z, z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_differ_and_repeat() {
        let a: Vec<u32> = (0..4).map(|_| Rng::new(1, 7).next_u32()).collect();
        assert!(a.windows(2).all(|w| w[0] == w[1]));
        let mut x = Rng::new(1, 7);
        let mut y = Rng::new(1, 8);
        let same = (0..64).filter(|_| x.next_u32() == y.next_u32()).count();
        assert!(same < 2);
    }

    #[test]
    fn uniforms_have_the_right_mean() {
        let mut rng = Rng::new(3, 0);
        let n = 100_000;
        let mean: f64 = (0..n).map(|_| rng.next_f32() as f64).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 0.005, "{mean}");
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
            Vec3::X,
        ] {
            let (t, b) = basis(n);
            assert!(t.dot(b).abs() < 1e-5 && t.dot(n).abs() < 1e-5 && b.dot(n).abs() < 1e-5);
            assert!((t.cross(b) - n).length() < 1e-5);
        }
    }

    #[test]
    fn cosine_samples_have_mean_cosine_two_thirds() {
        let mut rng = Rng::new(5, 0);
        let n = Vec3::new(0.2, 0.9, -0.1).normalize();
        let k = 100_000;
        let mut sum = 0.0;
        for _ in 0..k {
            let (d, c) = cosine_hemisphere(n, rng.next_2d());
            assert!((d.dot(n) - c).abs() < 1e-4 && (d.length() - 1.0).abs() < 1e-4);
            sum += c as f64;
        }
        assert!((sum / k as f64 - 2.0 / 3.0).abs() < 0.005);
    }
}
