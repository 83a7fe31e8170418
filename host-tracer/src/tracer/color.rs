//! Colour carried along a path: three linear RGB channels for RGB scenes, or [`BANDS`] spectral
//! bands of 10 nm (the band grid of [`crate::spectra`]) for scenes with spectral data. The integrator is generic over the count, so an
//! RGB scene pays for three multiplies per bounce, not thirty-one.

use std::ops::{Add, AddAssign, Div, Mul};

use crate::spectra::{band_centre_nm, BANDS};

/// `N` channel values (linear RGB for `N = 3`, spectral bands for `N = BANDS`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Channels<const N: usize>(pub [f32; N]);

impl<const N: usize> Channels<N> {
    /// All zero.
    pub const ZERO: Self = Self([0.0; N]);
    /// All one.
    pub const ONE: Self = Self([1.0; N]);

    /// Every channel `v`.
    pub fn splat(v: f32) -> Self {
        Self([v; N])
    }

    /// Largest channel.
    pub fn max_channel(&self) -> f32 {
        self.0.iter().copied().fold(0.0, f32::max)
    }

    /// Mean of the channels.
    pub fn mean(&self) -> f32 {
        self.0.iter().sum::<f32>() / N as f32
    }

    /// True when every channel is zero.
    pub fn is_black(&self) -> bool {
        self.0.iter().all(|&v| v == 0.0)
    }
}

impl<const N: usize> Add for Channels<N> {
    type Output = Self;
    fn add(mut self, o: Self) -> Self {
        self += o;
        self
    }
}

impl<const N: usize> AddAssign for Channels<N> {
    fn add_assign(&mut self, o: Self) {
        for (a, b) in self.0.iter_mut().zip(o.0) {
            *a += b;
        }
    }
}

impl<const N: usize> Mul for Channels<N> {
    type Output = Self;
    fn mul(mut self, o: Self) -> Self {
        for (a, b) in self.0.iter_mut().zip(o.0) {
            *a *= b;
        }
        self
    }
}

impl<const N: usize> Mul<f32> for Channels<N> {
    type Output = Self;
    fn mul(mut self, k: f32) -> Self {
        for a in &mut self.0 {
            *a *= k;
        }
        self
    }
}

impl<const N: usize> Div<f32> for Channels<N> {
    type Output = Self;
    fn div(self, k: f32) -> Self {
        self * (1.0 / k)
    }
}

/// A spectrum standing in for an RGB triple in a spectral scene: blue below 490 nm, green to
/// 590 nm, red above. A constant RGB gives the same constant spectrum (white stays white,
/// reflectances stay in [0, 1]); other colours are approximate. Scenes that need exact colour
/// give spectra.
pub fn bands_from_rgb(rgb: [f32; 3]) -> [f32; BANDS] {
    std::array::from_fn(|b| match band_centre_nm(b) {
        nm if nm < 490.0 => rgb[2],
        nm if nm < 590.0 => rgb[1],
        _ => rgb[0],
    })
}

/// Which of the camera's R, G, B chromatic-aberration weights band `i` takes (the same split
/// as [`bands_from_rgb`]).
pub fn band_rgb_channel(i: usize) -> usize {
    match band_centre_nm(i) {
        nm if nm < 490.0 => 2,
        nm if nm < 590.0 => 1,
        _ => 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rgb_bands_keep_constants() {
        assert_eq!(bands_from_rgb([0.5; 3]), [0.5; BANDS]);
    }
}
