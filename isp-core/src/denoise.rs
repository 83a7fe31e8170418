//! Noise reduction driven by the sensor's noise profile: non-local means on the raw mosaic,
//! packed into its four CFA planes, with every distance measured in units of the noise's own
//! variance.
//!
//! The stage runs on the mosaic right after black-level subtraction (so the raw's
//! [`NoiseProfile`], which is stated there, applies as it is), before shading, gains and
//! demosaicing (which would correlate the noise and spread it across colours). Each 2x2 CFA
//! block is one *packed pixel* with four channels, one per CFA position; a packed pixel and
//! its neighbours at offsets `o` within [`SEARCH_RADIUS`] are compared through the 3x3 packed
//! patches around them, all four channels together, so one weight moves all colours of a
//! block together (no chroma noise from planes filtered apart).
//!
//! # Float semantics
//!
//! With `x_k(q)` channel `k` of packed pixel `q` (a fraction of white above black, clamped to
//! `[0, 1]`), reflect-101 at the frame's edges in packed coordinates:
//!
//! ```text
//! m_k(q)  = mean of x_k over the 3x3 packed pixels around q
//! iv_k(q) = 1 / max(S_k m_k(q) + O_k, Q)        Q = (16 / 65535)^2, a floor
//! D_o(p)  = sum over q in the 3x3 around p, over k, of (x_k(q + o) - x_k(q))^2 iv_k(q)
//! u       = max(0, 1 - max(D_o(p) - 72, 0) / (8 * 72 * h^2)),   h = 0.8 * strength
//! w_o(p)  = u^8                                 (about exp(-max(D - 72, 0) / (72 h^2)))
//! out_k(p) = sum_o w_o(p) x_k(p + o) / sum_o w_o(p)
//! ```
//!
//! `S_k` and `O_k` are the profile's scale and offset for the colour at CFA position `k`. For
//! pure noise `D` is about 72 (36 terms of expectation 2), so the weight falls from 1 once
//! two patches differ by more than noise; the centre always has weight 1. The polynomial
//! `u^8` stands in for the exponential of the classic method (Buades, Coll and Morel 2005)
//! and is cheap in integers. Dividing by the variance of each sample's own level is the
//! classic method under a variance-stabilising transform (Foi's generalised Anscombe) without
//! the transform's inverse, whose bias in the dark needs a correction; the output is a convex
//! combination of the input, so flat areas keep their level.
//!
//! # Fixed-point path
//!
//! Samples are `u16` (65535 = 1.0). `iv` is `2^56 / var_q16` with the variance in `u16^2`
//! units in Q16 (the floor, 256, keeps it below 2^32 and the variance's whole realistic range
//! at 14 bits or more), each term `(diff^2 iv) >> 24` (Q16: the product fits 64 bits), `u` in
//! Q24 from a Q24 reciprocal of the span, `u^8` by three rounded squarings, and the output the
//! weighted sum divided by the weights' sum, rounded to nearest. The ISO gain and white balance
//! after the stage multiply what differs from the float path, and sRGB's toe multiplies it
//! again, so every step keeps bits to spare: within an 8-bit code of the float path.
//!
//! Quality, speed and what bounds them: `camsim bench denoise` and `docs/performance.md`.

use crate::demosaic::reflect;
use crate::noise::NoiseProfile;
use crate::{CfaPattern, IspError};

/// How far a packed pixel looks for similar ones (packed pixels, so 4 mosaic pixels).
pub const SEARCH_RADIUS: usize = 2;
/// Radius of the patches compared (packed pixels).
pub const PATCH_RADIUS: usize = 1;
/// Reflected packed pixels kept either side of each packed row, and packed rows either side
/// of the one filtered: the search and the patch together.
pub const PAD: usize = SEARCH_RADIUS + PATCH_RADIUS;
/// Packed rows one output packed row reads.
pub const PACKED_ROWS: usize = 2 * PAD + 1;
/// Largest strength (a multiplier on the profile-driven default, 1).
pub const MAX_STRENGTH: f32 = 4.0;
/// `h` at strength 1 (tuned on Kodak and McMaster raws at three noise levels).
const H_AT_STRENGTH_1: f32 = 0.8;
/// Terms of a patch distance: 3x3 packed pixels of four channels.
const TERMS: f32 = 36.0;
/// The variance floor: a standard deviation of 16 codes of 16 bits (one of 12 bits), far below
/// any visible noise; it bounds the fixed path's inverse variances.
const VAR_FLOOR: f64 = 256.0 / (65535.0 * 65535.0);
/// Fractional bits of the fixed path's weights.
const WEIGHT_BITS: u32 = 24;
/// Fractional bits of the fixed path's distances.
const DISTANCE_BITS: u32 = 16;
/// [`VAR_FLOOR`] in `u16^2` units, Q16.
const FLOOR_Q16: u64 = 256 << 16;

/// Elements of one packed row: four channel planes of `packed_width` samples plus [`PAD`]
/// reflected ones either side.
pub const fn packed_row_len(packed_width: usize) -> Option<usize> {
    match packed_width.checked_add(2 * PAD) {
        Some(p) => p.checked_mul(4),
        None => None,
    }
}

/// Elements of one packed row's inverse variances ([`inverse_variance_row_f32`],
/// [`inverse_variance_row_u16`]): four channels of `packed_width + 2` (one packed pixel beyond
/// either side).
pub const fn iv_row_len(packed_width: usize) -> Option<usize> {
    match packed_width.checked_add(2) {
        Some(wide) => wide.checked_mul(4),
        None => None,
    }
}

/// Working elements a filtered row needs (of the path's work type: `f32`, or `u64` for the
/// fixed path) with its inverse variances: three rows of them ([`iv_row_len`]) and
/// [`sums_len`].
pub const fn work_len(packed_width: usize) -> Option<usize> {
    let (Some(iv), Some(sums)) = (iv_row_len(packed_width), sums_len(packed_width)) else {
        return None;
    };
    match iv.checked_mul(3) {
        Some(v) => v.checked_add(sums),
        None => None,
    }
}

/// Working elements [`filter_row_f32`] and [`filter_row_u16`] take: one row of partial
/// distances (`packed_width + 2`) and the weighted sums (`5 * packed_width`).
pub const fn sums_len(packed_width: usize) -> Option<usize> {
    let Some(wide) = packed_width.checked_add(2) else {
        return None;
    };
    match packed_width.checked_mul(5) {
        Some(v) => v.checked_add(wide),
        None => None,
    }
}

/// The filter's parameters for the float path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloatParams {
    /// Scale and offset (with the floor) of each CFA position's variance.
    scale: [f32; 4],
    offset: [f32; 4],
    /// `1 / (8 * 72 * h^2)`.
    inv_span: f32,
}

/// The filter's parameters for the fixed path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FixedParams {
    /// Variance in `u16^2` units, Q16: `max(slope * sum9 + offset, floor)` (`sum9` the 3x3
    /// sum).
    slope_q16: [u64; 4],
    offset_q16: [u64; 4],
    /// `inv_span * 2^8` in Q24 (the excess is Q16, the weight Q24).
    inv_span_q24: u64,
}

/// Checks a strength: in `(0, MAX_STRENGTH]`.
fn check_strength(strength: f32) -> Result<f32, IspError> {
    if strength > 0.0 && strength <= MAX_STRENGTH {
        Ok(strength)
    } else {
        Err(IspError::InvalidParameter {
            name: "denoise strength",
            allowed: "(0, 4] (1 is the profile's default)",
        })
    }
}

/// The profile's (scale, offset) at each CFA position.
fn per_position(profile: &NoiseProfile, pattern: CfaPattern) -> [(f64, f64); 4] {
    let (s, o) = (profile.scale(), profile.offset());
    core::array::from_fn(|k| {
        let c = pattern.colour_at(k & 1, k >> 1).index();
        (f64::from(s[c]), f64::from(o[c]))
    })
}

/// `1 / (8 * 72 * h^2)` for a strength.
fn inv_span(strength: f32) -> f64 {
    let h = f64::from(H_AT_STRENGTH_1) * f64::from(strength);
    1.0 / (8.0 * f64::from(TERMS) * 2.0 * h * h)
}

impl FloatParams {
    /// The float filter for a raw of `pattern` with `profile`, at `strength` (`(0, 4]`, 1 the
    /// default).
    pub fn new(
        profile: &NoiseProfile,
        pattern: CfaPattern,
        strength: f32,
    ) -> Result<Self, IspError> {
        let strength = check_strength(strength)?;
        let p = per_position(profile, pattern);
        Ok(Self {
            scale: p.map(|(s, _)| s as f32),
            offset: p.map(|(_, o)| o as f32),
            inv_span: inv_span(strength) as f32,
        })
    }
}

impl FixedParams {
    /// The fixed-point filter for a raw of `pattern` with `profile`, at `strength`.
    pub fn new(
        profile: &NoiseProfile,
        pattern: CfaPattern,
        strength: f32,
    ) -> Result<Self, IspError> {
        let strength = check_strength(strength)?;
        let p = per_position(profile, pattern);
        let q16 = 65536.0;
        Ok(Self {
            // The variance at a mean of sum9 / 9 u16 units: S * 65535 * sum9 / 9 + O * 65535^2.
            slope_q16: p.map(|(s, _)| (s * 65535.0 / 9.0 * q16 + 0.5) as u64),
            offset_q16: p.map(|(_, o)| (o * 65535.0 * 65535.0 * q16 + 0.5) as u64),
            inv_span_q24: (inv_span(strength) * 256.0 * f64::from(1u32 << 24) + 0.5) as u64,
        })
    }
}

/// Channel `k`'s plane (padded) of a packed row.
#[inline]
fn plane<T>(row: &[T], k: usize, stride: usize) -> &[T] {
    &row[k * stride..(k + 1) * stride]
}

/// Checks the rows, inverse variances, work and output of a filtered row; returns the padded
/// stride.
fn check<T, W>(
    rows: &[&[T]],
    iv: &[&[W]],
    packed_width: usize,
    work: &[W],
    work_needed: Option<usize>,
    out_provided: usize,
    out_len: Option<usize>,
) -> Result<usize, IspError> {
    let too_small = |needed: Option<usize>, provided: usize| IspError::BufferTooSmall {
        needed: needed.unwrap_or(usize::MAX),
        provided,
    };
    let row_len = packed_row_len(packed_width);
    if let Some(short) = rows.iter().find(|r| Some(r.len()) != row_len) {
        return Err(too_small(row_len, short.len()));
    }
    let iv_len = iv_row_len(packed_width);
    if let Some(short) = iv.iter().find(|r| Some(r.len()) != iv_len) {
        return Err(too_small(iv_len, short.len()));
    }
    if work_needed.is_none_or(|n| work.len() < n) {
        return Err(too_small(work_needed, work.len()));
    }
    if Some(out_provided) != out_len {
        return Err(too_small(out_len, out_provided));
    }
    Ok(packed_width + 2 * PAD)
}

/// The 3x3 sums of channel `k` around packed columns `-1 ..= packed_width` of the middle of
/// `rows`, each passed to `emit(column + 1, sum)`, summed row by row, left to right (the
/// float path's order, which its results depend on).
#[inline(always)]
fn box_sums<T: Copy, S: core::ops::Add<Output = S>>(
    rows: &[&[T]; 3],
    k: usize,
    stride: usize,
    wide: usize,
    widen: impl Fn(T) -> S,
    mut emit: impl FnMut(usize, S),
) {
    let [up, mid, down] = rows.map(|r| plane(r, k, stride));
    for c in 0..wide {
        // Padded column c - 1 is index PAD + c - 1; its 3x3 neighbours start one left.
        let s = PAD + c - 2;
        let row = |r: &[T], sum: S| sum + widen(r[s]) + widen(r[s + 1]) + widen(r[s + 2]);
        let first = widen(up[s]) + widen(up[s + 1]) + widen(up[s + 2]);
        emit(c, row(down, row(mid, first)));
    }
}

/// The inverse variances `iv_k` of packed row `r` from `rows`, packed rows `r - 1 ..= r + 1`
/// (reflected, [`packed_row_len`] each), at packed columns `-1 ..= packed_width`, into `out`
/// ([`iv_row_len`]: four channels of `packed_width + 2`). The float path. Under reflect-101 a
/// row's 3x3 neighbourhoods are its mirror's, so a row's inverse variances serve wherever it
/// is reflected to: the engine keeps them in a ring, one row computed per packed row.
pub fn inverse_variance_row_f32(
    rows: [&[f32]; 3],
    packed_width: usize,
    params: &FloatParams,
    out: &mut [f32],
) -> Result<(), IspError> {
    inverse_variance_row(rows, packed_width, params, out)
}

/// As [`inverse_variance_row_f32`] in integers: `2^56 / var_q16`, at most `u32::MAX`.
pub fn inverse_variance_row_u16(
    rows: [&[u16]; 3],
    packed_width: usize,
    params: &FixedParams,
    out: &mut [u64],
) -> Result<(), IspError> {
    inverse_variance_row(rows, packed_width, params, out)
}

/// The inverse variances of both paths (see [`inverse_variance_row_f32`]).
fn inverse_variance_row<A: Arithmetic>(
    rows: [&[A::S]; 3],
    packed_width: usize,
    params: &A,
    out: &mut [A::W],
) -> Result<(), IspError> {
    let stride = check::<_, A::W>(
        &rows,
        &[],
        packed_width,
        &[],
        Some(0),
        out.len(),
        iv_row_len(packed_width),
    )?;
    let wide = packed_width + 2;
    for (k, dst) in out.chunks_exact_mut(wide).enumerate() {
        box_sums(&rows, k, stride, wide, A::widen, |c, sum| {
            dst[c] = params.inverse_variance(k, sum);
        });
    }
    Ok(())
}

/// What the float and fixed filters do differently: the arithmetic of one distance term, the
/// weight of a distance, a weighted sample and the output. [`filter_row`] is the one loop.
trait Arithmetic {
    /// Samples.
    type S: Copy;
    /// Distances, inverse variances, weights and sums.
    type W: Copy + Default + core::ops::Add<Output = Self::W> + core::ops::AddAssign;
    /// A sample in the work type.
    fn widen(x: Self::S) -> Self::W;
    /// The inverse variance of channel (CFA position) `k` at a 3x3 sum `sum9` of its samples.
    fn inverse_variance(&self, k: usize, sum9: Self::W) -> Self::W;
    /// One channel's squared difference of `a` and `b` over the variance (`i`, its inverse).
    fn term(a: Self::S, b: Self::S, i: Self::W) -> Self::W;
    /// The weight of a patch distance.
    fn weight(&self, distance: Self::W) -> Self::W;
    /// `w` times a sample.
    fn weighted(w: Self::W, x: Self::S) -> Self::W;
    /// The weighted mean `num / den` as a sample (`den` at least the centre's weight).
    fn output(num: Self::W, den: Self::W) -> Self::S;
}

impl Arithmetic for FloatParams {
    type S = f32;
    type W = f32;

    #[inline(always)]
    fn widen(x: f32) -> f32 {
        x
    }

    #[inline(always)]
    fn inverse_variance(&self, k: usize, sum9: f32) -> f32 {
        let var = self.scale[k] * (sum9 * (1.0 / 9.0)) + self.offset[k];
        1.0 / var.max(VAR_FLOOR as f32)
    }

    #[inline(always)]
    fn term(a: f32, b: f32, i: f32) -> f32 {
        let d = b - a;
        d * d * i
    }

    #[inline(always)]
    fn weight(&self, distance: f32) -> f32 {
        let excess = (distance - 2.0 * TERMS).max(0.0);
        let u = (1.0 - excess * self.inv_span).max(0.0);
        let u2 = u * u;
        let u4 = u2 * u2;
        u4 * u4
    }

    #[inline(always)]
    fn weighted(w: f32, x: f32) -> f32 {
        w * x
    }

    #[inline(always)]
    fn output(num: f32, den: f32) -> f32 {
        num / den
    }
}

impl Arithmetic for FixedParams {
    type S = u16;
    type W = u64;

    #[inline(always)]
    fn widen(x: u16) -> u64 {
        u64::from(x)
    }

    #[inline(always)]
    fn inverse_variance(&self, k: usize, sum9: u64) -> u64 {
        // At least 2^24 with the floor, so the quotient is at most 2^32.
        let var = (self.slope_q16[k] * sum9 + self.offset_q16[k]).max(FLOOR_Q16);
        ((1u64 << 56) / var).min(u64::from(u32::MAX))
    }

    #[inline(always)]
    fn term(a: u16, b: u16, i: u64) -> u64 {
        // d^2 < 2^32 and i < 2^32 (so `as u32` keeps it): one 32 x 32 -> 64 bit product,
        // which vectorises (`pmuludq`), where a 64-bit product of `u64` operands did not.
        let d = u32::from(a.abs_diff(b));
        (u64::from(d * d) * u64::from(i as u32)) >> (40 - DISTANCE_BITS)
    }

    #[inline(always)]
    fn weight(&self, distance: u64) -> u64 {
        let floor = (2 * 36) << DISTANCE_BITS;
        let one = 1u64 << WEIGHT_BITS;
        let square = |a: u64| (a * a + (1 << (WEIGHT_BITS - 1))) >> WEIGHT_BITS;
        // Beyond 65536 units every allowed strength has weight 0.
        let excess = distance.saturating_sub(floor).min(1 << 32);
        let drop = (excess.saturating_mul(self.inv_span_q24) >> 24).min(one);
        square(square(square(one - drop)))
    }

    #[inline(always)]
    fn weighted(w: u64, x: u16) -> u64 {
        w * u64::from(x)
    }

    #[inline(always)]
    fn output(num: u64, den: u64) -> u16 {
        // The centre's weight is 2^24, so the divisor is never 0.
        let d = den.max(1);
        ((num + d / 2) / d).min(65535) as u16
    }
}

/// Filters packed row `j` from `rows`, packed rows `j - 3 ..= j + 3` (reflected by the
/// caller; each [`packed_row_len`] long, reflected [`PAD`] packed pixels either side), and
/// `iv`, the inverse variances of packed rows `j - 1 ..= j + 1` ([`inverse_variance_row_f32`]),
/// into `out`: four planes of `packed_width` samples, CFA position by position (row-major in
/// the 2x2 block). `work` holds [`sums_len`] elements. The float path.
pub fn filter_row_f32(
    rows: [&[f32]; PACKED_ROWS],
    iv: [&[f32]; 3],
    packed_width: usize,
    params: &FloatParams,
    work: &mut [f32],
    out: &mut [f32],
) -> Result<(), IspError> {
    filter_row(rows, iv, packed_width, params, work, out)
}

/// As [`filter_row_f32`] in integers: samples `u16` (65535 = 1.0), inverse variances from
/// [`inverse_variance_row_u16`], work `u64`.
pub fn filter_row_u16(
    rows: [&[u16]; PACKED_ROWS],
    iv: [&[u64]; 3],
    packed_width: usize,
    params: &FixedParams,
    work: &mut [u64],
    out: &mut [u16],
) -> Result<(), IspError> {
    filter_row(rows, iv, packed_width, params, work, out)
}

/// The filter of both paths (see [`filter_row_f32`]), in `A`'s arithmetic; the float sums are
/// formed in the order the module docs give.
#[inline(always)]
fn filter_row<A: Arithmetic>(
    rows: [&[A::S]; PACKED_ROWS],
    iv: [&[A::W]; 3],
    packed_width: usize,
    params: &A,
    work: &mut [A::W],
    out: &mut [A::S],
) -> Result<(), IspError> {
    let stride = check(
        &rows,
        &iv,
        packed_width,
        work,
        sums_len(packed_width),
        out.len(),
        packed_width.checked_mul(4),
    )?;
    let wide = packed_width + 2;
    let (vsum, rest) = work.split_at_mut(wide);
    let (num, rest) = rest.split_at_mut(4 * packed_width);
    let den = &mut rest[..packed_width];
    num.fill(A::W::default());
    den.fill(A::W::default());
    for dy in -(SEARCH_RADIUS as isize)..=SEARCH_RADIUS as isize {
        for dx in -(SEARCH_RADIUS as isize)..=SEARCH_RADIUS as isize {
            // Column sums over the patch rows of the normalised squared differences.
            vsum.fill(A::W::default());
            for (t, iv_row) in iv.iter().enumerate() {
                let (r, n) = (t + 2, (t as isize + 2 + dy) as usize);
                for k in 0..4 {
                    let here = &plane(rows[r], k, stride)[PAD - 1..PAD + 1 + packed_width];
                    let s = (PAD as isize - 1 + dx) as usize;
                    let there = &plane(rows[n], k, stride)[s..s + wide];
                    let inv = plane(iv_row, k, wide);
                    for (((v, &a), &b), &i) in vsum.iter_mut().zip(here).zip(there).zip(inv) {
                        *v += A::term(a, b, i);
                    }
                }
            }
            let centre = (PAD as isize + dy) as usize;
            let s = (PAD as isize + dx) as usize;
            for (i, dn) in den.iter_mut().enumerate() {
                let w = params.weight(vsum[i] + vsum[i + 1] + vsum[i + 2]);
                *dn += w;
                for k in 0..4 {
                    num[k * packed_width + i] +=
                        A::weighted(w, plane(rows[centre], k, stride)[s + i]);
                }
            }
        }
    }
    // (Indexed per plane, not `chunks_exact_mut`, which panics on a width of 0.)
    for k in 0..4 {
        let plane_out = &mut out[k * packed_width..(k + 1) * packed_width];
        for (i, o) in plane_out.iter_mut().enumerate() {
            *o = A::output(num[k * packed_width + i], den[i]);
        }
    }
    Ok(())
}

/// Packs mosaic rows `pair` (two rows of `2 * packed_width` samples, the packed row's top and
/// bottom) into `dst` ([`packed_row_len`]): four channel planes with [`PAD`] reflected samples
/// either side.
pub fn pack_row<T: Copy>(
    pair: [&[T]; 2],
    packed_width: usize,
    dst: &mut [T],
) -> Result<(), IspError> {
    let stride = packed_width + 2 * PAD;
    if pair.iter().any(|r| r.len() < 2 * packed_width)
        || dst.len() < 4 * stride
        || packed_width == 0
    {
        return Err(IspError::InvalidParameter {
            name: "denoise rows",
            allowed: "two mosaic rows of twice the packed width",
        });
    }
    for (k, plane) in dst.chunks_exact_mut(stride).take(4).enumerate() {
        let row = pair[k >> 1];
        for (c, v) in plane.iter_mut().enumerate() {
            let i = reflect(c as isize - PAD as isize, packed_width);
            *v = row[2 * i + (k & 1)];
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Packed rows of a noisy ramp (a deterministic LCG), as both paths take them.
    fn rows(
        packed_width: usize,
        scale: f64,
    ) -> ([[f32; 4 * 38]; PACKED_ROWS], [[u16; 4 * 38]; PACKED_ROWS]) {
        assert_eq!(packed_width + 2 * PAD, 38);
        let mut state = 12345u64;
        let mut f = [[0.0f32; 4 * 38]; PACKED_ROWS];
        let mut u = [[0u16; 4 * 38]; PACKED_ROWS];
        for t in 0..PACKED_ROWS {
            for k in 0..4 {
                for c in 0..38 {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    let noise = ((state >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 3.46;
                    let level = 0.05 + 0.5 * c as f64 / 38.0;
                    let v = (level + noise * (scale * level).sqrt()).clamp(0.0, 1.0);
                    let q = (v * 65535.0).round() as u16;
                    u[t][k * 38 + c] = q;
                    f[t][k * 38 + c] = f32::from(q) / 65535.0;
                }
            }
        }
        (f, u)
    }

    #[test]
    fn fixed_filter_tracks_the_float_filter() {
        let wp = 32;
        for scale in [0.0008f32, 0.0032, 0.0128] {
            let profile = NoiseProfile::uniform(scale, 2.5e-4).unwrap();
            let (f, u) = rows(wp, f64::from(scale));
            let fp = FloatParams::new(&profile, CfaPattern::Rggb, 1.0).unwrap();
            let xp = FixedParams::new(&profile, CfaPattern::Rggb, 1.0).unwrap();
            let mut fw = [0.0f32; 1024];
            let mut uw = [0u64; 1024];
            let (mut fi, mut ui) = ([[0.0f32; 4 * 34]; 3], [[0u64; 4 * 34]; 3]);
            for t in 0..3 {
                let f3 = core::array::from_fn(|d| &f[t + 1 + d][..]);
                inverse_variance_row_f32(f3, wp, &fp, &mut fi[t]).unwrap();
                let u3 = core::array::from_fn(|d| &u[t + 1 + d][..]);
                inverse_variance_row_u16(u3, wp, &xp, &mut ui[t]).unwrap();
            }
            let (mut fo, mut uo) = ([0.0f32; 128], [0u16; 128]);
            filter_row_f32(
                core::array::from_fn(|t| &f[t][..]),
                core::array::from_fn(|t| &fi[t][..]),
                wp,
                &fp,
                &mut fw,
                &mut fo,
            )
            .unwrap();
            filter_row_u16(
                core::array::from_fn(|t| &u[t][..]),
                core::array::from_fn(|t| &ui[t][..]),
                wp,
                &xp,
                &mut uw,
                &mut uo,
            )
            .unwrap();
            for (a, b) in fo.iter().zip(&uo) {
                let d = (a * 65535.0 - f32::from(*b)).abs();
                assert!(d <= 2.0, "S {scale}: float {} fixed {b}", a * 65535.0);
            }
        }
    }
}
