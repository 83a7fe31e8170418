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
//! Scratch: [`scratch_len`] samples for a band of `band_rows` output rows. A bigger band
//! recomputes less halo: 24 halo rows per band.

use super::{reflect, same_size, Method};
use crate::frame::{MosaicView, RgbViewMut, Sample};
use crate::{CfaColour, CfaPattern, IspError};

/// Rows and columns of context computed around each band (even, so parity is unchanged).
pub const HALO: usize = 12;
/// Planes of scratch per band.
const PLANES: usize = 12;
/// Floor of the one-sided gradients, in units of full scale.
const EPS: f32 = 1e-5;
/// Keeps divisions by squared sums finite on flat fields.
const TINY: f32 = 1e-20;
/// One-sided smoothing of the colour differences, centre first.
const SMOOTH: [f32; 4] = [0.56, 0.35, 0.08, 0.01];

/// Scratch samples [`directional`] needs to process a frame `width` wide in bands of
/// `band_rows` output rows; `None` on overflow.
///
/// ```
/// use isp_core::demosaic::directional::{scratch_len, HALO};
/// assert_eq!(scratch_len(100, 8), Some(12 * (8 + 2 * HALO) * (100 + 2 * HALO)));
/// ```
pub const fn scratch_len(width: usize, band_rows: usize) -> Option<usize> {
    let Some(rows) = band_rows.checked_add(2 * HALO) else {
        return None;
    };
    let Some(cols) = width.checked_add(2 * HALO) else {
        return None;
    };
    let Some(plane) = rows.checked_mul(cols) else {
        return None;
    };
    plane.checked_mul(PLANES)
}

/// Demosaics `input` into `output` (same size) with the directional method, using `scratch`
/// (at least [`scratch_len`]`(width, 1)` samples; the band height is whatever fits).
///
/// ```
/// use isp_core::demosaic::directional::{directional, scratch_len};
/// use isp_core::frame::{MosaicView, RgbViewMut};
/// use isp_core::CfaPattern;
/// let flat = [1000u16; 64];
/// let mosaic = MosaicView::new(&flat, 8, 8, 8, CfaPattern::Grbg).unwrap();
/// let mut rgb = [0u16; 192];
/// let mut out = RgbViewMut::new(&mut rgb, 8, 8, 24).unwrap();
/// let mut scratch = vec![0f32; scratch_len(8, 8).unwrap()];
/// directional(&mosaic, &mut out, &mut scratch).unwrap();
/// assert!(rgb.iter().all(|v| *v == 1000)); // a flat field stays flat
/// ```
pub fn directional<T: Sample>(
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
    scratch: &mut [f32],
) -> Result<(), IspError> {
    let (w, h) = same_size(input, output)?;
    if w < 2 || h < 2 {
        return super::demosaic(Method::Bilinear, input, output);
    }
    let pw = w + 2 * HALO;
    let fits = scratch.len() / (PLANES * pw);
    if fits <= 2 * HALO {
        return Err(IspError::InvalidParameter {
            name: "scratch",
            allowed: "at least scratch_len(width, 1) samples",
        });
    }
    let band = (fits - 2 * HALO).min(h);
    let plane_len = (band + 2 * HALO) * pw;
    let mut y0 = 0;
    while y0 < h {
        let rows = band.min(h - y0);
        let planes = Planes::split(&mut scratch[..PLANES * plane_len], plane_len);
        let geometry = Band {
            y0,
            rows,
            w,
            h,
            pw,
            pattern: input.pattern(),
        };
        geometry.run(input, output, planes);
        y0 += rows;
    }
    Ok(())
}

/// The scratch planes of one band, each `(rows + 2 * HALO) * pw` samples.
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

/// Where a band sits in the frame.
struct Band {
    y0: usize,
    rows: usize,
    w: usize,
    h: usize,
    pw: usize,
    pattern: CfaPattern,
}

#[inline]
fn clamp01(v: f32) -> f32 {
    if v > 0.0 {
        v.min(1.0)
    } else {
        0.0
    }
}

/// `own` if it is more decided (further from 0.5) than the mean of its diagonal neighbours,
/// else that mean.
#[inline]
fn refined(plane: &[f32], i: usize, pw: usize) -> f32 {
    let own = plane[i];
    let around =
        0.25 * (plane[i - pw - 1] + plane[i - pw + 1] + plane[i + pw - 1] + plane[i + pw + 1]);
    if (0.5 - own).abs() < (0.5 - around).abs() {
        around
    } else {
        own
    }
}

/// Sum of squared first and second differences along offset `d`, over the three pixels
/// `i - d`, `i`, `i + d`.
#[inline]
fn direction_stat(m: &[f32], i: usize, d: usize) -> f32 {
    let mut s = 1e-10;
    for k in [i - d, i, i + d] {
        let first = m[k - d] - m[k + d];
        let second = 2.0 * m[k] - m[k - 2 * d] - m[k + 2 * d];
        s += first * first + 0.25 * second * second;
    }
    s
}

/// Inverse-gradient weighted colour difference `x - g` from the pair of neighbours `i - d` and
/// `i + d` (`x` known there), with gradients reaching `3 d` in `x` and `2 d` in `g`.
#[inline]
fn pair_estimate(x: &[f32], g: &[f32], i: usize, d: usize) -> f32 {
    let grad = |fwd: bool| {
        let (n, far, g2) = if fwd {
            (i + d, i + 3 * d, i + 2 * d)
        } else {
            (i - d, i - 3 * d, i - 2 * d)
        };
        let opposite = if fwd { i - d } else { i + d };
        EPS + (x[n] - x[opposite]).abs() + (x[n] - x[far]).abs() + (g[i] - g[g2]).abs()
    };
    let (before, after) = (grad(false), grad(true));
    let est_before = x[i - d] - g[i - d];
    let est_after = x[i + d] - g[i + d];
    (after * est_before + before * est_after) / (before + after)
}

impl Band {
    fn colour(&self, x: usize, r: usize) -> CfaColour {
        // HALO is even, so band coordinates have the frame's parity.
        self.pattern.colour_at(x & 1, (self.y0 + r) & 1)
    }

    fn run<T: Sample>(
        &self,
        input: &MosaicView<'_, T>,
        output: &mut RgbViewMut<'_, T>,
        p: Planes<'_>,
    ) {
        let pw = self.pw;
        let rr = self.rows + 2 * HALO;
        // Stage 0: the mosaic, reflected at the frame edges.
        for r in 0..rr {
            let src = input.row(reflect(
                self.y0 as isize + r as isize - HALO as isize,
                self.h,
            ));
            let dst = &mut p.mosaic[r * pw..(r + 1) * pw];
            for (x, v) in dst.iter_mut().enumerate() {
                *v = src[reflect(x as isize - HALO as isize, self.w)].to_unit();
            }
        }
        let m = &*p.mosaic;
        let span =
            |rad: usize| (rad..rr - rad).flat_map(move |r| (rad..pw - rad).map(move |x| (r, x)));

        // Stage 1: directional colour differences G - C.
        for (r, x) in span(2) {
            let i = r * pw + x;
            let sign = if self.colour(x, r) == CfaColour::Green {
                1.0
            } else {
                -1.0
            };
            let along = |d: usize| {
                0.5 * (m[i - d] + m[i + d]) + 0.25 * (2.0 * m[i] - m[i - 2 * d] - m[i + 2 * d])
            };
            p.diff_h[i] = sign * (m[i] - along(1));
            p.diff_v[i] = sign * (m[i] - along(pw));
        }
        // Stage 2: their gradients.
        for (r, x) in span(3) {
            let i = r * pw + x;
            p.grad_h[i] = (p.diff_h[i - 1] - p.diff_h[i + 1]).abs();
            p.grad_v[i] = (p.diff_v[i - pw] - p.diff_v[i + pw]).abs();
        }
        for (r, x) in span(4) {
            let i = r * pw + x;
            p.sum3_v[i] = p.grad_v[i - 1] + p.grad_v[i] + p.grad_v[i + 1];
            p.sum3_h[i] = p.grad_h[i - pw] + p.grad_h[i] + p.grad_h[i + pw];
        }
        // Stage 3: green.
        let (dh, dv, s3v, s3h) = (&*p.diff_h, &*p.diff_v, &*p.sum3_v, &*p.sum3_h);
        for (r, x) in span(6) {
            let i = r * pw + x;
            if self.colour(x, r) == CfaColour::Green {
                p.green[i] = m[i];
                continue;
            }
            let sn = s3v[i] + s3v[i - pw] + s3v[i - 2 * pw];
            let ss = s3v[i] + s3v[i + pw] + s3v[i + 2 * pw];
            let sw = s3h[i] + s3h[i - 1] + s3h[i - 2];
            let se = s3h[i] + s3h[i + 1] + s3h[i + 2];
            let sv = (sn + ss - s3v[i]) * (sn + ss - s3v[i]) + TINY;
            let sh = (sw + se - s3h[i]) * (sw + se - s3h[i]) + TINY;
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
                dn += f * dv[i - k * pw];
                ds += f * dv[i + k * pw];
                dw += f * dh[i - k];
                de += f * dh[i + k];
            }
            let g_diff = m[i] + (wn * dn + ws * ds + ww * dw + we * de) / (wn + ws + ww + we);
            let half = |d: usize, fwd: bool| {
                let (n, n2, n3) = if fwd {
                    (i + d, i + 2 * d, i + 3 * d)
                } else {
                    (i - d, i - 2 * d, i - 3 * d)
                };
                let opposite = if fwd { i - d } else { i + d };
                EPS + (m[opposite] - m[n]).abs() + (m[i] - m[n2]).abs() + (m[n] - m[n3]).abs()
            };
            let (gn, gs, gw, ge) = (
                half(pw, false),
                half(pw, true),
                half(1, false),
                half(1, true),
            );
            let vertical = (gs * m[i - pw] + gn * m[i + pw]) / (gn + gs);
            let horizontal = (ge * m[i - 1] + gw * m[i + 1]) / (gw + ge);
            let g_plain = class * horizontal + (1.0 - class) * vertical;
            let diff_mean = sn.min(ss).min(sw.min(se)) / 9.0;
            let raw_mean = gn.min(gs).min(gw.min(ge)) / 3.0;
            let a = 0.6 + 0.35 * raw_mean / (raw_mean + 2.0 * diff_mean + 1e-9);
            p.green[i] = clamp01(a * g_diff + (1.0 - a) * g_plain);
        }
        // Stage 4: classifiers on the mosaic.
        for (r, x) in span(3) {
            let i = r * pw + x;
            let v = direction_stat(m, i, pw);
            let hz = direction_stat(m, i, 1);
            p.class_hv[i] = v / (v + hz);
            let pp = direction_stat(m, i, pw + 1);
            let q = direction_stat(m, i, pw - 1);
            p.class_pq[i] = pp / (pp + q);
        }
        // Stage 5: the opposite chroma at R and B.
        let g = &*p.green;
        let (class_hv, class_pq) = (&*p.class_hv, &*p.class_pq);
        for (r, x) in span(8) {
            let i = r * pw + x;
            let colour = self.colour(x, r);
            let (own_red, own_blue) = match colour {
                CfaColour::Green => {
                    p.red[i] = 0.0;
                    p.blue[i] = 0.0;
                    continue;
                }
                CfaColour::Red => (true, false),
                CfaColour::Blue => (false, true),
            };
            let est_p = pair_estimate(m, g, i, pw + 1);
            let est_q = pair_estimate(m, g, i, pw - 1);
            let c = refined(class_pq, i, pw);
            let opposite = clamp01(g[i] + (1.0 - c) * est_p + c * est_q);
            p.red[i] = if own_red { m[i] } else { opposite };
            p.blue[i] = if own_blue { m[i] } else { opposite };
        }
        // Stage 6: R and B at G, and the output.
        let (red, blue) = (&*p.red, &*p.blue);
        for r in HALO..HALO + self.rows {
            let out = output.row_mut(self.y0 + r - HALO);
            for x in HALO..HALO + self.w {
                let i = r * pw + x;
                let rgb = match self.colour(x, r) {
                    CfaColour::Green => {
                        let c = refined(class_hv, i, pw);
                        let at_g = |plane: &[f32]| {
                            let vertical = pair_estimate(plane, g, i, pw);
                            let horizontal = pair_estimate(plane, g, i, 1);
                            clamp01(g[i] + (1.0 - c) * vertical + c * horizontal)
                        };
                        [at_g(red), m[i], at_g(blue)]
                    }
                    _ => [red[i], g[i], blue[i]],
                };
                let o = 3 * (x - HALO);
                out[o] = T::from_unit(rgb[0]);
                out[o + 1] = T::from_unit(rgb[1]);
                out[o + 2] = T::from_unit(rgb[2]);
            }
        }
    }
}
