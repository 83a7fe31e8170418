//! The directional method in integer arithmetic, for cores without a floating-point unit.
//!
//! The same stages, schedule and buffers as the `f32` method, on `i32` samples scaled to 16
//! bits (8-bit input is multiplied by 257). Sums of samples are exact; ratios (the classifiers,
//! the blend weights) are Q16 fractions; weighted means round half up. Every value stored or
//! carried between steps fits 32 bits: the classifiers' statistics are formed from their
//! inputs rounded to the top 13 or 14 bits of the largest (exact on small differences), and the
//! numerators of the weighted means, which reach 2^46, are [`Wide`] values that exist only to
//! be divided (`i64` on cores without an FPU; on x86-64 and AArch64 a 32-bit low word with an
//! `f32` estimate, the same quotients in 32-bit lanes). The float method's small constants are
//! carried over at their size on this scale, not replaced by a 1 that would be large next to
//! them: its gradient floor (1e-5 of full scale, 0.66 LSB) by scaling those gradients by 100
//! and adding 66, its classifier floor (1e-10) by an offset of 2 units of the integer statistic
//! (1.72 exactly), and its 1e-20 against division by zero (negligible on this scale) by
//! handling zero exactly. Each value's bound is stated where it is formed.

#[cfg(target_arch = "x86_64")]
use super::LANES_AVX512;
use super::{
    at, for_each_block, lane, store, Arithmetic, Blocks, Frame, Planes, Span, LANES, SMOOTH_PERCENT,
};
use crate::frame::{IntSample, MosaicView, RgbViewMut};
use crate::math::nearest;
use crate::IspError;

/// Fraction bits of the ratios.
const Q: u32 = 16;
/// One in Q16.
const ONE: i32 = 1 << Q;
/// The float method's gradient floor, 1e-5 of full scale, in hundredths of a 16-bit LSB: the
/// gradients that carry it are kept in hundredths.
const EPS_HUNDREDTHS: i32 = 66;
/// The float method's `SUM_FLOOR` (one 16-bit step) on the gradient sums' scale (4 x).
const SUM_FLOOR: i32 = 4;
/// Full scale of the working samples.
const FULL: i32 = 65535;

/// Demosaics `input` into `output` (same size) with the directional method in integer
/// arithmetic, using `scratch` (at least [`scratch_len`](super::scratch_len)`(width)` samples).
/// Its CPSNR on the standard sets equals [`directional`](super::directional)'s to two
/// decimals (Kodak 39.73, McMaster 36.11 dB at 16 bits). Over every Kodak and McMaster image
/// as a 16-bit mosaic, 99.87 % of the samples are within 1 LSB of it and none further than 26
/// (a tenth of an 8-bit step): the method has no hard switch (its classifier refinement fades
/// between its two choices, its weights have a floor), so a difference in the last bit cannot
/// tip an estimate to the other direction's.
///
/// ```
/// use isp_core::demosaic::directional::{directional_fixed, scratch_len};
/// use isp_core::frame::{MosaicView, RgbViewMut};
/// use isp_core::CfaPattern;
/// let flat = [200u8; 64];
/// let mosaic = MosaicView::new(&flat, 8, 8, 8, CfaPattern::Bggr).unwrap();
/// let mut rgb = [0u8; 192];
/// let mut out = RgbViewMut::new(&mut rgb, 8, 8, 24).unwrap();
/// let mut scratch = vec![0i32; scratch_len(8).unwrap()];
/// directional_fixed(&mosaic, &mut out, &mut scratch).unwrap();
/// assert!(rgb.iter().all(|v| *v == 200)); // a flat field stays flat
/// ```
pub fn directional_fixed<T: IntSample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
    scratch: &mut [i32],
) -> Result<(), IspError> {
    super::whole_frame::<Fixed<T>, LANES>(input, output, scratch)
}

/// [`directional_fixed`] compiled for x86-64 CPUs with AVX2: the same output, its loops
/// eight 32-bit lanes wide (the baseline build, four lanes of SSE2, ran the Kodak set at 19
/// Mpix/s on a Zen 3 EPYC without AVX-512).
///
/// # Safety
///
/// The CPU must support AVX2; check first with `is_x86_feature_detected!("avx2")`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub fn directional_fixed_avx2<T: IntSample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
    scratch: &mut [i32],
) -> Result<(), IspError> {
    super::whole_frame::<Fixed<T>, LANES>(input, output, scratch)
}

/// [`directional_fixed`] compiled for x86-64 CPUs with AVX-512 (F, BW, VL and DQ): the same
/// output, its loops sixteen 32-bit lanes wide (on a Zen 4 EPYC the AVX2 build ran the
/// pipeline's directional frame 20 % slower).
///
/// # Safety
///
/// The CPU must support those features; check first with `is_x86_feature_detected!` for each
/// of "avx512f", "avx512bw", "avx512vl" and "avx512dq".
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq")]
pub fn directional_fixed_avx512<T: IntSample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
    scratch: &mut [i32],
) -> Result<(), IspError> {
    super::whole_frame::<Fixed<T>, LANES_AVX512>(input, output, scratch)
}

/// The integer method on samples of type `T`, its wide intermediates held as `W` (the
/// target's [`Native`] unless a test asks for the other).
pub(crate) struct Fixed<T, W = Native>(core::marker::PhantomData<(T, W)>);

impl<T: IntSample, W: Wide> Arithmetic for Fixed<T, W> {
    type T = T;
    type E = i32;
    #[inline(always)]
    fn enter(v: T) -> i32 {
        to_working(v)
    }
    #[inline(always)]
    fn leave(v: i32) -> T {
        from_working(v)
    }
    #[inline(always)]
    fn diff(frame: &Frame, r: usize, p: &mut Planes<'_, i32>) {
        frame.diff_row_fixed(r, p);
    }
    #[inline(always)]
    fn class<const L: usize>(frame: &Frame, r: usize, p: &mut Planes<'_, i32>) {
        frame.class_row_fixed::<W, L>(r, p);
    }
    #[inline(always)]
    fn green(frame: &Frame, r: usize, p: &mut Planes<'_, i32>) {
        frame.green_row_fixed::<W>(r, p);
    }
    #[inline(always)]
    fn chroma<const L: usize>(frame: &Frame, r: usize, p: &mut Planes<'_, i32>) {
        frame.chroma_row_fixed::<W, L>(r, p);
    }
    #[inline(always)]
    fn output<const L: usize>(frame: &Frame, r: usize, p: &mut Planes<'_, i32>, out: &mut [T]) {
        frame.fill_known(r, p);
        frame.output_estimates_fixed::<W, L>(r, p);
        let [red, green, blue] = &p.out_rgb;
        frame.write_row([&**red, &**green, &**blue], out, from_working::<T>);
    }
    #[inline(always)]
    fn estimate_output<const L: usize>(frame: &Frame, r: usize, p: &mut Planes<'_, i32>) {
        frame.output_estimates_fixed::<W, L>(r, p);
    }
}

/// A sample on the 16-bit working scale.
fn to_working<T: IntSample>(v: T) -> i32 {
    // 65535 / MAX is exact for u8 (257) and u16 (1).
    (v.to_u32() * (FULL as u32 / T::MAX)) as i32
}

/// A working value back on the sample's scale, rounded half up.
fn from_working<T: IntSample>(v: i32) -> T {
    let step = FULL as u32 / T::MAX;
    T::from_u32((v.clamp(0, FULL) as u32 + step / 2) / step)
}

/// An integer of up to 62 bits formed from `i32` products and sums, to be divided by an `i32`
/// into an `i32` quotient: the method's weighted means. Every value the stages store fits
/// `i32`; only these numerators do not.
///
/// [`Exact`] holds it as an `i64`. [`Estimated`] holds its low 32 bits (wrapping) beside an
/// `f32` estimate, and divides by rounding the estimated quotient and lowering it by one where
/// the exact remainder is negative (that remainder fits the low word for a divisor below
/// 2^31): the
/// same quotients in 32-bit lanes, sixteen to an AVX-512 vector instead of eight `i64`s (whose
/// multiplies and conversions took most of the method's time). `Native` is `Estimated` where
/// the core has a floating-point unit (x86-64, AArch64), else `Exact`.
pub(crate) trait Wide: Copy {
    /// `v`.
    fn of(v: i32) -> Self;
    /// `a * b`, exactly.
    fn product(a: i32, b: i32) -> Self;
    /// `self + other`.
    fn plus(self, other: Self) -> Self;
    /// `floor(self / d)` for `1 <= d < 2^31` and a quotient below 2^21 in magnitude, when the
    /// estimate (if any) is within `d / 4` of the value: every call states its bounds.
    fn floor_div(self, d: i32) -> i32;
    /// `self / d` rounded half up, `floor((2 self + d) / (2 d))`, under the bounds of
    /// [`Wide::floor_div`] with `d < 2^30`.
    fn round_div(self, d: i32) -> i32;
}

/// A [`Wide`] as an `i64`.
#[derive(Clone, Copy)]
// Where `f32` is in hardware only the tests use it, to check `Estimated` against it.
#[cfg_attr(
    any(target_arch = "x86_64", target_arch = "aarch64", target_abi = "eabihf"),
    allow(dead_code)
)]
pub(crate) struct Exact(i64);

impl Wide for Exact {
    #[inline(always)]
    fn of(v: i32) -> Self {
        Exact(i64::from(v))
    }
    #[inline(always)]
    fn product(a: i32, b: i32) -> Self {
        Exact(i64::from(a) * i64::from(b))
    }
    #[inline(always)]
    fn plus(self, other: Self) -> Self {
        Exact(self.0.wrapping_add(other.0))
    }
    #[inline(always)]
    fn floor_div(self, d: i32) -> i32 {
        self.0.div_euclid(i64::from(d.max(1))) as i32
    }
    #[inline(always)]
    fn round_div(self, d: i32) -> i32 {
        let d = i64::from(d.max(1));
        (2 * self.0 + d).div_euclid(2 * d) as i32
    }
}

/// A [`Wide`] as its low 32 bits and an `f32` estimate. [`Native`] on the targets whose `f32`
/// is in hardware (x86-64, AArch64, and ARM's hard-float ABI: the Cortex-M4F/M7F/M33 FPU,
/// where the `i64` division `Exact` calls in software was 28 % of the directional method's
/// instructions); elsewhere it is kept, and tested on the host, but unused.
#[derive(Clone, Copy)]
#[cfg_attr(
    not(any(target_arch = "x86_64", target_arch = "aarch64", target_abi = "eabihf")),
    allow(dead_code)
)]
pub(crate) struct Estimated {
    low: i32,
    estimate: f32,
}

impl Wide for Estimated {
    #[inline(always)]
    fn of(v: i32) -> Self {
        Estimated {
            low: v,
            estimate: v as f32,
        }
    }
    #[inline(always)]
    fn product(a: i32, b: i32) -> Self {
        Estimated {
            low: a.wrapping_mul(b),
            estimate: a as f32 * b as f32,
        }
    }
    #[inline(always)]
    fn plus(self, other: Self) -> Self {
        Estimated {
            low: self.low.wrapping_add(other.low),
            estimate: self.estimate + other.estimate,
        }
    }
    /// The estimated quotient rounded to the nearest integer is within 3/4 of the exact one
    /// (the estimate is within `d / 4`, and `f32` division adds a relative 2^-24), so the
    /// remainder `n - q d` lies within `3 d / 4` of 0: exact in the low word for `d < 2^31`,
    /// and its sign says whether `q` is the floor or one above it.
    #[inline(always)]
    fn floor_div(self, d: i32) -> i32 {
        floor_from(nearest(self.estimate / d as f32), self.low, d)
    }
    /// As [`Estimated::floor_div`] on `2 n + d` over `2 d`, whose quotient is `n / d + 1/2`:
    /// the estimate is divided and the half added after, not doubled and offset first.
    #[inline(always)]
    fn round_div(self, d: i32) -> i32 {
        // The half is added apart: 1.5 x 2^23 + 0.5 is not an `f32`.
        let q = nearest(self.estimate / d as f32 + 0.5);
        floor_from(q, self.low.wrapping_mul(2).wrapping_add(d), 2 * d)
    }
}

/// `floor(n / d)` from `q`, the nearest integer to an estimate of it within 3/4: `q`, or one
/// less where the remainder `n - q d` is negative. `n` is the numerator's low word; the
/// remainder, within `3 d / 4` of 0, is exact in it.
#[inline(always)]
#[cfg_attr(
    not(any(target_arch = "x86_64", target_arch = "aarch64", target_abi = "eabihf")),
    allow(dead_code)
)]
fn floor_from(q: i32, n: i32, d: i32) -> i32 {
    let r = n.wrapping_sub(q.wrapping_mul(d));
    if r < 0 {
        q.wrapping_sub(1)
    } else {
        q
    }
}

/// The target's [`Wide`]: [`Estimated`] where `f32` is in hardware.
#[cfg(any(target_arch = "x86_64", target_arch = "aarch64", target_abi = "eabihf"))]
pub(crate) type Native = Estimated;
/// The target's [`Wide`]: [`Exact`] where `f32` would be emulated.
#[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64", target_abi = "eabihf")))]
pub(crate) type Native = Exact;

/// `(wa a + wb b) / (wa + wb)` rounded half up, as `a + wb (b - a) / (wa + wb)`: the same
/// value from one product. Weights `>= 0` with a sum in `[1, 2^30)`, `wb |b - a| < 2^46`.
#[inline(always)]
fn mean2<W: Wide>(wa: i32, a: i32, wb: i32, b: i32) -> i32 {
    a + W::product(wb, b - a).round_div(wa + wb)
}

/// `floor((c x + 2^15) / 2^16)`: `x` scaled by a Q16 fraction `0 <= c <= 2^16` and rounded,
/// for `|x| < 2^20`, in 32 bits: with `x = hi 2^16 + lo` it is `c hi` plus the rounded top of
/// `c lo`, which is below 2^32 (as the pipeline's `MulQ16` splits its constants).
#[inline(always)]
fn mul_q16(c: i32, x: i32) -> i32 {
    let (hi, lo) = (x >> Q, (x & 0xffff) as u32);
    c * hi + ((c as u32 * lo + 0x8000) >> Q) as i32
}

/// `v` clamped to the working range.
#[inline(always)]
fn clamp_full(v: i32) -> i32 {
    let v = if v > 0 { v } else { 0 };
    if v < FULL {
        v
    } else {
        FULL
    }
}

/// How far `m` (`0..=2^24`) reaches past `bits` bits: `max(0, bit_length(m) - bits)`, the
/// right shift that brings it within them.
#[inline(always)]
fn excess_bits(m: i32, bits: i32) -> i32 {
    #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
    // `m` is exact in `f32`, whose exponent field is its bit length plus 126 (0 for m = 0):
    // a conversion and a shift per lane, where a vector bit length takes a table per byte
    // before AVX-512 CD.
    let length = ((m as f32).to_bits() >> 23) as i32 - 126;
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    let length = 32 - (m as u32).leading_zeros() as i32;
    let excess = length - bits;
    if excess > 0 {
        excess
    } else {
        0
    }
}

/// `v >> k` rounded half up, for `v >= 0` and `0 <= k < 31`.
#[inline(always)]
fn shift_round(v: i32, k: i32) -> i32 {
    (v + ((1 << k) >> 1)) >> k
}

// The small helpers below are functions marked to inline, not closures or `Ord::min`: in the
// pipeline's large AVX-512 entry LLVM left such calls out of line, one call per pixel, and
// a loop with a call does not vectorise.

/// The least of four values.
#[inline(always)]
fn least4(a: i32, b: i32, c: i32, d: i32) -> i32 {
    let ab = if a < b { a } else { b };
    let cd = if c < d { c } else { d };
    if ab < cd {
        ab
    } else {
        cd
    }
}

/// The larger of two values.
#[inline(always)]
fn larger(a: i32, b: i32) -> i32 {
    if a > b {
        a
    } else {
        b
    }
}

/// A gradient (a sum of sample differences, < 2^18) in hundredths of an LSB, with the float
/// method's floor: < 2^25.
#[inline(always)]
fn hundredths(s: i32) -> i32 {
    100 * s + EPS_HUNDREDTHS
}

/// The inverse-square weight of a side whose gradient sum is `s`, relative to the least sum
/// `least` (both < 2^23), in Q16: `((least + floor) / (s + floor))^2`.
#[inline(always)]
fn relative_weight<W: Wide>(least: i32, s: i32) -> i32 {
    // Numerator < 2^39, divisor < 2^24, quotient <= 2^16; the estimate is the product of
    // two values exact in `f32`.
    let q = W::product(least + SUM_FLOOR, ONE).floor_div(s + SUM_FLOOR);
    // q^2 / 2^16 in `u32`, where q = 2^16 (the least side itself) would wrap.
    if q < ONE {
        ((q as u32 * q as u32) >> Q) as i32
    } else {
        ONE
    }
}

/// `a / (a + b)` in Q16, rounded, for `a, b >= 0` and `a + b < 2^31`; one half when both
/// are 0.
#[inline(always)]
fn ratio<W: Wide>(a: i32, b: i32) -> i32 {
    let sum = a + b;
    // Numerator < 2^47 from an exact product and a sum, its estimate within 2^-8 of the
    // divisor; quotient <= 2^16. Both arms computed, so the loops calling this vectorise (a
    // select, not a branch).
    let q = W::product(a, ONE)
        .plus(W::of(sum >> 1))
        .floor_div(larger(sum, 1));
    if sum == 0 {
        ONE / 2
    } else {
        q
    }
}

/// The float method's horizontal/vertical (or diagonal) classifier `v / (v + h)` from two
/// lines of seven samples, in Q16. The statistics (sums of squared first differences and a
/// quarter of the squared second differences over the three centre positions, here times 4)
/// are formed from the differences rounded to their largest's top 13 bits (exact wherever the
/// largest is below 2^13, an eighth of full scale), so each is below 15 x 2^26 and their sum
/// fits `i32` and the division; the float method's floor of 1e-10 (in squared full scale) is
/// 1.72 units of the exact statistics, 2 here, and nothing once they are scaled.
#[inline(always)]
fn line_class<W: Wide>(v: [i32; 7], h: [i32; 7]) -> i32 {
    let mut first = [0i32; 6];
    let mut second = [0i32; 6];
    for k in 0..3 {
        first[k] = (v[k + 1] - v[k + 3]).abs();
        second[k] = (2 * v[k + 2] - v[k] - v[k + 4]).abs();
        first[3 + k] = (h[k + 1] - h[k + 3]).abs();
        second[3 + k] = (2 * h[k + 2] - h[k] - h[k + 4]).abs();
    }
    let mut largest = 0;
    for k in 0..6 {
        largest = larger(largest, larger(first[k], second[k]));
    }
    // Differences < 2^18 before, <= 2^13 after: each statistic <= 3 * 5 * 2^26.
    let shift = excess_bits(largest, 13);
    let mut stat = [0i32; 2];
    for k in 0..6 {
        let f = shift_round(first[k], shift);
        let s = shift_round(second[k], shift);
        stat[k / 3] += 4 * f * f + s * s;
    }
    let floor = if shift == 0 { 2 } else { 0 };
    ratio::<W>(stat[0] + floor, stat[1] + floor)
}

/// The float method's `pair_estimate`: `x` the chroma at offsets -3, -1, 1, 3, `g` the green
/// at -2..=2. The weights (hundredths of an LSB) are < 2^25 and the differences < 2^17, so the
/// product in the mean < 2^42 and the divisor < 2^26.
#[inline(always)]
fn pair_estimate<W: Wide>(x: [i32; 4], g: [i32; 5]) -> i32 {
    let before = hundredths((x[1] - x[2]).abs() + (x[1] - x[0]).abs() + (g[2] - g[0]).abs());
    let after = hundredths((x[2] - x[1]).abs() + (x[2] - x[3]).abs() + (g[2] - g[4]).abs());
    mean2::<W>(after, x[1] - g[1], before, x[2] - g[3])
}

/// `base + (1 - c) a + c b` for a Q16 classifier `c`, clamped to the working range (`a`, `b`
/// < 2^17 in magnitude).
#[inline(always)]
fn steered(base: i32, c: i32, a: i32, b: i32) -> i32 {
    // (2^16 - c) a + c b = 2^16 a + c (b - a), so the rounded shift is a + mul_q16(c, b - a).
    clamp_full(base + a + mul_q16(c, b - a))
}

impl Frame {
    /// Colour differences `G - C` times 4 (exact): |value| <= 4 * 65535 < 2^18.
    #[inline(always)]
    fn diff_row_fixed(&self, r: usize, p: &mut Planes<'_, i32>) {
        let m: [&[i32]; 5] = p.mosaic.rows(r);
        let gp = self.green_parity(r);
        for parity in 0..2 {
            let span = Span::new(self, parity, 2);
            // The sign as a mask, `(x ^ flip) - flip` negating where it is -1: multiplied by
            // a sign not known at compile time, the loop spent a vector multiply per sample.
            let flip = if parity == gp { 0 } else { -1 };
            let c: [&[i32]; 5] = span.taps(m[2]);
            let dh = span.out(p.diff_h.row_mut(r));
            for i in 0..dh.len() {
                let d = 2 * c[2][i] - 2 * (c[1][i] + c[3][i]) + c[0][i] + c[4][i];
                dh[i] = (d ^ flip) - flip;
            }
            let v = span.column(m);
            let dv = span.out(p.diff_v.row_mut(r));
            for i in 0..dv.len() {
                let d = 2 * v[2][i] - 2 * (v[1][i] + v[3][i]) + v[0][i] + v[4][i];
                dv[i] = (d ^ flip) - flip;
            }
        }
    }

    /// The classifiers in Q16.
    #[inline(always)]
    fn class_row_fixed<W: Wide, const L: usize>(&self, r: usize, p: &mut Planes<'_, i32>) {
        let t = self.class_taps(r, &p.mosaic);
        let lines = [
            (t.green, t.vertical, t.horizontal),
            (t.other, t.along_p, t.along_q),
        ];
        for (span, first, second) in lines {
            let out = span.out(p.class.row_mut(r));
            let n = out.len();
            let blocks = Blocks::<_, L>::new(&first, n).zip(Blocks::<_, L>::new(&second, n));
            let Some((first_blocks, second_blocks)) = blocks else {
                // Fewer than `L` sites.
                for (i, class) in out.iter_mut().enumerate() {
                    *class = line_class::<W>(at(&first, i), at(&second, i));
                }
                continue;
            };
            for_each_block::<L>(
                n,
                #[inline(always)]
                |block| {
                    let (a, b) = (first_blocks.at(block), second_blocks.at(block));
                    let mut values = [0; L];
                    for (j, class) in values.iter_mut().enumerate() {
                        *class = line_class::<W>(lane(&a, j), lane(&b, j));
                    }
                    store(out, block, &values);
                },
            );
        }
    }

    #[inline(always)]
    fn green_row_fixed<W: Wide>(&self, r: usize, p: &mut Planes<'_, i32>) {
        self.keep_green(r, &p.mosaic, &mut p.green);
        let t = self.green_taps(r, &p.mosaic, [&p.diff_v, &p.diff_h], [&p.sum3_v, &p.sum3_h]);
        let out = t.span.out(p.green.row_mut(r));
        let (col, c, dv, dh, s3v, s3h) = (t.column, t.row, t.diff_v, t.diff_h, t.sum3_v, t.sum3_h);
        for i in 0..out.len() {
            // Gradients of the differences < 2^19, their three-sample sums < 2^21.
            let [v0, v1, v2, v3, v4] = at(&s3v, i);
            let [h0, h1, h2, h3, h4] = at(&s3h, i);
            // One-sided sums < 2^23, boxes < 2^23 (five sums).
            let (sn, ss, sw, se) = (v2 + v1 + v0, v2 + v3 + v4, h2 + h1 + h0, h2 + h3 + h4);
            // The float method's floor of one 16-bit step on these sums (4 x): every sum
            // is positive, so no side's weight is a special case.
            let (box_v, box_h) = (sn + ss - v2 + SUM_FLOOR, sw + se - h2 + SUM_FLOOR);
            // box_v^2 / (box_v^2 + box_h^2) from the boxes rounded to the larger's top 14
            // bits: squares <= 2^28.
            let shift = excess_bits(larger(box_v, box_h), 14);
            let (bv, bh) = (shift_round(box_v, shift), shift_round(box_h, shift));
            let class = ratio::<W>(bv * bv, bh * bh);
            // Inverse-square weights relative to the smallest sum, in Q16.
            let least = least4(sn, ss, sw, se);
            let weights = [
                relative_weight::<W>(least, sn),
                relative_weight::<W>(least, ss),
                relative_weight::<W>(least, sw),
                relative_weight::<W>(least, se),
            ];
            // Smoothed differences, 100 x 4 x the float method's (< 2^25).
            let mut smooth = [0i32; 4];
            for (k, f) in SMOOTH_PERCENT.iter().enumerate() {
                smooth[0] += f * dv[3 - k][i];
                smooth[1] += f * dv[3 + k][i];
                smooth[2] += f * dh[3 - k][i];
                smooth[3] += f * dh[3 + k][i];
            }
            // Weighted sum < 2^43, weights' sum <= 2^18 (one of them 2^16), so the divisor
            // 400 x it < 2^27 and the estimate's error a few units in 2^24 of the quotient.
            let mut num = W::of(0);
            let mut den = 0;
            for (w, d) in weights.iter().zip(smooth) {
                num = num.plus(W::product(*w, d));
                den += w;
            }
            let g_diff = c[3][i] + num.round_div(400 * den);
            let [c0, c1, c2, c3, c4, c5, c6] = at(&c, i);
            let [n0, n1, n2, _, n4, n5, n6] = at(&col, i);
            // Gradients in hundredths of an LSB (< 2^25).
            let gn = hundredths((n4 - n2).abs() + (c3 - n1).abs() + (n2 - n0).abs());
            let gs = hundredths((n2 - n4).abs() + (c3 - n5).abs() + (n4 - n6).abs());
            let gw = hundredths((c4 - c2).abs() + (c3 - c1).abs() + (c2 - c0).abs());
            let ge = hundredths((c2 - c4).abs() + (c3 - c5).abs() + (c4 - c6).abs());
            // Products < 2^42, divisors < 2^26.
            let vertical = mean2::<W>(gs, n2, gn, n4);
            let horizontal = mean2::<W>(ge, c2, gw, c4);
            let g_plain = vertical + mul_q16(class, horizontal - vertical);
            // The float method's 0.6 + 0.35 r / (r + 2 d), with r the least raw gradient over
            // 3 and d the least difference gradient over 9: on these scales (hundredths, and
            // 4 x), r / (r + 2 d) is 3 raw / (3 raw + 50 diff). Numerator < 2^43, divisor
            // < 2^29.
            let raw = 3 * least4(gn, gs, gw, ge);
            let a = 39322 + W::product(22938, raw).floor_div(raw + 50 * least);
            out[i] = clamp_full(g_plain + mul_q16(a, g_diff - g_plain));
        }
    }

    #[inline(always)]
    fn chroma_row_fixed<W: Wide, const L: usize>(&self, r: usize, p: &mut Planes<'_, i32>) {
        let t = self.chroma_taps(r, &p.mosaic, &p.green, &p.class);
        let out = t.span.out(p.opposite.row_mut(r));
        let n = out.len();
        if n < L {
            for (i, opposite) in out.iter_mut().enumerate() {
                let class = (t.class[i], at(&t.class_around, i));
                let p = (at(&t.chroma_p, i), at(&t.green_p, i));
                let q = (at(&t.chroma_q, i), at(&t.green_q, i));
                *opposite = opposite_site::<W>(class, p, q);
            }
            return;
        }
        // One statement each, not one pattern over a tuple of `Option`s: LLVM kept that tuple
        // in memory, and each tap's block then took a compare, a branch and a reload of the
        // tap's length (53 of them per block at green sites). `new` fails only below `L`
        // sites, handled above, or for a tap shorter than the span, which `Span` never gives.
        let Some(class) = Blocks::<_, L>::new(&[t.class], n) else {
            return;
        };
        let Some(around) = Blocks::<_, L>::new(&t.class_around, n) else {
            return;
        };
        let Some(chroma_p) = Blocks::<_, L>::new(&t.chroma_p, n) else {
            return;
        };
        let Some(green_p) = Blocks::<_, L>::new(&t.green_p, n) else {
            return;
        };
        let Some(chroma_q) = Blocks::<_, L>::new(&t.chroma_q, n) else {
            return;
        };
        let Some(green_q) = Blocks::<_, L>::new(&t.green_q, n) else {
            return;
        };
        for_each_block::<L>(
            n,
            #[inline(always)]
            |block| {
                let (class, around) = (class.at(block), around.at(block));
                let (chroma_p, green_p) = (chroma_p.at(block), green_p.at(block));
                let (chroma_q, green_q) = (chroma_q.at(block), green_q.at(block));
                let mut values = [0; L];
                for (j, opposite) in values.iter_mut().enumerate() {
                    let class = (class[0][j], lane(&around, j));
                    let p = (lane(&chroma_p, j), lane(&green_p, j));
                    let q = (lane(&chroma_q, j), lane(&green_q, j));
                    *opposite = opposite_site::<W>(class, p, q);
                }
                store(out, block, &values);
            },
        );
    }

    /// Stage 6: red and blue at row `r`'s green pixels, into the output rows (their
    /// green-site halves).
    #[inline(always)]
    fn output_estimates_fixed<W: Wide, const L: usize>(&self, r: usize, p: &mut Planes<'_, i32>) {
        let t = self.green_site_taps(r, &p.mosaic, &p.opposite, &p.green, &p.class);
        let [red, _, blue] = &mut p.out_rgb;
        let (red_g, blue_g) = (t.span.out(red), t.span.out(blue));
        let n = red_g.len();
        if n < L {
            for i in 0..n {
                let class = (t.class[i], at(&t.class_around, i));
                let green = [at(&t.green_v, i), at(&t.green_h, i)];
                let red = [at(&t.red_v, i), at(&t.red_h, i)];
                let blue = [at(&t.blue_v, i), at(&t.blue_h, i)];
                [red_g[i], blue_g[i]] = green_site::<W>(class, green, red, blue);
            }
            return;
        }
        // One statement each: see `chroma_row_fixed`.
        let Some(class) = Blocks::<_, L>::new(&[t.class], n) else {
            return;
        };
        let Some(around) = Blocks::<_, L>::new(&t.class_around, n) else {
            return;
        };
        let Some(green_v) = Blocks::<_, L>::new(&t.green_v, n) else {
            return;
        };
        let Some(green_h) = Blocks::<_, L>::new(&t.green_h, n) else {
            return;
        };
        let Some(red_v) = Blocks::<_, L>::new(&t.red_v, n) else {
            return;
        };
        let Some(red_h) = Blocks::<_, L>::new(&t.red_h, n) else {
            return;
        };
        let Some(blue_v) = Blocks::<_, L>::new(&t.blue_v, n) else {
            return;
        };
        let Some(blue_h) = Blocks::<_, L>::new(&t.blue_h, n) else {
            return;
        };
        for_each_block::<L>(
            n,
            #[inline(always)]
            |block| {
                let (class, around) = (class.at(block), around.at(block));
                let (green_v, green_h) = (green_v.at(block), green_h.at(block));
                let (red_v, red_h) = (red_v.at(block), red_h.at(block));
                let (blue_v, blue_h) = (blue_v.at(block), blue_h.at(block));
                let mut values = [[0; L]; 2];
                for j in 0..L {
                    let class = (class[0][j], lane(&around, j));
                    let green = [lane(&green_v, j), lane(&green_h, j)];
                    let red = [lane(&red_v, j), lane(&red_h, j)];
                    let blue = [lane(&blue_v, j), lane(&blue_h, j)];
                    [values[0][j], values[1][j]] = green_site::<W>(class, green, red, blue);
                }
                store(red_g, block, &values[0]);
                store(blue_g, block, &values[1]);
            },
        );
    }
}

/// The opposite chroma at one red or blue site: its classifier and the four around it, and
/// along each diagonal (`p`, `q`) the chroma at -3, -1, 1, 3 and the green at -2..=2.
#[inline(always)]
fn opposite_site<W: Wide>(
    class: (i32, [i32; 4]),
    p: ([i32; 4], [i32; 5]),
    q: ([i32; 4], [i32; 5]),
) -> i32 {
    let est_p = pair_estimate::<W>(p.0, p.1);
    let est_q = pair_estimate::<W>(q.0, q.1);
    steered(p.1[2], refined(class.0, class.1), est_p, est_q)
}

/// Red and blue at one green site: its classifier and the four around it, the green along
/// the column and the row (offsets -2..=2), and red and blue along both (-3, -1, 1, 3).
#[inline(always)]
fn green_site<W: Wide>(
    class: (i32, [i32; 4]),
    green: [[i32; 5]; 2],
    red: [[i32; 4]; 2],
    blue: [[i32; 4]; 2],
) -> [i32; 2] {
    let c = refined(class.0, class.1);
    let [gv, gh] = green;
    [
        steered_pair::<W>(c, gv, gh, red),
        steered_pair::<W>(c, gv, gh, blue),
    ]
}

/// One chroma at a green site from its samples along the column and the row (`along`) and
/// the green there (`gv`, `gh`), steered by the classifier `c`. A function marked to inline,
/// not a closure: in the pipeline's AVX2 entry LLVM left a closure here out of line, a call
/// per lane.
#[inline(always)]
fn steered_pair<W: Wide>(c: i32, gv: [i32; 5], gh: [i32; 5], along: [[i32; 4]; 2]) -> i32 {
    let vertical = pair_estimate::<W>(along[0], gv);
    let horizontal = pair_estimate::<W>(along[1], gh);
    steered(gv[2], c, vertical, horizontal)
}

/// The float method's `refined` for Q16 classifiers: `own` if it is further from one half
/// than the mean of its four diagonal neighbours, else that mean, fading linearly between the
/// two within 1/64 (1024) of equally decided.
#[inline(always)]
fn refined(own: i32, diagonal: [i32; 4]) -> i32 {
    let around = (diagonal[0] + diagonal[1] + diagonal[2] + diagonal[3] + 2) >> 2;
    let (half, fade) = (ONE / 2, ONE / 64);
    let lead = (half - own).abs() - (half - around).abs();
    // (lead + fade) / (2 fade) in Q16; |lead| <= 2^15, so the product < 2^21.
    let keep = (lead + fade) * (ONE / (2 * fade));
    let keep = if keep > 0 { keep } else { 0 };
    let keep = if keep < ONE { keep } else { ONE };
    around + mul_q16(keep, own - around)
}

#[cfg(test)]
mod tests {
    use super::{excess_bits, mul_q16, Estimated, Exact, Fixed, Wide};
    use crate::frame::{MosaicView, RgbViewMut};
    use crate::CfaPattern;

    /// The tests' operands.
    fn generator() -> impl FnMut() -> u64 {
        crate::math::xorshift(0x2545_f491_4f6c_dd1d)
    }

    /// Both [`Wide`]s side by side, every division checked to agree.
    #[derive(Clone, Copy)]
    struct Checked(Exact, Estimated);
    impl Wide for Checked {
        fn of(v: i32) -> Self {
            Checked(Exact::of(v), Estimated::of(v))
        }
        fn product(a: i32, b: i32) -> Self {
            Checked(Exact::product(a, b), Estimated::product(a, b))
        }
        fn plus(self, o: Self) -> Self {
            Checked(self.0.plus(o.0), self.1.plus(o.1))
        }
        fn floor_div(self, d: i32) -> i32 {
            let (a, b) = (self.0.floor_div(d), self.1.floor_div(d));
            assert_eq!(a, b, "floor {} / {d} est {}", self.0 .0, self.1.estimate);
            a
        }
        fn round_div(self, d: i32) -> i32 {
            let (a, b) = (self.0.round_div(d), self.1.round_div(d));
            assert_eq!(a, b, "round {} / {d} est {}", self.0 .0, self.1.estimate);
            a
        }
    }

    /// The estimated division gives the exact quotient for numerators formed as the stages
    /// form them (two products and an offset), at exact multiples, remainders of one and
    /// `d - 1`, and negative numerators, for divisors up to 2^31.
    #[test]
    fn estimated_division_is_the_integer_division() {
        let mut next = generator();
        for _ in 0..200_000 {
            let d = ((next() >> (33 + next() % 31)) as i32).max(1); // 1 ..= 2^31 - 1
            let q = (next() >> (44 + next() % 20)) as i64 - (1 << 19); // |q| <= 2^20
            for r in [0, 1, i64::from(d) / 2, i64::from(d) - 1]
                .into_iter()
                .filter(|r| *r < i64::from(d))
            {
                let n = q * i64::from(d) + r;
                // n = a * b + c with b a spread value, as the weighted means are.
                let b = ((next() >> (40 + next() % 24)) as i32).max(1);
                let (a, c) = (n.div_euclid(i64::from(b)), n.rem_euclid(i64::from(b)));
                if a.abs() >= 1 << 31 {
                    continue;
                }
                let (a, c) = (a as i32, c as i32);
                let exact = Exact::product(a, b).plus(Exact::of(c));
                let estimated = Estimated::product(a, b).plus(Estimated::of(c));
                assert_eq!(exact.0, n);
                assert_eq!(exact.floor_div(d), q as i32, "{n} / {d}");
                assert_eq!(estimated.floor_div(d), q as i32, "{n} / {d}");
                if d < 1 << 30 {
                    let rounded = (2 * n + i64::from(d)).div_euclid(2 * i64::from(d));
                    assert_eq!(exact.round_div(d), rounded as i32, "{n} / {d}");
                    assert_eq!(estimated.round_div(d), rounded as i32, "{n} / {d}");
                }
            }
        }
    }

    /// `mul_q16` is the rounded Q16 product it replaces, over the classifiers and the
    /// differences the stages scale.
    #[test]
    fn mul_q16_is_the_rounded_product() {
        let mut next = generator();
        for _ in 0..500_000 {
            let c = (next() % 65537) as i32;
            let x = (next() % (1 << 21)) as i32 - (1 << 20) + 1;
            let wide = (i64::from(c) * i64::from(x) + 0x8000) >> 16;
            assert_eq!(i64::from(mul_q16(c, x)), wide, "{c} {x}");
        }
        for (c, x) in [
            (65536, (1 << 20) - 1),
            (65536, 1 - (1 << 20)),
            (0, -5),
            (65535, -1),
        ] {
            assert_eq!(
                i64::from(mul_q16(c, x)),
                (i64::from(c) * i64::from(x) + 0x8000) >> 16
            );
        }
    }

    /// The bit length read from the `f32` exponent is the integer one, at every power of two
    /// and its neighbours up to 2^24.
    #[test]
    fn excess_bits_is_the_bit_length_past_the_limit() {
        for p in 0..=24 {
            for m in [(1i32 << p) - 1, 1 << p, (1 << p) + 1] {
                let m = m.min(1 << 24);
                let length = 32 - (m as u32).leading_zeros() as i32;
                for bits in [12, 14] {
                    assert_eq!(excess_bits(m, bits), (length - bits).max(0), "{m} {bits}");
                }
            }
        }
    }

    /// The method with `Estimated` intermediates (x86-64 and AArch64) gives the bytes it gives
    /// with `Exact` ones (every other target), every division checked on the way, on a frame of sharp edges, saturated colour,
    /// ramps and noise at full 16-bit range, in every CFA phase.
    #[test]
    fn estimated_and_exact_methods_agree_bit_for_bit() {
        const W: usize = 96;
        const H: usize = 64;
        const SCRATCH: usize = match super::super::scratch_len(W) {
            Some(n) => n,
            None => 0,
        };
        let (w, h) = (W, H);
        let mut next = generator();
        let mut data = [0u16; W * H];
        for (i, d) in data.iter_mut().enumerate() {
            let (x, y) = (i % w, i / w);
            let noise = (next() >> 52) as u32; // 0..4096
            let v = match (x / 16 + y / 16) % 4 {
                0 => 65535 * ((x + y) % 2) as u32,       // a checkerboard
                1 => (x * 700 + y * 300) as u32 % 65536, // ramps
                2 => noise * 16,                         // full-range noise
                _ => 30 + noise % 40,                    // dark, near flat
            };
            *d = v.min(65535) as u16;
        }
        for pattern in [
            CfaPattern::Rggb,
            CfaPattern::Bggr,
            CfaPattern::Grbg,
            CfaPattern::Gbrg,
        ] {
            let mosaic = MosaicView::new(&data, w, h, w, pattern).unwrap();
            let run = |exact: bool| {
                let mut rgb = [0u16; 3 * W * H];
                let mut out = RgbViewMut::new(&mut rgb, w, h, 3 * w).unwrap();
                let mut scratch = [0i32; SCRATCH];
                if exact {
                    super::super::whole_frame::<Fixed<u16, Checked>, { super::super::LANES }>(
                        &mosaic,
                        &mut out,
                        &mut scratch,
                    )
                } else {
                    super::super::whole_frame::<Fixed<u16, Estimated>, { super::super::LANES }>(
                        &mosaic,
                        &mut out,
                        &mut scratch,
                    )
                }
                .unwrap();
                rgb
            };
            let (exact, estimated) = (run(true), run(false));
            let differing = exact.iter().zip(&estimated).filter(|(a, b)| a != b).count();
            assert_eq!(differing, 0, "{pattern:?}");
            // The frame exercises the method: its output is not flat.
            assert!(exact.iter().any(|v| *v > 60000) && exact.iter().any(|v| *v < 100));
        }
    }
}
