//! The directional method in integer arithmetic, for cores without a floating-point unit.
//!
//! The same stages, schedule and buffers as the `f32` method, on `i32` samples scaled to 16
//! bits (8-bit input is multiplied by 257). Sums of samples are exact; ratios (the classifiers,
//! the blend weights) are Q16 fractions; weighted means divide in `i64` and round half up.
//! The float method's small constants are carried over at their size on this scale, not
//! replaced by a 1 that would be large next to them: its gradient floor (1e-5 of full scale,
//! 0.66 LSB) by scaling those gradients by 100 and adding 66, its classifier floor (1e-10) by
//! an offset of 1.75 units of the integer statistic, and its 1e-20 against division by zero
//! (negligible on this scale) by handling zero exactly. Each product's bound is stated where it
//! is formed; none exceeds `i64`. Every division is exact integer division (`floor_div`),
//! computed on x86-64 and AArch64 through an `f32` estimate so that the loops vectorise.

use super::{at, Arithmetic, Frame, Planes, Span, SMOOTH_PERCENT};
use crate::frame::{IntSample, MosaicView, RgbViewMut};
use crate::IspError;

/// Fraction bits of the ratios.
const Q: u32 = 16;
/// One in Q16.
const ONE: i64 = 1 << Q;
/// The float method's gradient floor, 1e-5 of full scale, in hundredths of a 16-bit LSB: the
/// gradients that carry it are kept in hundredths.
const EPS_HUNDREDTHS: i32 = 66;
/// The float method's `SUM_FLOOR` (one 16-bit step) on the gradient sums' scale (4 x).
const SUM_FLOOR: i64 = 4;
/// Full scale of the working samples.
const FULL: i32 = 65535;

/// Demosaics `input` into `output` (same size) with the directional method in integer
/// arithmetic, using `scratch` (at least [`scratch_len`](super::scratch_len)`(width)` samples).
/// Its CPSNR on the standard sets equals [`directional`](super::directional)'s to two
/// decimals (Kodak 39.73, McMaster 36.11 dB at 16 bits). Over every Kodak and McMaster image
/// as a 16-bit mosaic, 99.88 % of the samples are within 1 LSB of it and none further than 25
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
    super::whole_frame::<Fixed<T>>(input, output, scratch)
}

/// [`directional_fixed`] compiled for x86-64 CPUs with AVX-512 (F, BW, VL and DQ): the same
/// output; the 64-bit lanes and conversions its divisions need are native there, so its loops
/// run eight `i64` lanes wide (about 4x the baseline build).
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
    super::whole_frame::<Fixed<T>>(input, output, scratch)
}

/// The integer method on samples of type `T`.
pub(crate) struct Fixed<T>(core::marker::PhantomData<T>);

impl<T: IntSample> Arithmetic for Fixed<T> {
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
    fn class(frame: &Frame, r: usize, p: &mut Planes<'_, i32>) {
        // Gradients < 2^19, their three-sample sums < 2^21.
        frame.class_row_fixed(r, p);
    }
    #[inline(always)]
    fn green(frame: &Frame, r: usize, p: &mut Planes<'_, i32>) {
        frame.green_row_fixed(r, p);
    }
    #[inline(always)]
    fn chroma(frame: &Frame, r: usize, p: &mut Planes<'_, i32>) {
        frame.chroma_row_fixed(r, p);
    }
    #[inline(always)]
    fn output(frame: &Frame, r: usize, p: &mut Planes<'_, i32>, out: &mut [T]) {
        frame.output_estimates_fixed(r, p);
        let [red, green, blue] = &p.out_rgb;
        frame.write_row([&**red, &**green, &**blue], out, from_working::<T>);
    }
    #[inline(always)]
    fn estimate_output(frame: &Frame, r: usize, p: &mut Planes<'_, i32>) {
        frame.output_estimates_fixed(r, p);
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

/// `floor(n / d)` for `d > 0`, `|n| < 2^62` and a quotient below 2^20 in magnitude (every
/// division here: the largest quotients are colour differences, < 2^18), exactly
/// `n.div_euclid(d)`.
///
/// On x86-64 and AArch64 it divides in `f32` and corrects the quotient by one either way:
/// `n` and `d` convert with a relative error of 2^-24 each and the division adds one more,
/// so the `f32` quotient is within 0.2 of the exact one, its nearest integer within one of
/// the exact floor, and the remainder `n - q d` (exact in `i64`) says which. Unlike an integer division, which no vector unit has, this vectorises,
/// so the stages' loops run in SIMD lanes: the integer method divides about eight times per
/// pixel, and `idiv` took most of its time. On other targets (cores without a floating-point
/// unit, where `f64` is emulated) it is the integer division.
#[inline(always)]
fn floor_div(n: i64, d: i64) -> i64 {
    #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
    {
        // The quotient rounded to the nearest integer by adding 1.5 * 2^23, which leaves it in
        // the low bits of the sum (for |x| < 2^22): no float-to-integer conversion, whose
        // saturating `as` compiles to a branch per lane. `f32`, not `f64`: its division has
        // the precision this needs at three times the throughput. The products wrap, so no
        // input panics; for the inputs above the result is exact.
        const ROUNDER: f32 = 12_582_912.0;
        let x = n as f32 / d as f32;
        let q = ((x + ROUNDER).to_bits() as i32).wrapping_sub(ROUNDER.to_bits() as i32) as i64;
        let r = n.wrapping_sub(q.wrapping_mul(d));
        let q = if r < 0 { q.wrapping_sub(1) } else { q };
        if r >= d {
            q.wrapping_add(1)
        } else {
            q
        }
    }
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    {
        n.div_euclid(d.max(1))
    }
}

/// `n / d` rounded half up, for `d > 0`.
#[inline(always)]
fn div_round(n: i64, d: i64) -> i64 {
    floor_div(2 * n + d, 2 * d)
}

/// `v` clamped to the working range.
#[inline(always)]
fn clamp_full(v: i64) -> i32 {
    let v = if v > 0 { v } else { 0 };
    (if v < FULL as i64 { v } else { FULL as i64 }) as i32
}

// The small helpers below are functions marked to inline, not closures or `Ord::min`: in the
// pipeline's large AVX-512 entry LLVM left such calls out of line, one call per pixel, and
// a loop with a call does not vectorise.

/// The least of four values.
#[inline(always)]
fn least4(a: i64, b: i64, c: i64, d: i64) -> i64 {
    let ab = if a < b { a } else { b };
    let cd = if c < d { c } else { d };
    if ab < cd {
        ab
    } else {
        cd
    }
}

/// A gradient (a sum of sample differences) in hundredths of an LSB, with the float method's
/// floor.
#[inline(always)]
fn hundredths(s: i32) -> i32 {
    100 * s + EPS_HUNDREDTHS
}

/// The inverse-square weight of a side whose gradient sum is `s`, relative to the least sum
/// `least`, in Q16: `((least + floor) / (s + floor))^2`; `(least + floor) << 16 < 2^40`.
#[inline(always)]
fn relative_weight(least: i64, s: i64) -> i64 {
    let q = floor_div((least + SUM_FLOOR) << Q, s + SUM_FLOOR);
    (q * q) >> Q
}

/// `a / (a + b)` in Q16, rounded, for `0 <= a, b < 2^46`; one half when both are 0.
#[inline(always)]
fn ratio(a: i64, b: i64) -> i64 {
    let sum = a + b;
    // Both arms computed, so the loops calling this vectorise (a select, not a branch).
    let q = floor_div((a << Q) + sum / 2, sum.max(1));
    if sum == 0 {
        ONE / 2
    } else {
        q
    }
}

/// The float method's classifier `v / (v + h)` from two line statistics ([`line_stat`], each
/// < 2^37): its floor of 1e-10 (in squared full scale) is 1.72 units of these statistics, so
/// `(4 v + 7) / (4 v + 4 h + 14)`.
#[inline(always)]
fn line_ratio(v: i64, h: i64) -> i64 {
    ratio(4 * v + 7, 4 * h + 7)
}

/// `4 x` the float method's line statistic (sum of squared first differences and a quarter
/// of the squared second differences over the three centre positions of seven samples).
/// Samples < 2^16, so each term < 4 * 2^32 + 2^34 and the sum < 2^37.
#[inline(always)]
fn line_stat(v: [i32; 7]) -> i64 {
    let mut s = 0;
    for k in 2..5 {
        let first = (v[k - 1] - v[k + 1]) as i64;
        let second = (2 * v[k] - v[k - 2] - v[k + 2]) as i64;
        s += 4 * first * first + second * second;
    }
    s
}

/// The float method's `pair_estimate`: `x` the chroma at offsets -3, -1, 1, 3, `g` the green
/// at -2..=2. The weights (hundredths of an LSB) are < 2^25 and the differences < 2^17.
#[inline(always)]
fn pair_estimate(x: [i32; 4], g: [i32; 5]) -> i64 {
    let before = hundredths((x[1] - x[2]).abs() + (x[1] - x[0]).abs() + (g[2] - g[0]).abs());
    let after = hundredths((x[2] - x[1]).abs() + (x[2] - x[3]).abs() + (g[2] - g[4]).abs());
    let (before, after) = (before as i64, after as i64);
    div_round(
        after * (x[1] - g[1]) as i64 + before * (x[2] - g[3]) as i64,
        before + after,
    )
}

/// `base + (1 - c) a + c b` for a Q16 classifier `c`, clamped to the working range.
#[inline(always)]
fn steered(base: i32, c: i64, a: i64, b: i64) -> i32 {
    clamp_full(base as i64 + (((ONE - c) * a + c * b + ONE / 2) >> Q))
}

impl Frame {
    /// Colour differences `G - C` times 4 (exact): |value| <= 4 * 65535 < 2^18.
    #[inline(always)]
    fn diff_row_fixed(&self, r: usize, p: &mut Planes<'_, i32>) {
        let m: [&[i32]; 5] = p.mosaic.rows(r);
        let gp = self.green_parity(r);
        for parity in 0..2 {
            let span = Span::new(self, parity, 2);
            let sign = if parity == gp { 1 } else { -1 };
            let c: [&[i32]; 5] = span.taps(m[2]);
            let dh = span.out(p.diff_h.row_mut(r));
            for i in 0..dh.len() {
                dh[i] = sign * (2 * c[2][i] - 2 * (c[1][i] + c[3][i]) + c[0][i] + c[4][i]);
            }
            let v = span.column(m);
            let dv = span.out(p.diff_v.row_mut(r));
            for i in 0..dv.len() {
                dv[i] = sign * (2 * v[2][i] - 2 * (v[1][i] + v[3][i]) + v[0][i] + v[4][i]);
            }
        }
    }

    /// The classifiers in Q16.
    #[inline(always)]
    fn class_row_fixed(&self, r: usize, p: &mut Planes<'_, i32>) {
        let t = self.class_taps(r, &p.mosaic);
        let hv = t.green.out(p.class.row_mut(r));
        for (i, class) in hv.iter_mut().enumerate() {
            *class = line_ratio(
                line_stat(at(&t.vertical, i)),
                line_stat(at(&t.horizontal, i)),
            ) as i32;
        }
        let pq = t.other.out(p.class.row_mut(r));
        for (i, class) in pq.iter_mut().enumerate() {
            *class = line_ratio(line_stat(at(&t.along_p, i)), line_stat(at(&t.along_q, i))) as i32;
        }
    }

    #[inline(always)]
    fn green_row_fixed(&self, r: usize, p: &mut Planes<'_, i32>) {
        self.keep_green(r, &p.mosaic, &mut p.green);
        let t = self.green_taps(r, &p.mosaic, [&p.diff_v, &p.diff_h], [&p.sum3_v, &p.sum3_h]);
        let out = t.span.out(p.green.row_mut(r));
        let (col, c, dv, dh, s3v, s3h) = (t.column, t.row, t.diff_v, t.diff_h, t.sum3_v, t.sum3_h);
        for i in 0..out.len() {
            let [v0, v1, v2, v3, v4] = at(&s3v, i);
            let [h0, h1, h2, h3, h4] = at(&s3h, i);
            // Written out, not `array::map`: see `at`.
            let (v0, v1, v2, v3, v4) = (v0 as i64, v1 as i64, v2 as i64, v3 as i64, v4 as i64);
            let (h0, h1, h2, h3, h4) = (h0 as i64, h1 as i64, h2 as i64, h3 as i64, h4 as i64);
            // One-sided sums < 2^23, boxes < 2^24.
            let (sn, ss, sw, se) = (v2 + v1 + v0, v2 + v3 + v4, h2 + h1 + h0, h2 + h3 + h4);
            let (box_v, box_h) = (sn + ss - v2, sw + se - h2);
            // The float method's floor of one 16-bit step on these sums (4 x): every sum
            // is positive, so no side's weight is a special case. Floored boxes < 2^23, so
            // their squares < 2^46.
            let (box_v, box_h) = (box_v + SUM_FLOOR, box_h + SUM_FLOOR);
            let class = ratio(box_v * box_v, box_h * box_h);
            // Inverse-square weights relative to the smallest sum, in Q16: (least / s)^2,
            // least << 16 < 2^40.
            let least = least4(sn, ss, sw, se);
            let weights = [
                relative_weight(least, sn),
                relative_weight(least, ss),
                relative_weight(least, sw),
                relative_weight(least, se),
            ];
            // Smoothed differences, 100 x 4 x the float method's (< 2^25).
            let mut smooth = [0i64; 4];
            for (k, f) in SMOOTH_PERCENT.iter().enumerate() {
                smooth[0] += f * dv[3 - k][i] as i64;
                smooth[1] += f * dv[3 + k][i] as i64;
                smooth[2] += f * dh[3 - k][i] as i64;
                smooth[3] += f * dh[3 + k][i] as i64;
            }
            let mut num = 0;
            let mut den = 0;
            for (w, d) in weights.iter().zip(smooth) {
                num += w * d;
                den += w;
            }
            let g_diff = c[3][i] as i64 + div_round(num, 400 * den);
            let [c0, c1, c2, c3, c4, c5, c6] = at(&c, i);
            let [n0, n1, n2, _, n4, n5, n6] = at(&col, i);
            // Gradients in hundredths of an LSB (< 2^25).
            let gn = hundredths((n4 - n2).abs() + (c3 - n1).abs() + (n2 - n0).abs());
            let gs = hundredths((n2 - n4).abs() + (c3 - n5).abs() + (n4 - n6).abs());
            let gw = hundredths((c4 - c2).abs() + (c3 - c1).abs() + (c2 - c0).abs());
            let ge = hundredths((c2 - c4).abs() + (c3 - c5).abs() + (c4 - c6).abs());
            let (gn, gs, gw, ge) = (gn as i64, gs as i64, gw as i64, ge as i64);
            let vertical = div_round(gs * n2 as i64 + gn * n4 as i64, gn + gs);
            let horizontal = div_round(ge * c2 as i64 + gw * c4 as i64, gw + ge);
            let g_plain = (class * horizontal + (ONE - class) * vertical + ONE / 2) >> Q;
            // The float method's 0.6 + 0.35 r / (r + 2 d), with r the least raw gradient over
            // 3 and d the least difference gradient over 9: on these scales (hundredths, and
            // 4 x), r / (r + 2 d) is 3 raw / (3 raw + 50 diff).
            let raw = 3 * least4(gn, gs, gw, ge);
            let a = 39322 + floor_div(22938 * raw, raw + 50 * least);
            out[i] = clamp_full((a * g_diff + (ONE - a) * g_plain + ONE / 2) >> Q);
        }
    }

    #[inline(always)]
    fn chroma_row_fixed(&self, r: usize, p: &mut Planes<'_, i32>) {
        let t = self.chroma_taps(r, &p.mosaic, &p.green, &p.class);
        let out = t.span.out(p.opposite.row_mut(r));
        for (i, opposite) in out.iter_mut().enumerate() {
            let est_p = pair_estimate(at(&t.chroma_p, i), at(&t.green_p, i));
            let est_q = pair_estimate(at(&t.chroma_q, i), at(&t.green_q, i));
            let c = refined(t.class[i], at(&t.class_around, i));
            *opposite = steered(t.green_p[2][i], c, est_p, est_q);
        }
    }

    /// Stage 6: red and blue at row `r`'s green pixels, into the output rows with what the
    /// row already knows.
    #[inline(always)]
    fn output_estimates_fixed(&self, r: usize, p: &mut Planes<'_, i32>) {
        self.fill_known(r, p);
        let t = self.green_site_taps(r, &p.mosaic, &p.opposite, &p.green, &p.class);
        let [red, _, blue] = &mut p.out_rgb;
        let (red_g, blue_g) = (t.span.out(red), t.span.out(blue));
        for i in 0..red_g.len() {
            let c = refined(t.class[i], at(&t.class_around, i));
            let (gv, gh) = (at(&t.green_v, i), at(&t.green_h, i));
            let vertical = pair_estimate(at(&t.red_v, i), gv);
            let horizontal = pair_estimate(at(&t.red_h, i), gh);
            red_g[i] = steered(gv[2], c, vertical, horizontal);
            let vertical = pair_estimate(at(&t.blue_v, i), gv);
            let horizontal = pair_estimate(at(&t.blue_h, i), gh);
            blue_g[i] = steered(gv[2], c, vertical, horizontal);
        }
    }
}

/// The float method's `refined` for Q16 classifiers: `own` if it is further from one half
/// than the mean of its four diagonal neighbours, else that mean, fading linearly between the
/// two within 1/64 (1024) of equally decided.
#[inline(always)]
fn refined(own: i32, diagonal: [i32; 4]) -> i64 {
    let around = i64::from((diagonal[0] + diagonal[1] + diagonal[2] + diagonal[3] + 2) >> 2);
    let (own, half, fade) = (i64::from(own), ONE / 2, ONE / 64);
    let lead = (half - own).abs() - (half - around).abs();
    // (lead + fade) / (2 fade) in Q16; |lead| <= 2^15, so every product < 2^37.
    let keep = (lead + fade) * (ONE / (2 * fade));
    let keep = if keep > 0 { keep } else { 0 };
    let keep = if keep < ONE { keep } else { ONE };
    around + ((keep * (own - around) + ONE / 2) >> Q)
}

#[cfg(test)]
mod tests {
    use super::floor_div;

    /// `floor_div` is `div_euclid` over the quotients and operands the stages divide: exact
    /// multiples, remainders of one and `d - 1`, negative numerators, and spread values.
    #[test]
    fn floor_div_is_the_integer_division() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for _ in 0..200_000 {
            let d = (next() >> (17 + next() % 46)).max(1) as i64; // 1 ..= 2^47
            let q = (next() >> (44 + next() % 20)) as i64 - (1 << 19); // |q| <= 2^20
            let quotient_room = (1i64 << 62) / d;
            let q = q.clamp(-quotient_room + 1, quotient_room - 1);
            for r in [0, 1, d / 2, d - 1].into_iter().filter(|r| *r < d) {
                let n = q * d + r;
                assert_eq!(floor_div(n, d), q, "{n} / {d}");
                assert_eq!(floor_div(n, d), n.div_euclid(d), "{n} / {d}");
            }
        }
    }
}
