//! The high-quality method: directional colour-difference demosaicing with ratio-free
//! refinement, designed for a fixed window and a band of line buffers.
//!
//! Computed in `f32` on samples scaled to `[0, 1]` (any FPU-equipped core; integer samples are
//! converted on the way in and rounded half up on the way out), in seven stages over a band of
//! rows with a 12-row halo above and below (and 12 columns left and right), reflected at the
//! frame edges like every other method (reflect-101, which keeps the CFA parity):
//!
//! 1. **Directional colour differences.** At every pixel, Hamilton-Adams estimates of the
//!    missing green (at R/B) or chroma (at G) along the row and along the column give two
//!    colour-difference planes `G - C`, horizontal and vertical.
//! 2. **Their gradients** along their own direction, summed over 3x3 windows displaced north,
//!    south, west and east of the pixel (the gradient-based threshold-free idea of
//!    Pekkucuksen and Altunbasak, ICIP 2010, with our own windows and weights).
//! 3. **Green at R/B** blends two estimates. The first adds to the pixel's own sample the four
//!    one-sided smoothed colour differences (taps 0.56, 0.35, 0.08, 0.01 from the centre out),
//!    weighted by the inverse square of each side's gradient sum. The second is a gradient-
//!    weighted mean of the green neighbours alone, steered by a horizontal/vertical classifier
//!    from the same gradient sums. The blend favours the colour-difference estimate (0.6 to
//!    0.95) where the colour differences are smoother than the raw samples, and the plain
//!    neighbours where they are not: colour differences hold for natural scenes (Kodak) but
//!    break on saturated, weakly correlated colour (McMaster).
//! 4. **Classifiers on the mosaic** (horizontal/vertical and the two diagonals): a sum of
//!    squared first and second differences along each direction, refined by the mean of the
//!    four diagonal neighbours' where those are more decided. This statistic and steps 5-6
//!    follow Luis Sanz Rodríguez's ratio corrected demosaicing (RCD), without its ratios.
//! 5. **B at R and R at B**: colour differences from the four diagonal neighbours, weighted by
//!    inverse gradients and steered by the diagonal classifier.
//! 6. **R and B at G**: the same from the four cardinal neighbours (now all known), steered by
//!    the horizontal/vertical classifier.
//!
//! Every estimate is clamped to `[0, 1]` before use, so no overshoot survives and integer
//! outputs saturate. The window reaches 11 pixels out; frames 1 pixel wide or high use
//! bilinear's line rule (see the parent module).
//!
//! **Streaming.** Each stage runs one row at a time, a fixed number of rows behind the stage it
//! reads, over ring buffers of 16 rows per intermediate plane: [`scratch_len`]`(width)` samples
//! in all (12 planes), about 1.6 MB for a 2048-pixel-wide frame and independent of the height.
//! Each intermediate stage computes every pixel of its row and selects by CFA colour, so its
//! inner loop has no branch and vectorises (the output row, which interleaves RGB, branches).
//! On x86-64, [`directional_avx2`] is the same code compiled for AVX2 (bit-identical output).
//! Speed is not yet where the design aims: 24.5 Mpix/s single-thread at 16 bits with AVX2 on
//! the project's 2-core EPYC (`camsim bench demosaic`), about a fifth of MHC.

use super::{reflect, same_size, Method};
use crate::frame::{MosaicView, RgbViewMut, Sample};
use crate::{CfaColour, CfaPattern, IspError};

/// Rows and columns of context outside the frame (even, so padded coordinates keep the
/// frame's CFA parity).
pub const HALO: usize = 12;
/// Rows held per plane: the longest distance between a row's production and its last reader
/// is 14 rows (the red and blue planes).
const RING: usize = 16;
/// Intermediate planes.
const PLANES: usize = 12;
/// Floor of the one-sided gradients, in units of full scale.
const EPS: f32 = 1e-5;
/// Keeps divisions by squared sums finite on flat fields.
const TINY: f32 = 1e-20;
/// One-sided smoothing of the colour differences, centre first.
const SMOOTH: [f32; 4] = [0.56, 0.35, 0.08, 0.01];

/// Scratch samples [`directional`] needs for a frame `width` pixels wide; `None` on overflow.
///
/// ```
/// use isp_core::demosaic::directional::{scratch_len, HALO};
/// assert_eq!(scratch_len(100), Some(12 * 16 * (100 + 2 * HALO)));
/// ```
pub const fn scratch_len(width: usize) -> Option<usize> {
    let Some(cols) = width.checked_add(2 * HALO) else {
        return None;
    };
    let Some(plane) = cols.checked_mul(RING) else {
        return None;
    };
    plane.checked_mul(PLANES)
}

/// Demosaics `input` into `output` (same size) with the directional method, using `scratch`
/// (at least [`scratch_len`]`(width)` samples).
///
/// ```
/// use isp_core::demosaic::directional::{directional, scratch_len};
/// use isp_core::frame::{MosaicView, RgbViewMut};
/// use isp_core::CfaPattern;
/// let flat = [1000u16; 64];
/// let mosaic = MosaicView::new(&flat, 8, 8, 8, CfaPattern::Grbg).unwrap();
/// let mut rgb = [0u16; 192];
/// let mut out = RgbViewMut::new(&mut rgb, 8, 8, 24).unwrap();
/// let mut scratch = vec![0f32; scratch_len(8).unwrap()];
/// directional(&mosaic, &mut out, &mut scratch).unwrap();
/// assert!(rgb.iter().all(|v| *v == 1000)); // a flat field stays flat
/// ```
pub fn directional<T: Sample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
    scratch: &mut [f32],
) -> Result<(), IspError> {
    directional_body(input, output, scratch)
}

/// The method itself, inlined into each entry point so each is compiled for its own target
/// features.
#[inline(always)]
fn directional_body<T: Sample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
    scratch: &mut [f32],
) -> Result<(), IspError> {
    let (w, h) = same_size(input, output)?;
    if w < 2 || h < 2 {
        return super::demosaic(Method::Bilinear, input, output);
    }
    let needed = scratch_len(w).ok_or(IspError::InvalidParameter {
        name: "width",
        allowed: "small enough that scratch_len(width) fits in usize",
    })?;
    if scratch.len() < needed {
        return Err(IspError::InvalidParameter {
            name: "scratch",
            allowed: "at least scratch_len(width) samples",
        });
    }
    let pw = w + 2 * HALO;
    let frame = Frame {
        w,
        h,
        pw,
        pattern: input.pattern(),
    };
    let mut p = Planes::split(&mut scratch[..needed], RING * pw);
    let rows = h + 2 * HALO;
    // Each stage's lag behind the mosaic row just read, and its radius (rows and columns at
    // each edge of the padded frame it cannot compute).
    for t in 0..rows + 11 {
        if t < rows {
            frame.mosaic_row(input, t, &mut p);
        }
        let valid = |lag: usize, radius: usize| {
            t.checked_sub(lag)
                .filter(|r| *r >= radius && *r + radius < rows)
        };
        if let Some(r) = valid(2, 2) {
            frame.diff_row(r, &mut p);
        }
        if let Some(r) = valid(3, 3) {
            frame.grad_row(r, &mut p);
            frame.class_row(r, &mut p);
        }
        if let Some(r) = valid(4, 4) {
            frame.sum3_row(r, &mut p);
        }
        if let Some(r) = valid(6, 6) {
            frame.green_row(r, &mut p);
        }
        if let Some(r) = valid(8, 8) {
            frame.chroma_row(r, &mut p);
        }
        if let Some(r) = t.checked_sub(11).filter(|r| (HALO..HALO + h).contains(r)) {
            frame.output_row(r, &p, output.row_mut(r - HALO));
        }
    }
    Ok(())
}

/// [`directional`] compiled for x86-64 CPUs with AVX2: eight lanes per vector instead of
/// four, the same operations in the same order, so the output is bit-identical (no FMA
/// contraction happens without fast-math).
///
/// On other targets use [`directional`].
///
/// # Safety
///
/// The CPU must support AVX2 (a function with a target feature is unsafe to call from code
/// compiled without it). Check first, as `camsim` does with
/// `is_x86_feature_detected!("avx2")`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub fn directional_avx2<T: Sample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
    scratch: &mut [f32],
) -> Result<(), IspError> {
    directional_body(input, output, scratch)
}

/// The ring buffers, each `RING` rows of `pw` samples.
struct Planes<'a> {
    mosaic: &'a mut [f32],
    diff_h: &'a mut [f32],
    diff_v: &'a mut [f32],
    grad_h: &'a mut [f32],
    grad_v: &'a mut [f32],
    /// `grad_v` summed over 3 columns.
    sum3_v: &'a mut [f32],
    /// `grad_h` summed over 3 rows.
    sum3_h: &'a mut [f32],
    green: &'a mut [f32],
    /// Horizontal/vertical classifier on the mosaic (1 = use the horizontal estimate).
    class_hv: &'a mut [f32],
    /// Diagonal classifier (1 = use the NE-SW estimate).
    class_pq: &'a mut [f32],
    red: &'a mut [f32],
    blue: &'a mut [f32],
}

impl<'a> Planes<'a> {
    fn split(scratch: &'a mut [f32], n: usize) -> Self {
        let (mosaic, rest) = scratch.split_at_mut(n);
        let (diff_h, rest) = rest.split_at_mut(n);
        let (diff_v, rest) = rest.split_at_mut(n);
        let (grad_h, rest) = rest.split_at_mut(n);
        let (grad_v, rest) = rest.split_at_mut(n);
        let (sum3_v, rest) = rest.split_at_mut(n);
        let (sum3_h, rest) = rest.split_at_mut(n);
        let (green, rest) = rest.split_at_mut(n);
        let (class_hv, rest) = rest.split_at_mut(n);
        let (class_pq, rest) = rest.split_at_mut(n);
        let (red, blue) = rest.split_at_mut(n);
        Planes {
            mosaic,
            diff_h,
            diff_v,
            grad_h,
            grad_v,
            sum3_v,
            sum3_h,
            green,
            class_hv,
            class_pq,
            red,
            blue,
        }
    }
}

/// The frame's geometry in padded coordinates (`HALO` added on every side).
struct Frame {
    w: usize,
    h: usize,
    pw: usize,
    pattern: CfaPattern,
}

/// Row `r` of a ring plane.
#[inline]
fn row(plane: &[f32], r: usize, pw: usize) -> &[f32] {
    let start = (r % RING) * pw;
    &plane[start..start + pw]
}

#[inline]
fn row_mut(plane: &mut [f32], r: usize, pw: usize) -> &mut [f32] {
    let start = (r % RING) * pw;
    &mut plane[start..start + pw]
}

/// Rows `r - N/2 ..= r + N/2` of a ring plane.
#[inline]
fn rows<const N: usize>(plane: &[f32], r: usize, pw: usize) -> [&[f32]; N] {
    core::array::from_fn(|k| row(plane, r + k - N / 2, pw))
}

/// `v` clamped to `[0, 1]`; NaN gives 0. Without a branch (`max` then `min`), so the scalar
/// rows do not mispredict on it.
#[inline(always)]
#[allow(clippy::manual_clamp)] // `clamp` keeps NaN; this must give 0
fn clamp01(v: f32) -> f32 {
    v.max(0.0).min(1.0)
}

/// The classifier at column `x` of the middle of three rows: its own value if it is more decided
/// (further from 0.5) than the mean of its four diagonal neighbours, else that mean.
#[inline(always)]
fn refined(class: [&[f32]; 3], x: usize) -> f32 {
    let own = class[1][x];
    let around = 0.25 * (class[0][x - 1] + class[0][x + 1] + class[2][x - 1] + class[2][x + 1]);
    if (0.5 - own).abs() < (0.5 - around).abs() {
        around
    } else {
        own
    }
}

/// Sum of squared first and second differences along a line of seven samples `v[0..7]`
/// centred on `v[3]`, over the three centre positions.
#[inline(always)]
fn line_stat(v: [f32; 7]) -> f32 {
    let mut s = 1e-10;
    for k in 2..5 {
        let first = v[k - 1] - v[k + 1];
        let second = 2.0 * v[k] - v[k - 2] - v[k + 2];
        s += first * first + 0.25 * second * second;
    }
    s
}

/// Inverse-gradient weighted colour difference from two opposite neighbours: `x[k]` and
/// `g[k]` are the chroma and green along the line at offsets `-3..=3` (`x` known at odd
/// offsets), `g0` the green at the centre.
#[inline(always)]
fn pair_estimate(x: [f32; 7], g: [f32; 5]) -> f32 {
    let before = EPS + (x[2] - x[4]).abs() + (x[2] - x[0]).abs() + (g[2] - g[0]).abs();
    let after = EPS + (x[4] - x[2]).abs() + (x[4] - x[6]).abs() + (g[2] - g[4]).abs();
    (after * (x[2] - g[1]) + before * (x[4] - g[3])) / (before + after)
}

impl Frame {
    /// 1.0 where padded column `x` of padded row `r` is green, else 0.0, as `(even x, odd x)`.
    fn green_mask(&self, r: usize) -> [f32; 2] {
        let is = |x: usize| f32::from(u8::from(self.pattern.colour_at(x, r) == CfaColour::Green));
        [is(0), is(1)]
    }

    fn colour(&self, x: usize, r: usize) -> CfaColour {
        self.pattern.colour_at(x & 1, r & 1)
    }

    #[inline(always)]
    fn mosaic_row<T: Sample>(&self, input: &MosaicView<'_, T>, r: usize, p: &mut Planes<'_>) {
        let src = input.row(reflect(r as isize - HALO as isize, self.h));
        let dst = row_mut(p.mosaic, r, self.pw);
        for (d, s) in dst[HALO..HALO + self.w].iter_mut().zip(src) {
            *d = s.to_unit();
        }
        for x in (0..HALO).chain(HALO + self.w..self.pw) {
            dst[x] = src[reflect(x as isize - HALO as isize, self.w)].to_unit();
        }
    }

    #[inline(always)]
    fn diff_row(&self, r: usize, p: &mut Planes<'_>) {
        let pw = self.pw;
        let m: [&[f32]; 5] = rows(p.mosaic, r, pw);
        let mask = self.green_mask(r);
        let dh = row_mut(p.diff_h, r, pw);
        for x in 2..pw - 2 {
            let sign = 2.0 * mask[x & 1] - 1.0;
            let c = m[2];
            let along = 0.5 * (c[x - 1] + c[x + 1]) + 0.25 * (2.0 * c[x] - c[x - 2] - c[x + 2]);
            dh[x] = sign * (c[x] - along);
        }
        let dv = row_mut(p.diff_v, r, pw);
        for x in 2..pw - 2 {
            let sign = 2.0 * mask[x & 1] - 1.0;
            let along = 0.5 * (m[1][x] + m[3][x]) + 0.25 * (2.0 * m[2][x] - m[0][x] - m[4][x]);
            dv[x] = sign * (m[2][x] - along);
        }
    }

    #[inline(always)]
    fn grad_row(&self, r: usize, p: &mut Planes<'_>) {
        let pw = self.pw;
        let dh = row(p.diff_h, r, pw);
        let gh = row_mut(p.grad_h, r, pw);
        for x in 3..pw - 3 {
            gh[x] = (dh[x - 1] - dh[x + 1]).abs();
        }
        let [up, _, down]: [&[f32]; 3] = rows(p.diff_v, r, pw);
        let gv = row_mut(p.grad_v, r, pw);
        for x in 3..pw - 3 {
            gv[x] = (up[x] - down[x]).abs();
        }
    }

    #[inline(always)]
    fn sum3_row(&self, r: usize, p: &mut Planes<'_>) {
        let pw = self.pw;
        let gv = row(p.grad_v, r, pw);
        let s3v = row_mut(p.sum3_v, r, pw);
        for x in 4..pw - 4 {
            s3v[x] = gv[x - 1] + gv[x] + gv[x + 1];
        }
        let gh: [&[f32]; 3] = rows(p.grad_h, r, pw);
        let s3h = row_mut(p.sum3_h, r, pw);
        for x in 4..pw - 4 {
            s3h[x] = gh[0][x] + gh[1][x] + gh[2][x];
        }
    }

    #[inline(always)]
    fn class_row(&self, r: usize, p: &mut Planes<'_>) {
        let pw = self.pw;
        let m: [&[f32]; 7] = rows(p.mosaic, r, pw);
        let hv = row_mut(p.class_hv, r, pw);
        for x in 3..pw - 3 {
            let v = line_stat(core::array::from_fn(|k| m[k][x]));
            let hz = line_stat(core::array::from_fn(|k| m[3][x + k - 3]));
            hv[x] = v / (v + hz);
        }
        let pq = row_mut(p.class_pq, r, pw);
        for x in 3..pw - 3 {
            let pp = line_stat(core::array::from_fn(|k| m[k][x + k - 3]));
            let q = line_stat(core::array::from_fn(|k| m[k][x + 3 - k]));
            pq[x] = pp / (pp + q);
        }
    }

    #[inline(always)]
    fn green_row(&self, r: usize, p: &mut Planes<'_>) {
        let pw = self.pw;
        let m: [&[f32]; 7] = rows(p.mosaic, r, pw);
        let dv: [&[f32]; 7] = rows(p.diff_v, r, pw);
        let dh = row(p.diff_h, r, pw);
        let s3v: [&[f32]; 5] = rows(p.sum3_v, r, pw);
        let s3h = row(p.sum3_h, r, pw);
        let mask = self.green_mask(r);
        let out = row_mut(p.green, r, pw);
        let c = m[3];
        for x in 6..pw - 6 {
            let sn = s3v[2][x] + s3v[1][x] + s3v[0][x];
            let ss = s3v[2][x] + s3v[3][x] + s3v[4][x];
            let sw = s3h[x] + s3h[x - 1] + s3h[x - 2];
            let se = s3h[x] + s3h[x + 1] + s3h[x + 2];
            let box_v = sn + ss - s3v[2][x];
            let box_h = sw + se - s3h[x];
            let (sv, sh) = (box_v * box_v + TINY, box_h * box_h + TINY);
            let class = sv / (sv + sh);
            let (wn, ws, ww, we) = (
                1.0 / (sn * sn + TINY),
                1.0 / (ss * ss + TINY),
                1.0 / (sw * sw + TINY),
                1.0 / (se * se + TINY),
            );
            let mut dn = 0.0;
            let mut ds = 0.0;
            let mut dw = 0.0;
            let mut de = 0.0;
            for (k, f) in SMOOTH.iter().enumerate() {
                dn += f * dv[3 - k][x];
                ds += f * dv[3 + k][x];
                dw += f * dh[x - k];
                de += f * dh[x + k];
            }
            let g_diff = c[x] + (wn * dn + ws * ds + ww * dw + we * de) / (wn + ws + ww + we);
            let col = |k: usize| m[k][x];
            let gn =
                EPS + (col(4) - col(2)).abs() + (col(3) - col(1)).abs() + (col(2) - col(0)).abs();
            let gs =
                EPS + (col(2) - col(4)).abs() + (col(3) - col(5)).abs() + (col(4) - col(6)).abs();
            let gw = EPS
                + (c[x + 1] - c[x - 1]).abs()
                + (c[x] - c[x - 2]).abs()
                + (c[x - 1] - c[x - 3]).abs();
            let ge = EPS
                + (c[x - 1] - c[x + 1]).abs()
                + (c[x] - c[x + 2]).abs()
                + (c[x + 1] - c[x + 3]).abs();
            let vertical = (gs * col(2) + gn * col(4)) / (gn + gs);
            let horizontal = (ge * c[x - 1] + gw * c[x + 1]) / (gw + ge);
            let g_plain = class * horizontal + (1.0 - class) * vertical;
            let diff_mean = sn.min(ss).min(sw.min(se)) * (1.0 / 9.0);
            let raw_mean = gn.min(gs).min(gw.min(ge)) * (1.0 / 3.0);
            let a = 0.6 + 0.35 * raw_mean / (raw_mean + 2.0 * diff_mean + 1e-9);
            let estimate = clamp01(a * g_diff + (1.0 - a) * g_plain);
            let is_green = mask[x & 1];
            out[x] = is_green * c[x] + (1.0 - is_green) * estimate;
        }
    }

    #[inline(always)]
    fn chroma_row(&self, r: usize, p: &mut Planes<'_>) {
        let pw = self.pw;
        let m: [&[f32]; 7] = rows(p.mosaic, r, pw);
        let g: [&[f32]; 5] = rows(p.green, r, pw);
        let pq: [&[f32]; 3] = rows(p.class_pq, r, pw);
        // 1.0 where the pixel is red (blue), by column parity.
        let is = |x: usize, colour: CfaColour| f32::from(u8::from(self.colour(x, r) == colour));
        let red_mask = [is(0, CfaColour::Red), is(1, CfaColour::Red)];
        let blue_mask = [is(0, CfaColour::Blue), is(1, CfaColour::Blue)];
        // A function, not a closure: a closure is not inlined into the AVX2 entry point, and
        // compiled on its own it is called per pixel with baseline instructions.
        #[inline(always)]
        fn opposite_at(m: &[&[f32]; 7], g: &[&[f32]; 5], pq: [&[f32]; 3], x: usize) -> f32 {
            let est_p = pair_estimate(
                core::array::from_fn(|k| m[k][x + k - 3]),
                core::array::from_fn(|k| g[k][x + k - 2]),
            );
            let est_q = pair_estimate(
                core::array::from_fn(|k| m[k][x + 3 - k]),
                core::array::from_fn(|k| g[k][x + 2 - k]),
            );
            let c = refined(pq, x);
            clamp01(g[2][x] + (1.0 - c) * est_p + c * est_q)
        }
        let red = row_mut(p.red, r, pw);
        let blue = row_mut(p.blue, r, pw);
        for x in 8..pw - 8 {
            let own = m[3][x];
            let opposite = opposite_at(&m, &g, pq, x);
            let (rm, bm) = (red_mask[x & 1], blue_mask[x & 1]);
            // At red: red = own, blue = opposite; at blue the reverse; at green both 0.
            red[x] = rm * own + bm * opposite;
            blue[x] = bm * own + rm * opposite;
        }
    }

    /// Red or blue (`plane`) at a green pixel from its four cardinal neighbours, steered by
    /// the refined classifier `c`. A function, not a closure, so it inlines into the AVX2
    /// entry point.
    #[inline(always)]
    fn at_green(plane: [&[f32]; 7], g: &[&[f32]; 5], c: f32, x: usize) -> f32 {
        let vertical = pair_estimate(
            core::array::from_fn(|k| plane[k][x]),
            core::array::from_fn(|k| g[k][x]),
        );
        let horizontal = pair_estimate(
            core::array::from_fn(|k| plane[3][x + k - 3]),
            core::array::from_fn(|k| g[2][x + k - 2]),
        );
        clamp01(g[2][x] + (1.0 - c) * vertical + c * horizontal)
    }

    #[inline(always)]
    fn output_row<T: Sample>(&self, r: usize, p: &Planes<'_>, out: &mut [T]) {
        let pw = self.pw;
        let m = row(p.mosaic, r, pw);
        let g: [&[f32]; 5] = rows(p.green, r, pw);
        let hv: [&[f32]; 3] = rows(p.class_hv, r, pw);
        let red: [&[f32]; 7] = rows(p.red, r, pw);
        let blue: [&[f32]; 7] = rows(p.blue, r, pw);
        let mask = self.green_mask(r);
        for (o, x) in out.chunks_exact_mut(3).zip(HALO..HALO + self.w) {
            let c = refined(hv, x);
            let rgb = if mask[x & 1] > 0.5 {
                [
                    Self::at_green(red, &g, c, x),
                    m[x],
                    Self::at_green(blue, &g, c, x),
                ]
            } else {
                [red[3][x], g[2][x], blue[3][x]]
            };
            o[0] = T::from_unit(rgb[0]);
            o[1] = T::from_unit(rgb[1]);
            o[2] = T::from_unit(rgb[2]);
        }
    }
}
