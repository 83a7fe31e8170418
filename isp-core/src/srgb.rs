//! The sRGB transfer functions of IEC 61966-2-1, exact, in `f32`.
//!
//! Encoding (OETF, linear -> signal): `12.92 x` for `x <= 0.0031308`, else
//! `1.055 x^(1/2.4) - 0.055`. Decoding (EOTF) inverts it with the threshold `0.04045`.
//! Inputs outside `[0, 1]` are clamped; NaN maps to 0, so the output is always in `[0, 1]`.

use crate::math;

/// Linear value above which the power segment applies.
pub const LINEAR_THRESHOLD: f32 = 0.003_130_8;
/// Encoded value above which the power segment applies.
pub const ENCODED_THRESHOLD: f32 = 0.040_45;

fn clamp01(x: f32) -> f32 {
    if x > 0.0 {
        x.min(1.0)
    } else {
        0.0 // also NaN
    }
}

/// Linear light in `[0, 1]` to the sRGB signal in `[0, 1]`.
pub fn encode(linear: f32) -> f32 {
    let x = clamp01(linear);
    if x <= LINEAR_THRESHOLD {
        12.92 * x
    } else {
        clamp01(1.055 * math::powf(x, 1.0 / 2.4) - 0.055)
    }
}

/// The sRGB signal in `[0, 1]` to linear light in `[0, 1]`.
pub fn decode(encoded: f32) -> f32 {
    let v = clamp01(encoded);
    if v <= ENCODED_THRESHOLD {
        v / 12.92
    } else {
        clamp01(math::powf((v + 0.055) / 1.055, 2.4))
    }
}
