//! The three-aperture chromatic aberration heuristic.
//!
//! Each of red, green and blue gets its own copy of the aperture, shifted along the radial
//! direction of the image point by `strength * p` (red outwards, green in place, blue inwards),
//! where `p` is the film point normalised so the sensor's corner is at distance 1. At the image
//! centre the three coincide. A shifted aperture moves an out-of-focus blur, not a focused
//! point: the fringes appear where the image is out of focus, grow with the defocus, flip sign
//! across the focus plane and vanish on it. That is the heuristic's look, not true lateral
//! colour (a magnification that differs per wavelength, sharp fringes even in focus).
//!
//! A lens point `x` is drawn from the mixture of the three apertures (one picked uniformly,
//! then sampled). Channel `c` gets the one-sample balance-heuristic weight
//! `w_c = 3 p_c(x) / sum_j p_j(x)`, which for uniform apertures is
//! `3 [x in A_c] / (number of apertures containing x)`: unbiased for every channel.

use glam::Vec2;

use crate::aperture::{split, ApertureShape};
use crate::{OpticsError, Result};

/// Strength of the three-aperture model; 0 (the default) turns it off at no cost.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ChromaticAberration {
    strength: f32,
}

/// A lens point and the per-channel (R, G, B) weight it carries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChromaticSample {
    /// Point on the aperture plane, in units of the aperture radius.
    pub lens_point: Vec2,
    /// Weight for each of R, G, B.
    pub throughput: [f32; 3],
}

impl ChromaticAberration {
    /// A model with shift `strength` aperture radii per unit of normalised image radius
    /// (finite; negative reverses the colour order).
    pub fn new(strength: f32) -> Result<Self> {
        if !strength.is_finite() {
            return Err(OpticsError::InvalidParameter {
                name: "strength",
                allowed: "finite",
            });
        }
        Ok(Self { strength })
    }

    /// The strength.
    pub fn strength(&self) -> f32 {
        self.strength
    }

    /// Aperture shift of R, G and B at the normalised film point `film`.
    pub fn shifts(&self, film: Vec2) -> [Vec2; 3] {
        let d = film * self.strength;
        [d, Vec2::ZERO, -d]
    }

    /// Samples a lens point for `film` (normalised) from `u` in `[0, 1)^2`.
    pub fn sample<S: ApertureShape>(&self, shape: &S, film: Vec2, u: Vec2) -> ChromaticSample {
        if self.strength == 0.0 {
            // Off: the plain aperture sample, the same point the thin lens alone would use.
            return ChromaticSample {
                lens_point: shape.sample(u),
                throughput: [1.0; 3],
            };
        }
        let shifts = self.shifts(film);
        let (chosen, ux) = split(u.x, 3);
        let chosen = chosen as usize;
        let base = shape.sample(Vec2::new(ux, u.y));
        let x = base + shifts[chosen];
        let mut pdf = [0.0f32; 3];
        for (c, p) in pdf.iter_mut().enumerate() {
            // The chosen aperture's density is taken at the sampled point itself, so rounding in
            // the shift can never leave it at zero.
            *p = if c == chosen {
                shape.pdf(base)
            } else {
                shape.pdf(x - shifts[c])
            };
        }
        let sum = pdf[0] + pdf[1] + pdf[2];
        let throughput = if sum > 0.0 {
            pdf.map(|p| 3.0 * p / sum)
        } else {
            [0.0; 3]
        };
        ChromaticSample {
            lens_point: x,
            throughput,
        }
    }
}
