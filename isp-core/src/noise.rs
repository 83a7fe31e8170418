//! The sensor's noise model: the variance of a raw sample as a function of its signal.
//!
//! A raw sample's signal `x`, in units of the white level above black (`(raw - black) / (white
//! - black)`, so 0 is black and 1 is white), has temporal noise of variance
//!
//! ```text
//! var(x) = S * x + O
//! ```
//!
//! per CFA colour: `S` is the shot-noise scale (the conversion gain's share: one electron is `S`
//! of the range), `O` the signal-independent floor (read noise, row and column noise, dark
//! noise, quantisation). This is the DNG `NoiseProfile` tag (51041, DNG 1.3: `N(x) = sqrt(S x +
//! O)`, one pair for every plane or one per colour plane) and Android's
//! `SENSOR_NOISE_PROFILE`. Fixed-pattern noise (PRNU, DSNU) is not part of it: like a
//! photon-transfer measurement by differencing two frames, the profile describes what changes
//! from frame to frame.
//!
//! ```
//! use isp_core::noise::NoiseProfile;
//! use isp_core::CfaColour;
//! let p = NoiseProfile::uniform(0.0032, 4.5e-6).unwrap();
//! // At mid grey the shot noise dominates: sqrt(0.0032 * 0.5 + 4.5e-6) = 0.04.
//! let sigma = p.sigma(CfaColour::Green, 0.5);
//! assert!((sigma - 0.0400562).abs() < 1e-6);
//! assert!(NoiseProfile::uniform(-1.0, 0.0).is_err());
//! ```

use crate::{CfaColour, IspError};

/// Largest scale or offset accepted: a variance of 1 is a noise as large as the whole range.
pub const MAX_TERM: f32 = 1.0;

/// `var(x) = S * x + O` per CFA colour (red, green, blue), `x` in units of the white level
/// above black. Build it with [`NoiseProfile::new`] or [`NoiseProfile::uniform`], which check
/// it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseProfile {
    scale: [f32; 3],
    offset: [f32; 3],
}

impl NoiseProfile {
    /// One `(S, O)` pair per colour, red, green, blue. Each term finite and in
    /// `[0, MAX_TERM]`, and each colour's pair not both 0 (a noiseless sensor has no profile).
    pub fn new(scale: [f32; 3], offset: [f32; 3]) -> Result<Self, IspError> {
        let term_ok = |v: f32| v.is_finite() && (0.0..=MAX_TERM).contains(&v);
        if !scale.iter().chain(&offset).all(|v| term_ok(*v)) {
            return Err(IspError::InvalidParameter {
                name: "noise profile",
                allowed: "scale S and offset O finite and in [0, 1]",
            });
        }
        if scale
            .iter()
            .zip(&offset)
            .any(|(s, o)| *s == 0.0 && *o == 0.0)
        {
            return Err(IspError::InvalidParameter {
                name: "noise profile",
                allowed: "S and O not both 0 for any colour",
            });
        }
        Ok(Self { scale, offset })
    }

    /// The same `(S, O)` for every colour.
    pub fn uniform(scale: f32, offset: f32) -> Result<Self, IspError> {
        Self::new([scale; 3], [offset; 3])
    }

    /// From the values as the DNG NoiseProfile tag lists them: `[S, O]` for every colour, or
    /// `[S_R, O_R, S_G, O_G, S_B, O_B]`, checked as [`Self::new`] checks them.
    ///
    /// ```
    /// use isp_core::noise::NoiseProfile;
    /// let p = NoiseProfile::from_pairs(&[0.003, 1e-6]).unwrap();
    /// assert!(p.is_uniform());
    /// assert!(NoiseProfile::from_pairs(&[0.003, 1e-6, 0.003]).is_err());
    /// ```
    pub fn from_pairs(values: &[f64]) -> Result<Self, IspError> {
        let pairs: [(f64, f64); 3] = match *values {
            [s, o] => [(s, o); 3],
            [sr, or, sg, og, sb, ob] => [(sr, or), (sg, og), (sb, ob)],
            _ => {
                return Err(IspError::InvalidParameter {
                    name: "noise profile",
                    allowed: "2 values (S, O) or 6 (S, O per colour R, G, B)",
                })
            }
        };
        Self::new(pairs.map(|p| p.0 as f32), pairs.map(|p| p.1 as f32))
    }

    /// `S` per colour, red, green, blue.
    pub fn scale(&self) -> [f32; 3] {
        self.scale
    }

    /// `O` per colour, red, green, blue.
    pub fn offset(&self) -> [f32; 3] {
        self.offset
    }

    /// Whether every colour has the same pair (a DNG then stores one pair).
    pub fn is_uniform(&self) -> bool {
        self.scale.iter().all(|s| *s == self.scale[0])
            && self.offset.iter().all(|o| *o == self.offset[0])
    }

    /// The variance of a sample of `colour` at signal `x` (clamped to `[0, 1]`).
    pub fn variance(&self, colour: CfaColour, x: f32) -> f32 {
        let c = colour.index();
        self.scale[c] * x.clamp(0.0, 1.0) + self.offset[c]
    }

    /// The standard deviation of a sample of `colour` at signal `x` (clamped to `[0, 1]`).
    pub fn sigma(&self, colour: CfaColour, x: f32) -> f32 {
        libm::sqrtf(self.variance(colour, x))
    }

    /// The profile after a gain `gain` on every colour (ISO or digital gain applied to the
    /// samples, clipping aside): `var(g x) = g S (g x) + g^2 O`. `None` when a term would leave
    /// `[0, MAX_TERM]` or `gain` is not finite and positive.
    pub fn gained(&self, gain: f32) -> Option<Self> {
        if !(gain.is_finite() && gain > 0.0) {
            return None;
        }
        Self::new(
            self.scale.map(|s| s * gain),
            self.offset.map(|o| o * gain * gain),
        )
        .ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_term_is_checked() {
        for bad in [f32::NAN, f32::INFINITY, -1e-9, 1.5] {
            assert!(NoiseProfile::new([0.01, bad, 0.01], [0.0; 3]).is_err());
            assert!(NoiseProfile::new([0.01; 3], [0.0, 0.0, bad]).is_err());
        }
        assert!(NoiseProfile::new([0.01, 0.0, 0.01], [0.0; 3]).is_err());
        let p = NoiseProfile::new([0.01, 0.0, 0.01], [0.0, 1e-6, 0.0]).unwrap();
        assert!(!p.is_uniform());
        assert_eq!(p.variance(CfaColour::Green, 0.7), 1e-6);
        assert_eq!(p.variance(CfaColour::Red, 2.0), 0.01);
    }

    #[test]
    fn a_gain_scales_the_model_as_the_samples() {
        let p = NoiseProfile::uniform(0.002, 1e-6).unwrap();
        let g = p.gained(4.0).unwrap();
        // var(4 x) at 4 x = 0.4 is 16 var(x) at x = 0.1.
        let expect = 16.0 * p.variance(CfaColour::Red, 0.1);
        assert!((g.variance(CfaColour::Red, 0.4) - expect).abs() < 1e-9);
        assert!(p.gained(0.0).is_none());
        assert!(p.gained(1e6).is_none());
    }
}
