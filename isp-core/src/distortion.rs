//! Lens distortion correction: each output pixel is resampled from where the lens put it, through
//! optics-core's Brown-Conrady model ([`BrownConrady`], OpenCV's 5-coefficient convention), with
//! bilinear interpolation. With the same camera matrix and coefficients the result is OpenCV's
//! `cv2.undistort` (`initUndistortRectifyMap` into 1/32-pixel maps, then `remap` with
//! `INTER_LINEAR` and a black constant border), to 1 LSB.
//!
//! # Semantics
//!
//! For output pixel `(u, v)`, in `f64`:
//!
//! ```text
//! x  = (u - cx) / fx,  y = (v - cy) / fy        the ideal ray, normalised
//! xd, yd = BrownConrady::distort(x, y)          where the lens images it
//! qx = rint(32 (fx xd + cx)),  qy = rint(32 (fy yd + cy))   source position in 1/32 pixel
//! ```
//!
//! (`rint` rounds half to even). With `(x0, y0) = (qx >> 5, qy >> 5)` and the fractions
//! `(ax, ay) = (qx & 31, qy & 31)`, the output is the weighted sum of the four pixels
//! `(x0, y0)`, `(x0 + 1, y0)`, `(x0, y0 + 1)`, `(x0 + 1, y0 + 1)` with the integer weights
//! `(32 - ax)(32 - ay)`, `ax (32 - ay)`, `(32 - ax) ay`, `ax ay` (they sum to 1024), divided by
//! 1024: rounded half up for `u8` and `u16` samples, exact for `f32`. A pixel off the image
//! reads 0 (black), so corners the lens never covered come out black, as in OpenCV. A source
//! position that is not finite or beyond `2^30 / 32` pixels reads only black.
//!
//! Quantising the position to 1/32 pixel is what OpenCV does and what firmware warpers do; it
//! makes the weights small exact integers, so the integer path is exact up to its final
//! rounding, and it is why the float and fixed pipelines agree here bit for bit in position.
//!
//! # Streaming
//!
//! Output row `v` reads a bounded window of input rows, [`LensDistortion::source_rows`]; the
//! tallest window over a frame is [`LensDistortion::window_rows`], which sizes the pipeline's
//! line buffers. It grows with the distortion: a few rows for a mild lens, tens for strong
//! barrel distortion at the corners of a large frame.
//!
//! ```
//! use isp_core::distortion::{BrownConrady, LensDistortion};
//! use isp_core::frame::{RgbView, RgbViewMut};
//! // Mild barrel distortion on a 64x48 frame.
//! let lens = LensDistortion::new(64.0, 64.0, 31.5, 23.5, BrownConrady::from_opencv([-0.1, 0.0, 0.0, 0.0, 0.0]).unwrap()).unwrap();
//! let src = vec![200u8; 64 * 48 * 3];
//! let mut dst = vec![0u8; 64 * 48 * 3];
//! lens.correct(&RgbView::new(&src, 64, 48, 192).unwrap(), &mut RgbViewMut::new(&mut dst, 64, 48, 192).unwrap()).unwrap();
//! // The centre samples the flat field; a flat field stays flat wherever the lens covered.
//! assert_eq!(dst[(24 * 64 + 32) * 3], 200);
//! assert!(lens.window_rows(64, 48) <= 4);
//! ```

use core::ops::RangeInclusive;

pub use optics_core::distortion::BrownConrady;

use crate::frame::{RgbView, RgbViewMut, Sample};
use crate::IspError;

/// Fractional bits of source positions (OpenCV's `INTER_BITS`): 1/32 pixel.
pub const SUBPIXEL_BITS: u32 = 5;
const SUBPIXELS: i32 = 1 << SUBPIXEL_BITS;
const FRACTION_MASK: i32 = SUBPIXELS - 1;
/// The four bilinear weights sum to `2^WEIGHT_BITS`.
const WEIGHT_BITS: u32 = 2 * SUBPIXEL_BITS;
/// Largest source position magnitude in 1/32 pixel; beyond it a pixel reads black.
const MAX_POSITION: f64 = (1u32 << 30) as f64;

/// `x` rounded to the nearest integer, ties to even, for `|x| < 2^30`: adding and subtracting
/// 1.5 * 2^52 leaves no fraction bits, so the FPU's default rounding does it (libm's `rint`
/// does the same in software, several times slower).
#[inline]
fn round_half_even(x: f64) -> i32 {
    const SHIFTER: f64 = 6_755_399_441_055_744.0;
    ((x + SHIFTER) - SHIFTER) as i32
}

/// A lens's distortion and the camera matrix it was calibrated with (focal lengths and
/// principal point in pixels of the frame being corrected).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LensDistortion {
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    model: BrownConrady<f64>,
}

impl LensDistortion {
    /// From OpenCV's camera matrix entries `fx`, `fy` (positive), `cx`, `cy` (finite) and the
    /// distortion model.
    pub fn new(
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        model: BrownConrady<f64>,
    ) -> Result<Self, IspError> {
        if !(fx.is_finite() && fx > 0.0 && fy.is_finite() && fy > 0.0) {
            return Err(IspError::InvalidParameter {
                name: "focal length (fx, fy)",
                allowed: "finite and > 0, in pixels",
            });
        }
        if !(cx.is_finite() && cy.is_finite()) {
            return Err(IspError::InvalidParameter {
                name: "principal point (cx, cy)",
                allowed: "finite, in pixels",
            });
        }
        Ok(Self {
            fx,
            fy,
            cx,
            cy,
            model,
        })
    }

    /// The camera matrix entries `[fx, fy, cx, cy]`.
    pub fn camera(&self) -> [f64; 4] {
        [self.fx, self.fy, self.cx, self.cy]
    }

    /// The distortion model.
    pub fn model(&self) -> BrownConrady<f64> {
        self.model
    }

    /// Whether correction changes nothing (every coefficient zero).
    pub fn is_identity(&self) -> bool {
        self.model.is_identity()
    }

    /// Where output pixel `(u, v)` samples the input, in 1/32 pixel, or `None` when the lens
    /// maps it nowhere usable (not finite, or too far off the image).
    #[inline]
    pub fn source_position(&self, u: usize, v: usize) -> Option<[i32; 2]> {
        let x = (u as f64 - self.cx) / self.fx;
        let y = (v as f64 - self.cy) / self.fy;
        let [xd, yd] = self.model.distort([x, y]).ok()?;
        let qx = f64::from(SUBPIXELS) * (self.fx * xd + self.cx);
        let qy = f64::from(SUBPIXELS) * (self.fy * yd + self.cy);
        // Also false for NaN.
        if qx.abs() < MAX_POSITION && qy.abs() < MAX_POSITION {
            Some([round_half_even(qx), round_half_even(qy)])
        } else {
            None
        }
    }

    /// The input rows output row `v` reads (taps off the image excluded), or `None` when the
    /// whole row is black.
    pub fn source_rows(
        &self,
        v: usize,
        width: usize,
        height: usize,
    ) -> Option<RangeInclusive<usize>> {
        let (mut lo, mut hi) = (usize::MAX, 0usize);
        for u in 0..width {
            let Some([qx, qy]) = self.source_position(u, v) else {
                continue;
            };
            let (x0, y0) = (qx >> SUBPIXEL_BITS, qy >> SUBPIXEL_BITS);
            if x0 + 1 < 0 || x0 as i64 >= width as i64 {
                continue;
            }
            for yi in [y0, y0 + 1] {
                if yi >= 0 && (yi as i64) < height as i64 {
                    lo = lo.min(yi as usize);
                    hi = hi.max(yi as usize);
                }
            }
        }
        (lo <= hi).then_some(lo..=hi)
    }

    /// The most input rows any output row of a `width` x `height` frame reads (0 when the lens
    /// shows nothing of the frame): the line buffers the correction needs. Evaluates the model
    /// at every pixel once.
    pub fn window_rows(&self, width: usize, height: usize) -> usize {
        (0..height)
            .filter_map(|v| self.source_rows(v, width, height))
            .map(|r| r.end() - r.start() + 1)
            .max()
            .unwrap_or(0)
    }

    /// Output row `v` (`3 * width` samples) of a `width` x `height` frame, reading input row
    /// `y` through `row(y)` (`3 * width` samples) for `y` in [`Self::source_rows`] only.
    pub(crate) fn correct_row<'r, T: Sample>(
        &self,
        v: usize,
        width: usize,
        height: usize,
        row: impl Fn(usize) -> &'r [T],
        out: &mut [T],
    ) {
        let (w, h) = (width as i64, height as i64);
        for (u, px) in out.chunks_exact_mut(3).enumerate().take(width) {
            let Some([qx, qy]) = self.source_position(u, v) else {
                px.fill(T::default());
                continue;
            };
            let (x0, y0) = (qx >> SUBPIXEL_BITS, qy >> SUBPIXEL_BITS);
            // Both columns off the frame: black, and no row is read (as in `source_rows`).
            if x0 + 1 < 0 || i64::from(x0) >= w {
                px.fill(T::default());
                continue;
            }
            let (ax, ay) = (qx & FRACTION_MASK, qy & FRACTION_MASK);
            let mut acc = [T::Acc::default(); 3];
            for (yi, wy) in [(y0, SUBPIXELS - ay), (y0 + 1, ay)] {
                if yi < 0 || i64::from(yi) >= h {
                    continue;
                }
                let src = row(yi as usize);
                for (xi, wx) in [(x0, SUBPIXELS - ax), (x0 + 1, ax)] {
                    if xi < 0 || i64::from(xi) >= w {
                        continue;
                    }
                    let i = 3 * xi as usize;
                    for c in 0..3 {
                        acc[c] = acc[c] + src[i + c].weighted(wx * wy);
                    }
                }
            }
            for c in 0..3 {
                px[c] = T::scaled_down(acc[c], WEIGHT_BITS);
            }
        }
    }

    /// Corrects a whole image: `dst` must have `src`'s size.
    pub fn correct<T: Sample>(
        &self,
        src: &RgbView<'_, T>,
        dst: &mut RgbViewMut<'_, T>,
    ) -> Result<(), IspError> {
        let (w, h) = (src.width(), src.height());
        if dst.width() != w || dst.height() != h {
            return Err(IspError::InvalidParameter {
                name: "output",
                allowed: "the input's width and height",
            });
        }
        for v in 0..h {
            // Rows of a checked view below its height always exist; an empty slice is never read.
            let row = |y: usize| src.row(y).unwrap_or(&[]);
            self.correct_row(v, w, h, row, dst.row_mut(v));
        }
        Ok(())
    }
}
