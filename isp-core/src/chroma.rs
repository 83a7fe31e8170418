//! Chroma noise reduction: an edge-aware mean of each pixel's chroma over its neighbours, in
//! the encoded (sRGB) domain after the colour matrix and tone, keeping its luma.
//!
//! What raw-domain noise reduction ([`crate::denoise`]) leaves, demosaicing spreads over a
//! few pixels and the colour matrix amplifies into colour: blotches of chroma a few pixels
//! across, the mottling the eye sees on flat coloured surfaces. Cameras smooth chroma over a
//! wider window than luma, since the eye resolves colour far more coarsely than brightness;
//! this stage does so, leaving luma (and with it every edge's sharpness) as it was.
//!
//! # Float semantics
//!
//! Each encoded pixel `e` is split into Rec. 709 luma `Y = 0.2126 e_r + 0.7152 e_g + 0.0722
//! e_b` (the sharpening stage's) and chroma `c_i = e_i - Y`. A pass along one axis replaces
//! each pixel `p`'s chroma by the weighted mean over the [`TAPS`] pixels `q` at offsets
//! `-RADIUS..=RADIUS` (reflect-101 at the frame's edges), in that order:
//!
//! ```text
//! w(p, q)  = max(0, 1 - |Y_q - Y_p| / t_y - (|c_q,r - c_p,r| + |c_q,g - c_p,g| + |c_q,b - c_p,b|) / t_c)
//! c'_p,i   = sum_q w(p, q) c_q,i / sum_q w(p, q)
//! ```
//!
//! with `t_y` = [`LUMA_RANGE`] and `t_c` = [`CHROMA_RANGE`] times the strength. The centre
//! has weight 1; a neighbour across an edge (of luma or of colour) has weight 0, so colours
//! do not bleed. The stage is the horizontal pass followed by the vertical pass over its
//! output (separable, as Pham and van Vliet's separable bilateral filter, 2005: 14 taps a
//! pixel instead of 49), and the pixel is `Y + c'`, clamped to `[0, 1]` with the sharpening
//! stage's detail if that is on. Luma is never changed: the weights sum the chroma of pixels
//! whose chroma has zero luma.
//!
//! # Fixed-point path
//!
//! Encoded pixels are 16-bit codes, `Y` rounded from Q16 weights (the sharpening stage's),
//! chroma `i32`. A weight is Q12: `max(0, 4096 - ((|dY| a_y + sum |dc| a_c + 2^15) >> 16))`
//! with `a_y = round(2^28 / (65535 t_y))` (and `a_c` likewise), so a code of difference
//! costs what it does in the float path; each mean is the weighted sum divided by the weights'
//! sum, rounded to the nearest code (halves up), exactly on every target.
//!
//! ```
//! use isp_core::chroma::{self, FloatParams};
//! // A grey row with one pixel's chroma pushed off: the pass pulls it back toward grey.
//! let params = FloatParams::new(1.0).unwrap().unwrap();
//! let mut encoded = [0.5f32; 3 * 9];
//! encoded[3 * 4] = 0.52;
//! let mut split = [0.0f32; 4 * 9];
//! chroma::split_row_f32(&encoded, &mut split).unwrap();
//! let mut out = [0.0f32; 4 * 9];
//! chroma::horizontal_f32(&params, &split, &mut out).unwrap();
//! assert_eq!(out[4 * 4], split[4 * 4]); // luma kept
//! assert!(out[4 * 4 + 1].abs() < 0.5 * split[4 * 4 + 1].abs()); // red chroma smoothed
//! ```

use crate::demosaic::reflect;
use crate::math;
use crate::IspError;

/// Pixels either side of the centre a pass reads.
pub const RADIUS: usize = 3;
/// Pixels a pass reads, and rows of the vertical pass's window.
pub const TAPS: usize = 2 * RADIUS + 1;
/// Elements per pixel of a split row: luma, then red, green and blue chroma.
pub const SPLIT: usize = 4;
/// Largest strength.
pub const MAX_STRENGTH: f32 = 4.0;
/// `t_y` at strength 1, in encoded units (`[0, 1]`): a neighbour this far from the pixel in
/// luma has weight 0. Chosen on the demo's frame against its truth and on clean Kodak and
/// McMaster images, which it leaves within 41-48 dB PSNR of themselves (colour bleeding only
/// across the faintest colour edges).
pub const LUMA_RANGE: f32 = 0.08;
/// `t_c` at strength 1, in encoded units: the summed chroma difference at which a neighbour
/// has weight 0.
pub const CHROMA_RANGE: f32 = 0.15;
/// Rec. 709 luma weights, this stage's and the sharpening stage's.
pub(crate) const LUMA: [f32; 3] = [0.2126, 0.7152, 0.0722];
/// [`LUMA`] in Q16, summing to 65536.
pub(crate) const LUMA_Q16: [u32; 3] = [13933, 46871, 4732];
/// Fractional bits of the fixed path's weights.
const WEIGHT_BITS: u32 = 12;
/// The fixed path's per-code weight costs are capped here, so every product fits `i64`
/// whatever the strength (a cost this high already zeroes a weight at one code).
const MAX_COST: f64 = (1u64 << 40) as f64;

/// The float path's inverse ranges are capped here (a cost this high zeroes a weight at any
/// visible difference).
const MAX_INVERSE: f32 = 1e12;

/// The float path's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloatParams {
    inv_luma: f32,
    inv_chroma: f32,
}

/// The fixed path's parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FixedParams {
    luma_cost: i64,
    chroma_cost: i64,
    /// The planar passes' costs: each per-code cost capped at [`COST_CAP`] and the largest
    /// difference whose product stays at or below it.
    luma_capped: (u32, u32),
    chroma_capped: (u32, u32),
}

fn check_strength(strength: f32) -> Result<bool, IspError> {
    if !(0.0..=MAX_STRENGTH).contains(&strength) {
        return Err(IspError::InvalidParameter {
            name: "chroma denoise strength",
            allowed: "[0, 4] (0 is off, 1 the default)",
        });
    }
    Ok(strength > 0.0)
}

impl FloatParams {
    /// The parameters at `strength` (`[0, 4]`); `None` at 0, which is off.
    pub fn new(strength: f32) -> Result<Option<Self>, IspError> {
        Ok(check_strength(strength)?.then(|| Self {
            // Capped so that a tiny strength gives no infinity (and no `0 * inf`).
            inv_luma: (1.0 / (LUMA_RANGE * strength)).min(MAX_INVERSE),
            inv_chroma: (1.0 / (CHROMA_RANGE * strength)).min(MAX_INVERSE),
        }))
    }
}

impl FixedParams {
    /// The parameters at `strength` (`[0, 4]`); `None` at 0, which is off.
    pub fn new(strength: f32) -> Result<Option<Self>, IspError> {
        let cost = |range: f32| {
            let per_code = f64::from(1u32 << (WEIGHT_BITS + 16)) / (65535.0 * f64::from(range));
            libm::round(per_code.min(MAX_COST)) as i64
        };
        let capped = |per_code: i64| {
            let per_code = per_code.clamp(0, i64::from(COST_CAP)) as u32;
            (per_code, COST_CAP.checked_div(per_code).unwrap_or(u32::MAX))
        };
        Ok(check_strength(strength)?.then(|| {
            let (luma_cost, chroma_cost) =
                (cost(LUMA_RANGE * strength), cost(CHROMA_RANGE * strength));
            Self {
                luma_cost,
                chroma_cost,
                luma_capped: capped(luma_cost),
                chroma_capped: capped(chroma_cost),
            }
        }))
    }
}

/// Splits a row of encoded pixels (`f32` in `[0, 1]`, interleaved RGB) into luma and chroma,
/// [`SPLIT`] elements a pixel.
pub fn split_row_f32(encoded: &[f32], out: &mut [f32]) -> Result<(), IspError> {
    check_split(encoded.len(), out.len())?;
    for (s, e) in out.chunks_exact_mut(SPLIT).zip(encoded.chunks_exact(3)) {
        let y = LUMA[0] * e[0] + LUMA[1] * e[1] + LUMA[2] * e[2];
        s.copy_from_slice(&[y, e[0] - y, e[1] - y, e[2] - y]);
    }
    Ok(())
}

/// Splits a row of encoded pixels (16-bit codes, interleaved RGB) into luma and chroma,
/// [`SPLIT`] elements a pixel.
pub fn split_row_u16(encoded: &[u16], out: &mut [i32]) -> Result<(), IspError> {
    check_split(encoded.len(), out.len())?;
    for (s, e) in out.chunks_exact_mut(SPLIT).zip(encoded.chunks_exact(3)) {
        let e = [e[0], e[1], e[2]].map(u32::from);
        // At most 65535 * 65536 + 2^15: fits u32.
        let y = ((LUMA_Q16[0] * e[0] + LUMA_Q16[1] * e[1] + LUMA_Q16[2] * e[2] + (1 << 15)) >> 16)
            as i32;
        s.copy_from_slice(&[y, e[0] as i32 - y, e[1] as i32 - y, e[2] as i32 - y]);
    }
    Ok(())
}

fn check_split(encoded: usize, split: usize) -> Result<(), IspError> {
    if !encoded.is_multiple_of(3) || split != encoded / 3 * SPLIT {
        return Err(IspError::InvalidParameter {
            name: "chroma rows",
            allowed: "whole RGB pixels in, four elements a pixel out",
        });
    }
    Ok(())
}

/// The horizontal pass over one split row into `out` (as long): luma copied, chroma the
/// weighted mean (see the module docs).
pub fn horizontal_f32(
    params: &FloatParams,
    split: &[f32],
    out: &mut [f32],
) -> Result<(), IspError> {
    horizontal(params, split, out)
}

/// [`horizontal_f32`] for the fixed path.
pub fn horizontal_i32(
    params: &FixedParams,
    split: &[i32],
    out: &mut [i32],
) -> Result<(), IspError> {
    horizontal(params, split, out)
}

/// The vertical pass for the middle row of `rows` (split rows `y - RADIUS..=y + RADIUS`,
/// reflected by the caller) into `out` (split, as long).
pub fn vertical_f32(
    params: &FloatParams,
    rows: [&[f32]; TAPS],
    out: &mut [f32],
) -> Result<(), IspError> {
    vertical(params, rows, out)
}

/// [`vertical_f32`] for the fixed path.
pub fn vertical_i32(
    params: &FixedParams,
    rows: [&[i32]; TAPS],
    out: &mut [i32],
) -> Result<(), IspError> {
    vertical(params, rows, out)
}

fn horizontal<A: Arithmetic>(params: &A, split: &[A::D], out: &mut [A::D]) -> Result<(), IspError> {
    if !split.len().is_multiple_of(SPLIT) || out.len() != split.len() {
        return Err(IspError::InvalidParameter {
            name: "chroma rows",
            allowed: "split rows of equal length, four elements a pixel",
        });
    }
    let w = split.len() / SPLIT;
    let pixel = |x: usize| -> [A::D; SPLIT] {
        let s = &split[SPLIT * x..SPLIT * x + SPLIT];
        [s[0], s[1], s[2], s[3]]
    };
    for (x, o) in out.chunks_exact_mut(SPLIT).enumerate() {
        let mean = if x >= RADIUS && x + RADIUS < w {
            // The window is a slice of the row: no reflection, no copy.
            params.mean(
                pixel(x),
                &split[SPLIT * (x - RADIUS)..SPLIT * (x + RADIUS + 1)],
            )
        } else {
            let mut taps = [split[0]; SPLIT * TAPS];
            for (k, t) in taps.chunks_exact_mut(SPLIT).enumerate() {
                t.copy_from_slice(&pixel(reflect(
                    x as isize + k as isize - RADIUS as isize,
                    w,
                )));
            }
            params.mean(pixel(x), &taps)
        };
        o.copy_from_slice(&mean);
    }
    Ok(())
}

fn vertical<A: Arithmetic>(
    params: &A,
    rows: [&[A::D]; TAPS],
    out: &mut [A::D],
) -> Result<(), IspError> {
    if !out.len().is_multiple_of(SPLIT) || rows.iter().any(|r| r.len() != out.len()) {
        return Err(IspError::InvalidParameter {
            name: "chroma rows",
            allowed: "split rows of equal length, four elements a pixel",
        });
    }
    let Some(&fill) = out.first() else {
        return Ok(());
    };
    for (x, o) in out.chunks_exact_mut(SPLIT).enumerate() {
        let mut taps = [fill; SPLIT * TAPS];
        for (t, row) in taps.chunks_exact_mut(SPLIT).zip(rows) {
            t.copy_from_slice(&row[SPLIT * x..SPLIT * x + SPLIT]);
        }
        let c = SPLIT * RADIUS;
        let centre = [taps[c], taps[c + 1], taps[c + 2], taps[c + 3]];
        o.copy_from_slice(&params.mean(centre, &taps));
    }
    Ok(())
}

/// What the float and fixed paths compute differently; one body runs both.
trait Arithmetic {
    /// Split elements: luma and chroma.
    type D: Copy;
    /// The weighted mean of the chroma of `taps` ([`TAPS`] split pixels in a row, in order),
    /// with `centre`'s luma.
    fn mean(&self, centre: [Self::D; SPLIT], taps: &[Self::D]) -> [Self::D; SPLIT];
}

impl Arithmetic for FloatParams {
    type D = f32;

    #[inline(always)]
    fn mean(&self, p: [f32; SPLIT], taps: &[f32]) -> [f32; SPLIT] {
        let (mut sum, mut den) = ([0.0f32; 3], 0.0f32);
        for q in taps.chunks_exact(SPLIT) {
            let dc = (q[1] - p[1]).abs() + (q[2] - p[2]).abs() + (q[3] - p[3]).abs();
            let w = (1.0 - (q[0] - p[0]).abs() * self.inv_luma - dc * self.inv_chroma).max(0.0);
            for (s, c) in sum.iter_mut().zip(&q[1..]) {
                *s += w * c;
            }
            den += w;
        }
        // The centre's weight is 1, so `den >= 1`.
        let r = 1.0 / den;
        [p[0], sum[0] * r, sum[1] * r, sum[2] * r]
    }
}

/// `num / den` rounded to the nearest integer, halves up, for each of `nums`, for `den` in
/// `1..2^15` and quotients below 2^16 in magnitude (means of chroma codes). Exact on every
/// target, so every target gives the same means: on x86-64 from an `f32` estimate (which
/// vectorises; an integer division does not) corrected by its remainder, elsewhere by 32-bit
/// divisions.
#[inline(always)]
fn rounded_quotients(nums: [i32; 3], den: i32) -> [i32; 3] {
    #[cfg(target_arch = "x86_64")]
    {
        quotients_from_estimate(nums, den)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        quotients_from_division(nums, den)
    }
}

/// [`rounded_quotients`] from `f32` estimates. An estimate `num * (1 / den)` is within
/// `3 * 2^-24` relative of the quotient (three roundings), under 0.02 below 2^16, so its
/// nearest integer is within one of the rounded quotient; the remainder `num - den q` then
/// says which way, in 32 bits (`den |q| < 2^15 2^16`).
#[inline(always)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
fn quotients_from_estimate(nums: [i32; 3], den: i32) -> [i32; 3] {
    let recip = 1.0 / den as f32;
    let quotient = |num: i32| correct_quotient(num, den, math::nearest(num as f32 * recip));
    // Spelled out: `array::map` is not inlined into the ISA entries.
    [quotient(nums[0]), quotient(nums[1]), quotient(nums[2])]
}

/// [`rounded_quotients`] by integer divisions (truncating, then corrected to halves up).
#[inline(always)]
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
fn quotients_from_division(nums: [i32; 3], den: i32) -> [i32; 3] {
    let den = den.max(1);
    let quotient = |num: i32| correct_quotient(num, den, num / den);
    [quotient(nums[0]), quotient(nums[1]), quotient(nums[2])]
}

/// `q`, a quotient of `num / den` within one of the rounded one, corrected to it: the rounded
/// quotient `m` leaves a remainder `num - den m` in `[-den / 2, den / 2)`.
#[inline(always)]
fn correct_quotient(num: i32, den: i32, q: i32) -> i32 {
    let twice_rem = 2 * num.wrapping_sub(den.wrapping_mul(q));
    if twice_rem >= den {
        q + 1
    } else if twice_rem < -den {
        q - 1
    } else {
        q
    }
}

impl Arithmetic for FixedParams {
    type D = i32;

    #[inline(always)]
    fn mean(&self, p: [i32; SPLIT], taps: &[i32]) -> [i32; SPLIT] {
        let (mut sum, mut den) = ([0i64; 3], 0i64);
        let diff = |a: i32, b: i32| i64::from(a.abs_diff(b));
        for q in taps.chunks_exact(SPLIT) {
            // Differences below 2^17, costs at most 2^40: the sum fits i64.
            let cost = diff(q[0], p[0]) * self.luma_cost
                + (diff(q[1], p[1]) + diff(q[2], p[2]) + diff(q[3], p[3])) * self.chroma_cost;
            let w = ((1i64 << WEIGHT_BITS) - ((cost + (1 << 15)) >> 16)).max(0);
            for (s, c) in sum.iter_mut().zip(&q[1..]) {
                *s += w * i64::from(*c);
            }
            den += w;
        }
        // The centre's weight is 2^12, so `den` is in `[2^12, 7 * 2^12]`; chroma is below
        // 2^16 in magnitude, so `|num| < 7 * 2^28` and both fit i32, as the mean does.
        let [r, g, b] = rounded_quotients(sum.map(|num| num as i32), den as i32);
        [p[0], r, g, b]
    }
}

/// The planar schedule's form of the passes: a row as four planes (luma, then red, green and
/// blue chroma), each in column order, so each tap offset is a loop over contiguous slices.
/// The same weights and sums in the same order as [`horizontal_f32`] and [`vertical_f32`]
/// (and their fixed twins), so the same output; the fixed path's costs are capped at
/// 2^28 per term ([`PlanarArithmetic`] for [`FixedParams`]), which changes no weight and keeps
/// every sum in 32 bits.
pub(crate) trait PlanarArithmetic: Copy {
    /// Split elements.
    type D: Copy + Default + 'static;
    /// Weights and weighted sums.
    type W: Copy + Default + core::ops::Add<Output = Self::W>;
    /// The weight of neighbour `q` for pixel `p` (luma, then the three chroma).
    fn weight(&self, p: [Self::D; SPLIT], q: [Self::D; SPLIT]) -> Self::W;
    /// The centre's weight (every pixel's weight with itself).
    const ONE: Self::W;
    /// `w c`.
    fn times(w: Self::W, c: Self::D) -> Self::W;
    /// The three means from their sums and the weights' sum.
    fn means(sums: [Self::W; 3], den: Self::W) -> [Self::D; 3];
}

impl PlanarArithmetic for FloatParams {
    type D = f32;
    type W = f32;
    const ONE: f32 = 1.0;

    #[inline(always)]
    fn weight(&self, p: [f32; SPLIT], q: [f32; SPLIT]) -> f32 {
        let dc = (q[1] - p[1]).abs() + (q[2] - p[2]).abs() + (q[3] - p[3]).abs();
        let w = 1.0 - (q[0] - p[0]).abs() * self.inv_luma - dc * self.inv_chroma;
        // `max(0)` as a select (`f32::max` is a call with a NaN rule): never NaN here.
        if w > 0.0 {
            w
        } else {
            0.0
        }
    }

    #[inline(always)]
    fn times(w: f32, c: f32) -> f32 {
        w * c
    }

    #[inline(always)]
    fn means(sums: [f32; 3], den: f32) -> [f32; 3] {
        let r = 1.0 / den;
        [sums[0] * r, sums[1] * r, sums[2] * r]
    }
}

/// A fixed-path cost term at or above this zeroes the weight by itself (`(2^28 + 2^15) >> 16
/// = 4096`), so capping each term here changes no weight.
const COST_CAP: u32 = 1 << 28;

impl PlanarArithmetic for FixedParams {
    type D = i32;
    type W = i32;
    const ONE: i32 = 1 << WEIGHT_BITS;

    #[inline(always)]
    fn weight(&self, p: [i32; SPLIT], q: [i32; SPLIT]) -> i32 {
        let d = |k: usize| q[k].abs_diff(p[k]);
        let (d0, d1, d2, d3) = (d(0), d(1), d(2), d(3));
        let ((luma_per_code, luma_limit), (chroma_per_code, chroma_limit)) =
            (self.luma_capped, self.chroma_capped);
        // A term over its limit would be capped at COST_CAP, which zeroes the weight by
        // itself; under the limits each term is at most 2^28, so the sum of four fits u32,
        // and the three chroma terms share one multiply (the same sum as term by term).
        let over = d0 > luma_limit || d1 > chroma_limit || d2 > chroma_limit || d3 > chroma_limit;
        let cost = if over {
            COST_CAP
        } else {
            d0 * luma_per_code + (d1 + d2 + d3) * chroma_per_code
        };
        let w = (1i32 << WEIGHT_BITS) - ((cost.min(COST_CAP) + (1 << 15)) >> 16) as i32;
        if w > 0 {
            w
        } else {
            0
        }
    }

    #[inline(always)]
    fn times(w: i32, c: i32) -> i32 {
        // w <= 2^12, |c| < 2^17: seven taps fit i32.
        w * c
    }

    #[inline(always)]
    fn means(sums: [i32; 3], den: i32) -> [i32; 3] {
        rounded_quotients(sums, den)
    }
}

/// The weight of one offset along a run of pixels: `out[i]` is the weight between pixel `i`
/// of `a` and pixel `i` of `b` (four planes each: luma, then the three chroma). A weight is
/// symmetric, so one row serves both taps of the offset: the pixel of `a` for its neighbour
/// in `b` and the pixel of `b` for its neighbour in `a` (Condat's observation for non-local
/// means, 2010), and a pass computes [`RADIUS`] weights a pixel, not [`TAPS`].
#[inline(always)]
pub(crate) fn weight_row<A: PlanarArithmetic>(
    params: &A,
    a: [&[A::D]; SPLIT],
    b: [&[A::D]; SPLIT],
    out: &mut [A::W],
) {
    let n = out.len();
    let [ay, ar, ag, ab] = a.map(|plane| &plane[..n]);
    let [by, br, bg, bb] = b.map(|plane| &plane[..n]);
    for i in 0..n {
        out[i] = params.weight([ay[i], ar[i], ag[i], ab[i]], [by[i], br[i], bg[i], bb[i]]);
    }
}

/// One pass's means over a run of `n` pixels, from the taps and their weights: `taps[k]` are
/// the four planes of tap `k` (offset `k - RADIUS`), each aligned with the output (element
/// `i` of tap `k` is pixel `i`'s neighbour); `weights` the weights of every tap but the
/// centre (whose weight is one), in tap order, aligned likewise. `out` gets luma copied from
/// the centre tap and the means of chroma. Each pixel's sums are formed in tap order, as
/// [`horizontal_f32`] forms them (so the same floats), in registers.
#[inline(always)]
pub(crate) fn weighted_means<A: PlanarArithmetic>(
    taps: [[&[A::D]; SPLIT]; TAPS],
    weights: [&[A::W]; TAPS - 1],
    out: [&mut [A::D]; SPLIT],
) {
    let [y_out, r_out, g_out, b_out] = out;
    let n = y_out.len();
    let (r_out, g_out, b_out) = (&mut r_out[..n], &mut g_out[..n], &mut b_out[..n]);
    let taps = taps.map(|tap| tap.map(|plane| &plane[..n]));
    let weights = weights.map(|w| &w[..n]);
    for i in 0..n {
        let (mut sr, mut sg, mut sb, mut den) = Default::default();
        for (k, [_, qr, qg, qb]) in taps.iter().enumerate() {
            let w = match k {
                RADIUS => A::ONE,
                k if k < RADIUS => weights[k][i],
                k => weights[k - 1][i],
            };
            sr = sr + A::times(w, qr[i]);
            sg = sg + A::times(w, qg[i]);
            sb = sb + A::times(w, qb[i]);
            den = den + w;
        }
        let [r, g, b] = A::means([sr, sg, sb], den);
        y_out[i] = taps[RADIUS][0][i];
        r_out[i] = r;
        g_out[i] = g;
        b_out[i] = b;
    }
}

/// The horizontal pass over a row of `n` pixels in planes: `row` the four planes with
/// [`RADIUS`] reflected pixels either side (`n + 2 RADIUS` each, pixel `i` at `RADIUS + i`),
/// `weights` room for [`row_weights_len`]`(n)` weights.
#[inline(always)]
pub(crate) fn pass_row<A: PlanarArithmetic>(
    params: &A,
    row: [&[A::D]; SPLIT],
    out: [&mut [A::D]; SPLIT],
    weights: &mut [A::W],
) {
    let n = out[0].len();
    let stride = n + RADIUS;
    // Row k - 1 holds, at t in 0..n + k, the weight between padded pixels RADIUS - k + t
    // and RADIUS + t: pixel i's tap -k at t = i, its tap +k at t = i + k.
    for k in 1..=RADIUS {
        let (lo, hi) = (RADIUS - k, RADIUS);
        weight_row(
            params,
            row.map(|plane| &plane[lo..lo + n + k]),
            row.map(|plane| &plane[hi..hi + n + k]),
            &mut weights[(k - 1) * stride..(k - 1) * stride + n + k],
        );
    }
    let weights: &[A::W] = weights;
    let of = |k: usize, t: usize| &weights[(k - 1) * stride + t..(k - 1) * stride + t + n];
    let taps: [[&[A::D]; SPLIT]; TAPS] =
        core::array::from_fn(|k| row.map(|plane| &plane[k..k + n]));
    weighted_means::<A>(
        taps,
        core::array::from_fn(|j| match j {
            j if j < RADIUS => of(RADIUS - j, 0),
            j => of(j + 1 - RADIUS, j + 1 - RADIUS),
        }),
        out,
    );
}

/// Rows of weights [`ColumnPass`] keeps: `k + 1` for offset `k`.
pub(crate) const COLUMN_WEIGHT_ROWS: usize = RADIUS * (RADIUS + 3) / 2;

/// The vertical pass down a frame, output row by output row, keeping each offset's weight
/// row for the row below that needs it: the weight between rows `y` and `y + k`, computed
/// for output row `y`'s tap `+k`, is output row `y + k`'s tap `-k`. Each slot is tagged with
/// the pair it holds, so rows out of order (a band's first rows, a frame's reflected edges)
/// compute what they lack and never read a stale row.
pub(crate) struct ColumnPass<'s, W> {
    /// [`COLUMN_WEIGHT_ROWS`] rows of `width`: offset `k`'s `k + 1` slots after offset
    /// `k - 1`'s.
    rows: &'s mut [W],
    width: usize,
    /// For offset `k` and slot `s`, the output row `u` whose pair (`u`, `u + k`) the slot
    /// holds, or `usize::MAX`.
    tags: [[usize; RADIUS + 1]; RADIUS],
}

impl<'s, W: Copy> ColumnPass<'s, W> {
    /// A pass over rows `width` pixels wide, its weight rows in `rows` (at least
    /// [`COLUMN_WEIGHT_ROWS`]` * width`).
    pub(crate) fn new(rows: &'s mut [W], width: usize) -> Self {
        Self {
            rows,
            width,
            tags: [[usize::MAX; RADIUS + 1]; RADIUS],
        }
    }

    /// The vertical pass for output row `y`: `taps[k]` the four planes of frame row `y + k -
    /// RADIUS` (reflected), `out` the row's four planes.
    #[inline(always)]
    pub(crate) fn pass<A: PlanarArithmetic<W = W>>(
        &mut self,
        params: &A,
        taps: [[&[A::D]; SPLIT]; TAPS],
        y: usize,
        out: [&mut [A::D]; SPLIT],
    ) {
        let w = self.width;
        // Where offset k's slot `slot` starts: offset k - 1's k slots come before it.
        let at = |k: usize, slot: usize| ((k - 1) * (k + 2) / 2 + slot) * w;
        for k in 1..=RADIUS {
            let slots = k + 1;
            // Below: the pair (y, y + k), for this row and for row y + k.
            let below = at(k, y % slots);
            weight_row(
                params,
                taps[RADIUS],
                taps[RADIUS + k],
                &mut self.rows[below..below + w],
            );
            self.tags[k - 1][y % slots] = y;
            // Above: the pair (y - k, y), computed for row y - k if that row ran, in the slot
            // y - k takes (y + 1 is y - k modulo k + 1).
            let above_slot = (y + 1) % slots;
            let wanted = y.checked_sub(k).unwrap_or(usize::MAX);
            if wanted == usize::MAX || self.tags[k - 1][above_slot] != wanted {
                let above = at(k, above_slot);
                weight_row(
                    params,
                    taps[RADIUS],
                    taps[RADIUS - k],
                    &mut self.rows[above..above + w],
                );
                self.tags[k - 1][above_slot] = wanted;
            }
        }
        let rows: &[W] = self.rows;
        let slot_row = |k: usize, slot: usize| &rows[at(k, slot)..at(k, slot) + w];
        weighted_means::<A>(
            taps,
            core::array::from_fn(|j| match j {
                j if j < RADIUS => slot_row(RADIUS - j, (y + 1) % (RADIUS - j + 1)),
                j => slot_row(j + 1 - RADIUS, y % (j + 2 - RADIUS)),
            }),
            out,
        );
    }
}

/// Weights [`pass_row`] needs for a row of `n` pixels.
pub(crate) const fn row_weights_len(n: usize) -> usize {
    RADIUS * (n + RADIUS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strength_is_checked() {
        assert!(FloatParams::new(-0.1).is_err());
        assert!(FixedParams::new(4.5).is_err());
        assert!(FloatParams::new(f32::NAN).is_err());
        assert_eq!(FloatParams::new(0.0), Ok(None));
        assert_eq!(FixedParams::new(0.0), Ok(None));
        // The smallest strengths keep the fixed path's sums in range.
        let tiny = FixedParams::new(f32::MIN_POSITIVE).unwrap().unwrap();
        assert!(tiny.luma_cost as f64 <= MAX_COST && tiny.chroma_cost as f64 <= MAX_COST);
        // And the float path's weights finite: the centre keeps weight 1.
        let tiny = FloatParams::new(f32::MIN_POSITIVE).unwrap().unwrap();
        let split = [0.5f32, 0.1, -0.05, 0.02, 0.5, 0.1, -0.05, 0.03];
        let mut out = [0.0f32; 8];
        horizontal_f32(&tiny, &split, &mut out).unwrap();
        // (Reflected copies of a pixel are its own taps, so the mean is of equal values.)
        for (a, b) in out.iter().zip(&split) {
            assert!((a - b).abs() < 1e-6, "{a} {b}");
        }
    }

    /// Both forms of the rounded quotient are the exact one (halves up) over the means'
    /// whole domain's edges and a sweep of it, so every target gives the same means.
    #[test]
    fn rounded_quotients_are_exact_on_every_form() {
        let exact = |num: i32, den: i32| {
            // floor((2 num + den) / (2 den)), in i64.
            (2 * i64::from(num) + i64::from(den)).div_euclid(2 * i64::from(den)) as i32
        };
        let mut rng = crate::math::xorshift(99);
        let check = |num: i32, den: i32| {
            let want = [exact(num, den); 3];
            let nums = [num; 3];
            assert_eq!(quotients_from_estimate(nums, den), want, "{num} / {den}");
            assert_eq!(quotients_from_division(nums, den), want, "{num} / {den}");
        };
        for den in [4096, 4097, 8191, 12288, 28671, 28672] {
            // Ties, their neighbours and the ends of the range.
            for m in [-65535i32, -65534, -1, 0, 1, 2, 65534, 65535] {
                for d in [-1, 0, 1] {
                    check(m * den + den / 2 + d, den);
                    check(m * den - den / 2 + d, den);
                }
            }
        }
        for _ in 0..1_000_000 {
            let den = 4096 + (rng() % (6 * 4096 + 1)) as i32;
            let num = (rng() % (2 * 65535 * den as u64 + 1)) as i64 - 65535 * i64::from(den);
            check(num as i32, den);
        }
    }

    #[test]
    fn mismatched_rows_are_refused() {
        let p = FloatParams::new(1.0).unwrap().unwrap();
        let mut out = [0.0f32; 8];
        assert!(split_row_f32(&[0.0; 5], &mut out).is_err());
        assert!(horizontal_f32(&p, &[0.0; 4], &mut out).is_err());
        let rows = [&[0.0f32; 8][..]; TAPS];
        assert!(vertical_f32(&p, rows, &mut [0.0; 4]).is_err());
    }

    /// A flat colour is unchanged; a colour edge does not bleed; luma is kept exactly.
    #[test]
    fn flat_colours_stay_and_edges_do_not_bleed() {
        let p = FloatParams::new(1.0).unwrap().unwrap();
        let q = FixedParams::new(1.0).unwrap().unwrap();
        // Orange then blue, 8 pixels each.
        let mut encoded = [0.0f32; 3 * 16];
        for (x, px) in encoded.chunks_exact_mut(3).enumerate() {
            px.copy_from_slice(if x < 8 {
                &[0.85, 0.5, 0.15]
            } else {
                &[0.3, 0.35, 0.7]
            });
        }
        let mut split = [0.0f32; 4 * 16];
        split_row_f32(&encoded, &mut split).unwrap();
        let mut out = [0.0f32; 4 * 16];
        horizontal_f32(&p, &split, &mut out).unwrap();
        for (a, b) in out.iter().zip(&split) {
            assert!((a - b).abs() < 1e-6, "{a} {b}");
        }
        let codes: [u16; 48] = core::array::from_fn(|i| (encoded[i] * 65535.0).round() as u16);
        let mut split = [0i32; 4 * 16];
        split_row_u16(&codes, &mut split).unwrap();
        let mut out = [0i32; 4 * 16];
        horizontal_i32(&q, &split, &mut out).unwrap();
        assert_eq!(out, split);
    }

    /// Noise on a flat colour: both paths reduce the chroma's spread, keep luma, and agree
    /// to a code of 16 bits.
    #[test]
    fn noisy_chroma_is_smoothed_alike_on_both_paths() {
        let p = FloatParams::new(1.0).unwrap().unwrap();
        let q = FixedParams::new(1.0).unwrap().unwrap();
        let mut seed = 12345u32;
        let mut noise = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 * 0.04 - 0.02
        };
        const W: usize = 64;
        let mut encoded = [0.0f32; 3 * W];
        for (i, v) in encoded.iter_mut().enumerate() {
            *v = [0.6, 0.45, 0.3][i % 3] + noise();
        }
        let codes: [u16; 3 * W] = core::array::from_fn(|i| (encoded[i] * 65535.0).round() as u16);
        let encoded: [f32; 3 * W] = core::array::from_fn(|i| f32::from(codes[i]) / 65535.0);
        let (mut fs, mut fo) = ([0.0f32; 4 * W], [0.0f32; 4 * W]);
        split_row_f32(&encoded, &mut fs).unwrap();
        horizontal_f32(&p, &fs, &mut fo).unwrap();
        let (mut is, mut io) = ([0i32; 4 * W], [0i32; 4 * W]);
        split_row_u16(&codes, &mut is).unwrap();
        horizontal_i32(&q, &is, &mut io).unwrap();
        let spread = |s: &[f32], c: usize| {
            let mean: f32 = s.chunks_exact(4).map(|p| p[c]).sum::<f32>() / W as f32;
            let v: f32 = s
                .chunks_exact(4)
                .map(|p| (p[c] - mean) * (p[c] - mean))
                .sum();
            v / W as f32
        };
        for c in 1..4 {
            assert!(spread(&fo, c) < 0.5 * spread(&fs, c), "channel {c}");
        }
        for (x, (f, i)) in fo.chunks_exact(4).zip(io.chunks_exact(4)).enumerate() {
            assert_eq!(f[0], fs[4 * x]);
            assert_eq!(i[0], is[4 * x]);
            for c in 0..4 {
                let diff = (f[c] * 65535.0 - i[c] as f32).abs();
                assert!(
                    diff <= 1.5,
                    "pixel {x} element {c}: {} vs {}",
                    f[c] * 65535.0,
                    i[c]
                );
            }
        }
        // The vertical pass over seven copies of the row is the identity on chroma's mean of
        // equal values.
        let mut v = [0.0f32; 4 * W];
        vertical_f32(&p, [&fo[..]; TAPS], &mut v).unwrap();
        for (a, b) in v.iter().zip(&fo) {
            assert!((a - b).abs() < 1e-6);
        }
    }
}
