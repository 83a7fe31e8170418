//! Random numbers and the warps the path tracer draws directions with.
//!
//! Every pixel has its own generator, seeded from the render seed and the pixel's index, so an
//! image is the same for a seed whatever the thread count or tile order.

use glam::{Vec2, Vec3};

/// PCG32 (O'Neill 2014, XSH-RR output), a small fast generator with good statistics.
#[derive(Debug, Clone)]
pub struct Rng {
    state: u64,
    increment: u64,
}

const PCG_MULTIPLIER: u64 = 6364136223846793005;

/// SplitMix64's finaliser (Steele et al. 2014): spreads nearby seeds far apart.
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

impl Rng {
    /// The generator for stream `stream` (a pixel index) of render seed `seed`.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Self {
            state: 0,
            increment: (mix64(stream ^ 0x9e3779b97f4a7c15) << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(mix64(seed));
        rng.next_u32();
        rng
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(PCG_MULTIPLIER)
            .wrapping_add(self.increment);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// Uniform in `[0, 1)`.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        // 24 bits: every value exactly representable and strictly below 1.
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniforms in `[0, 1)`.
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_f32(), self.next_f32())
    }
}

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
