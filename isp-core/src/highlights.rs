//! Highlight neutralisation: once a white-balanced pixel, or the raw around it, nears the clip
//! level, its colour fades to neutral, fully so at the clip.
//!
//! Where a channel clipped, the ratio between the channels says where the sensor stopped, not
//! what the scene was: white-balance gains then turn clipped whites magenta or yellow (the
//! unclipped channels are scaled past the clipped one), and demosaicing next to clipped samples
//! interpolates across a step far larger than the scene's (the light was brighter than the
//! clip), leaving speckles and fringes of every colour around a bright light. The pipeline clips
//! each white-balanced sample at 1, so a pixel whose channels or whose raw neighbours are at or
//! near 1 has unreliable colour. This stage, right after demosaicing (the neighbours are the
//! 3x3 raw samples the interpolation drew on most) and before distortion, denoise and the
//! colour matrix (which would spread a cast into every output channel), moves each channel
//! towards the pixel's largest by
//!
//! ```text
//! m = max(r, g, b)
//! n = max(m, the 3x3 white-balanced raw samples around the pixel)
//! k = clamp((n - knee) / (1 - knee), 0, 1)
//! c' = c + k * (m - c)
//! ```
//!
//! so pixels away from highlights are untouched, the fade is continuous, brightness never drops
//! (the pixel was at least `m` bright) and clipped areas and their rims come out neutral, as
//! in-camera highlight desaturation and fringe suppression do. The cost: a saturated colour
//! bright enough to reach the knee, and a one-pixel rim around it, lose saturation too. The
//! fixed path computes the same in 16-bit linear units with a Q48 reciprocal ([`KneeQ16`]).
//!
//! ```
//! use isp_core::highlights::{neutralise_f32, KneeQ16};
//! // A clipped white that white balance made magenta comes out white.
//! assert_eq!(neutralise_f32([1.0, 0.93, 1.0], 0.0, 0.9), [1.0, 1.0, 1.0]);
//! // Below the knee nothing changes.
//! assert_eq!(neutralise_f32([0.8, 0.5, 0.2], 0.0, 0.9), [0.8, 0.5, 0.2]);
//! // Next to a clipped sample, a dark pixel's colour goes too (a fringe).
//! assert_eq!(neutralise_f32([0.05, 0.25, 0.05], 1.0, 0.9), [0.25, 0.25, 0.25]);
//! // Halfway between the knee and the clip, channels move halfway to the largest.
//! let [r, g, b] = neutralise_f32([0.95, 0.55, 0.35], 0.0, 0.9);
//! assert!((r - 0.95).abs() < 1e-6 && (g - 0.75).abs() < 1e-6 && (b - 0.65).abs() < 1e-6);
//! assert_eq!(KneeQ16::new(0.9).neutralise([65535, 60948, 65535], 0), [65535; 3]);
//! ```

/// The float stage: each channel of `rgb` (white-balanced, `[0, 1]`) moved towards the largest
/// as the larger of that and `neighbourhood` (the largest raw sample around the pixel) rises
/// from `knee` to 1. A knee of 1 (or more) changes nothing.
#[inline]
pub fn neutralise_f32(rgb: [f32; 3], neighbourhood: f32, knee: f32) -> [f32; 3] {
    if knee >= 1.0 {
        return rgb;
    }
    neutralise_f32_below_clip(rgb, neighbourhood, knee)
}

/// [`neutralise_f32`] for a knee below 1, without a branch, so the loops that run it per pixel
/// vectorise: below the knee the fade `k` is 0, and `v + 0 * (m - v)` is `v` (tested against
/// the formula with an early return). Maxima and minima are selects, one instruction each on
/// x86 (`f32::max` adds a NaN rule).
#[inline(always)]
pub(crate) fn neutralise_f32_below_clip(rgb: [f32; 3], neighbourhood: f32, knee: f32) -> [f32; 3] {
    let max = |a: f32, b: f32| if a > b { a } else { b };
    let [r, g, b] = rgb;
    let m = max(max(r, g), b);
    let n = max(m, neighbourhood);
    let k = (n - knee) / (1.0 - knee);
    let k = if k < 1.0 { k } else { 1.0 };
    let k = if n > knee { k } else { 0.0 };
    [r + k * (m - r), g + k * (m - g), b + k * (m - b)]
}

/// The fixed-point stage's parameters: the knee in 16-bit linear units (65535 = 1.0) with 16
/// fractional bits, so it is the float knee to well under a code, and the Q48 reciprocal of the
/// span from it to the clip.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KneeQ16 {
    knee_q16: u64,
    reciprocal: u64,
}

/// 65535 (the clip) in the knee's units.
const CLIP_Q16: u64 = 65535 << 16;

impl KneeQ16 {
    /// From the float knee (clamped to `[0, 1]`; a knee within 2^-16 of a code of the clip
    /// acts as that far below it, the last knee with a span).
    pub fn new(knee: f32) -> Self {
        let knee_q16 = ((f64::from(knee.clamp(0.0, 1.0)) * CLIP_Q16 as f64 + 0.5) as u64)
            .min(CLIP_Q16 - (1 << 16));
        let span = CLIP_Q16 - knee_q16;
        Self {
            knee_q16,
            reciprocal: ((1u64 << 48) + span / 2) / span,
        }
    }

    /// The stage on 16-bit linear RGB with the largest raw sample around the pixel, rounding
    /// to nearest. Without a branch, so the loops that run it per pixel vectorise: below the
    /// knee `k` is 0 and so is every lift (tested against the formula with an early return).
    #[inline(always)]
    pub fn neutralise(&self, rgb: [u16; 3], neighbourhood: u16) -> [u16; 3] {
        let max = |a: u16, b: u16| if a > b { a } else { b };
        let [r, g, b] = rgb;
        let m = max(max(r, g), b);
        let above = (u64::from(max(m, neighbourhood)) << 16).saturating_sub(self.knee_q16);
        // k in Q16, 65536 = fully neutral; above <= span, so the product is below 2^49.
        let k = (above * self.reciprocal + (1 << 31)) >> 32;
        let k = (if k < 1 << 16 { k } else { 1 << 16 }) as u32;
        // In `u32`: (m - v) k + 2^15 <= 65535 * 65536 + 2^15 < 2^32, and v + lift <= m.
        let lift = |v: u16| {
            let lifted = u32::from(v) + ((u32::from(m - v) * k + (1 << 15)) >> 16);
            (if lifted < u32::from(m) {
                lifted
            } else {
                u32::from(m)
            }) as u16
        };
        [lift(r), lift(g), lift(b)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stage's formula as documented, with its early return below the knee: what the
    /// branch-free float stage must equal.
    fn reference_f32(rgb: [f32; 3], neighbourhood: f32, knee: f32) -> [f32; 3] {
        let m = rgb[0].max(rgb[1]).max(rgb[2]);
        let n = m.max(neighbourhood);
        if n <= knee || knee >= 1.0 {
            return rgb;
        }
        let k = ((n - knee) / (1.0 - knee)).min(1.0);
        rgb.map(|v| v + k * (m - v))
    }

    /// The same for the fixed stage, in `u64` throughout.
    fn reference_q16(q: &KneeQ16, rgb: [u16; 3], neighbourhood: u16) -> [u16; 3] {
        let m = rgb[0].max(rgb[1]).max(rgb[2]);
        let above = (u64::from(m.max(neighbourhood)) << 16).saturating_sub(q.knee_q16);
        if above == 0 {
            return rgb;
        }
        let k = ((above * q.reciprocal + (1 << 31)) >> 32).min(1 << 16);
        rgb.map(|v| {
            let lift = (u64::from(m - v) * k + (1 << 15)) >> 16;
            (u64::from(v) + lift).min(u64::from(m)) as u16
        })
    }

    /// The branch-free stages give the formulas' values: on a grid of colours, neighbourhoods
    /// and knees (including values at and next to the knee), and on random values.
    #[test]
    fn lane_forms_equal_the_stages() {
        let mut next = crate::math::xorshift(0x9e37_79b9_7f4a_7c15);
        for knee in [0.0f32, 0.5, 0.8, 0.9, 0.97, 0.999, 0.99999] {
            let q = KneeQ16::new(knee);
            let at_knee = (knee * 65535.0) as u16;
            let mut values = [0u16; 49];
            values[..9].copy_from_slice(&[
                0,
                1,
                1000,
                32768,
                65534,
                65535,
                at_knee.saturating_sub(1),
                at_knee,
                at_knee.saturating_add(1),
            ]);
            for v in &mut values[9..] {
                *v = (next() >> 48) as u16;
            }
            for &r in &values {
                for &g in &values {
                    for &b in &values[..8] {
                        for &n in &values[..9] {
                            let rgb = [r, g, b];
                            assert_eq!(q.neutralise(rgb, n), reference_q16(&q, rgb, n));
                            let unit = rgb.map(|v| f32::from(v) / 65535.0);
                            let nf = f32::from(n) / 65535.0;
                            let lanes = neutralise_f32(unit, nf, knee);
                            let stage = reference_f32(unit, nf, knee);
                            assert_eq!(lanes.map(f32::to_bits), stage.map(f32::to_bits));
                        }
                    }
                }
            }
        }
    }

    /// The fixed stage is within one 16-bit code of the float stage over a grid of colours and
    /// knees, and both leave pixels below the knee alone and make the clip neutral.
    #[test]
    fn fixed_follows_float() {
        for knee in [0.0f32, 0.5, 0.8, 0.9, 0.97, 0.999] {
            let q = KneeQ16::new(knee);
            for r in (0..=65535u32).step_by(4369) {
                for g in (0..=65535u32).step_by(3855) {
                    for b in [0u32, 1000, 30000, 60000, 65535] {
                        let rgb = [r as u16, g as u16, b as u16];
                        let n = [0u16, 50000, 65535][(r as usize + b as usize) % 3];
                        let f = neutralise_f32(
                            rgb.map(|v| f32::from(v) / 65535.0),
                            f32::from(n) / 65535.0,
                            knee,
                        );
                        let fixed = q.neutralise(rgb, n);
                        for c in 0..3 {
                            let d = (f64::from(fixed[c]) - f64::from(f[c]) * 65535.0).abs();
                            assert!(d <= 1.0, "knee {knee} {rgb:?}: {fixed:?} vs {f:?}");
                        }
                        let m = rgb.iter().max().copied().unwrap().max(n);
                        if f32::from(m) / 65535.0 <= knee {
                            assert_eq!(fixed, rgb);
                        }
                        if rgb.contains(&65535) {
                            assert_eq!(fixed, [65535; 3]);
                        }
                    }
                }
            }
        }
    }
}
