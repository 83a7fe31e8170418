//! The one random-number generator of the host side: PCG32 (O'Neill 2014, XSH-RR output).
//!
//! The path tracer draws one stream per pixel and the sensor model one per noise source (fixed
//! patterns from the sensor seed, temporal noise from the frame seed, defects), each from its
//! own seed and stream number, so a render, a sensor's patterns and a frame's noise never share
//! or reorder each other's numbers.

use glam::Vec2;

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
