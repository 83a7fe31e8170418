//! Colour carried along a path: three linear RGB channels for RGB scenes, or [`BANDS`] spectral
//! bands of 10 nm for scenes with spectral data. The integrator is generic over the count, so an
//! RGB scene pays for three multiplies per bounce, not thirty-one.

use std::ops::{Add, AddAssign, Div, Mul};

use crate::spectra::{Table, CIE1931, FIRST_NM, SAMPLES, STEP_NM};

/// Spectral bands of the spectral path.
pub const BANDS: usize = 31;
/// Centre of the first band, nm; bands are [`BAND_NM`] wide (so 395..705 nm in all).
pub const FIRST_BAND_NM: f64 = 400.0;
/// Width of one band, nm.
pub const BAND_NM: f64 = 10.0;

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

/// Centre wavelength of band `i`, nm.
pub fn band_centre_nm(i: usize) -> f64 {
    FIRST_BAND_NM + BAND_NM * i as f64
}

/// Averages a spectrum sampled on the 380..=780 nm, 5 nm grid of [`crate::spectra`] over each
/// band (trapezoid weights 1/4, 1/2, 1/4 at the band's edges and centre).
pub fn bands_from_grid(samples: &[f64]) -> [f32; BANDS] {
    let at = |nm: f64| -> f64 {
        let i = ((nm - FIRST_NM) / STEP_NM).round() as usize;
        samples.get(i.min(SAMPLES - 1)).copied().unwrap_or_default()
    };
    std::array::from_fn(|b| {
        let c = band_centre_nm(b);
        (0.25 * at(c - 5.0) + 0.5 * at(c) + 0.25 * at(c + 5.0)) as f32
    })
}

/// Band averages of a spectrum given at arbitrary increasing wavelengths (linear
/// interpolation, held constant beyond the ends).
pub fn bands_from_samples(wavelengths_nm: &[f64], values: &[f64]) -> [f32; BANDS] {
    let at = |nm: f64| -> f64 {
        let n = wavelengths_nm.len().min(values.len());
        if n == 0 {
            return 0.0;
        }
        if nm <= wavelengths_nm[0] {
            return values[0];
        }
        for i in 1..n {
            if nm <= wavelengths_nm[i] {
                let t = (nm - wavelengths_nm[i - 1]) / (wavelengths_nm[i] - wavelengths_nm[i - 1]);
                return values[i - 1] + t * (values[i] - values[i - 1]);
            }
        }
        values[n - 1]
    };
    std::array::from_fn(|b| {
        let c = band_centre_nm(b);
        (0.25 * at(c - 5.0) + 0.5 * at(c) + 0.25 * at(c + 5.0)) as f32
    })
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

/// The CIE 1931 colour matching functions averaged over each band and normalised so a spectrum
/// of constant 1 has Y = 1 (the tracer's luminance unit): `XYZ = sum_b w[b] * L[b]`.
pub fn xyz_weights() -> [[f32; 3]; BANDS] {
    let table = Table::parse(CIE1931).expect("the built-in CIE 1931 table parses");
    let cols: Vec<[f32; BANDS]> = ["x_bar", "y_bar", "z_bar"]
        .iter()
        .map(|name| bands_from_grid(table.column(name).expect("CIE 1931 has x, y, z")))
        .collect();
    let y_sum: f32 = cols[1].iter().sum();
    std::array::from_fn(|b| [cols[0][b] / y_sum, cols[1][b] / y_sum, cols[2][b] / y_sum])
}

/// CIE XYZ to linear sRGB (IEC 61966-2-1, D65).
pub const XYZ_TO_LINEAR_SRGB: [[f32; 3]; 3] = [
    [3.2406, -1.5372, -0.4986],
    [-0.9689, 1.8758, 0.0415],
    [0.0557, -0.2040, 1.0570],
];

/// Linear sRGB of a band spectrum, with `weights` from [`xyz_weights`].
pub fn bands_to_linear_srgb(bands: &[f32], weights: &[[f32; 3]; BANDS]) -> [f32; 3] {
    let mut xyz = [0.0f32; 3];
    for (v, w) in bands.iter().zip(weights) {
        for c in 0..3 {
            xyz[c] += v * w[c];
        }
    }
    std::array::from_fn(|r| (0..3).map(|c| XYZ_TO_LINEAR_SRGB[r][c] * xyz[c]).sum())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_spectrum_has_unit_luminance() {
        let w = xyz_weights();
        let y: f32 = w.iter().map(|c| c[1]).sum();
        assert!((y - 1.0).abs() < 1e-6);
        // Equal energy is near-neutral in sRGB (E is not D65, so not exactly).
        let rgb = bands_to_linear_srgb(&[1.0; BANDS], &w);
        for c in rgb {
            assert!((c - 1.0).abs() < 0.25, "{rgb:?}");
        }
    }

    #[test]
    fn rgb_bands_keep_constants() {
        assert_eq!(bands_from_rgb([0.5; 3]), [0.5; BANDS]);
        let s = bands_from_samples(&[400.0, 700.0], &[0.0, 1.0]);
        assert!((s[15] - 0.5).abs() < 1e-6, "{}", s[15]);
    }
}
