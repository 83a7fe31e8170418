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

use core::ops::{Range, RangeInclusive};

pub use optics_core::distortion::BrownConrady;

use crate::frame::{RgbView, RgbViewMut, Sample};
use crate::lateral_colour::{clamped_taps, LateralColour};
use crate::IspError;

/// Fractional bits of source positions (OpenCV's `INTER_BITS`): 1/32 pixel.
pub const SUBPIXEL_BITS: u32 = 5;
const SUBPIXELS: i32 = 1 << SUBPIXEL_BITS;
const FRACTION_MASK: i32 = SUBPIXELS - 1;
/// The four bilinear weights sum to `2^WEIGHT_BITS`.
const WEIGHT_BITS: u32 = 2 * SUBPIXEL_BITS;
/// Largest source position magnitude in 1/32 pixel; beyond it a pixel reads black.
const MAX_POSITION: f64 = (1u32 << 30) as f64;
/// Largest side of a mesh cell in pixels: a node every 16 pixels each way.
pub const MESH_CELL: usize = 16;
const CELL_BITS: u32 = 4;
/// The most the mesh's position may be off the exact model, in pixels, when
/// [`LensDistortion::fitted`] picks its cell: 1/32 pixel, the resampling's own step, with a
/// margin of two for the estimate.
const MESH_TOLERANCE: f64 = 1.0 / 64.0;
/// Fractional bits of a mesh node's position: 1/256 pixel.
pub const NODE_BITS: u32 = 8;
/// A mesh node the model maps nowhere usable (not finite, or 2^18 pixels or more away): the
/// pixels of the cells around it read black.
pub const NO_NODE: i32 = i32::MIN;
/// Largest node position magnitude in pixels: anything further is off every frame, and the
/// bound keeps a node below 2^26 and a row of interpolated nodes below 2^30.
const NODE_LIMIT: f64 = (1u32 << 18) as f64;
/// Cells of one strip of the helpers that hold node rows on the stack (1024 columns).
const STRIP_CELLS: usize = 64;

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
    /// The mesh's cell side, `2^cell_bits` pixels (16 unless [`LensDistortion::fitted`]).
    cell_bits: u32,
    /// Lateral colour corrected in the same resampling, or `None`.
    lateral_colour: Option<LateralColour>,
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
            cell_bits: CELL_BITS,
            lateral_colour: None,
        })
    }

    /// Lateral colour corrected on a frame without distortion correction: the identity model
    /// about `lca`'s centre, `lca` composed with it (see
    /// [`LensDistortion::with_lateral_colour`]).
    pub fn lateral_colour_only(lca: LateralColour) -> Self {
        let [cx, cy] = lca.centre();
        Self {
            // Any focal length maps the identity model's ideal rays to themselves.
            fx: 1.0,
            fy: 1.0,
            cx,
            cy,
            model: BrownConrady::default(),
            cell_bits: CELL_BITS,
            lateral_colour: (!lca.is_identity()).then_some(lca),
        }
    }

    /// The same lens with lateral colour corrected in the same resampling: green is read where
    /// the mesh puts it, red and blue where [`LateralColour::map_position`] moves green's
    /// position (so the colours are aligned in the lens's own, distorted image, where the
    /// prescription's scales were taken, and then undistorted together). One bilinear blend per
    /// colour, not two; red's and blue's taps beyond the frame read its edge, and a pixel whose
    /// green reads nothing of the frame is black in every colour. A `lca` with every scale 1
    /// is dropped.
    pub fn with_lateral_colour(mut self, lca: LateralColour) -> Self {
        self.lateral_colour = (!lca.is_identity()).then_some(lca);
        self
    }

    /// The lateral-colour correction composed with this lens, if any.
    pub fn lateral_colour(&self) -> Option<&LateralColour> {
        self.lateral_colour.as_ref()
    }

    /// The same lens with its mesh's cell fitted to a `width` x `height` frame: the largest of
    /// 16, 8, 4, 2 and 1 pixels whose estimated position error is at most 1/64 pixel (so the
    /// mesh stays within 1/32 of the exact model; tested). The estimate is the error of the
    /// 16-pixel mesh at each cell's centre and the midpoints of its top and left edges (where a
    /// bilinear interpolation is furthest off), scaled by the square of the cell's side (the
    /// error of a bilinear interpolation goes as the square of its step). Evaluates the model
    /// about four times per 16x16 pixels, once, when a pipeline is configured for a frame; a
    /// lens that covers its frame in focal lengths of a thousand pixels or more keeps cells of
    /// 16, a small frame's lens takes finer ones.
    pub fn fitted(mut self, width: usize, height: usize) -> Self {
        self.cell_bits = CELL_BITS;
        let worst = self.mesh_error_estimate(width, height);
        while self.cell_bits > 0
            && worst / f64::from(1u32 << (2 * (CELL_BITS - self.cell_bits))) > MESH_TOLERANCE
        {
            self.cell_bits -= 1;
        }
        self
    }

    /// The mesh's cell side in pixels (16 unless [`LensDistortion::fitted`] chose finer).
    pub fn mesh_cell(&self) -> usize {
        1 << self.cell_bits
    }

    /// The 16-pixel mesh's largest error against the exact model at the centres and the top
    /// and left edge midpoints of the cells over a `width` x `height` frame, in pixels
    /// (infinite where the model fails on a node of a cell, which then reads black anyway).
    fn mesh_error_estimate(&self, width: usize, height: usize) -> f64 {
        let coarse = Self {
            cell_bits: CELL_BITS,
            ..*self
        };
        let exact = |u: f64, v: f64| -> Option<[f64; 2]> {
            let [xd, yd] = self
                .model
                .distort([(u - self.cx) / self.fx, (v - self.cy) / self.fy])
                .ok()?;
            Some([self.fx * xd + self.cx, self.fy * yd + self.cy])
        };
        let node = |i: usize, j: usize| exact((i * MESH_CELL) as f64, (j * MESH_CELL) as f64);
        let cell = MESH_CELL as f64;
        let mut worst = 0.0f64;
        for j in 0..coarse.mesh_columns(height) - 1 {
            for i in 0..coarse.mesh_columns(width) - 1 {
                let (Some(a), Some(b), Some(c), Some(d)) = (
                    node(i, j),
                    node(i + 1, j),
                    node(i, j + 1),
                    node(i + 1, j + 1),
                ) else {
                    continue;
                };
                let (u0, v0) = (i as f64 * cell, j as f64 * cell);
                // (s, t) in the cell: centre, top edge's middle, left edge's middle.
                for (s, t) in [(0.5, 0.5), (0.5, 0.0), (0.0, 0.5)] {
                    let Some(e) = exact(u0 + s * cell, v0 + t * cell) else {
                        continue;
                    };
                    for k in 0..2 {
                        let m = (1.0 - t) * ((1.0 - s) * a[k] + s * b[k])
                            + t * ((1.0 - s) * c[k] + s * d[k]);
                        let error = (m - e[k]).abs();
                        // NaN (a wild model) counts as the largest error.
                        worst = if error.is_nan() {
                            f64::INFINITY
                        } else {
                            worst.max(error)
                        };
                    }
                }
            }
        }
        worst
    }

    /// The camera matrix entries `[fx, fy, cx, cy]`.
    pub fn camera(&self) -> [f64; 4] {
        [self.fx, self.fy, self.cx, self.cy]
    }

    /// The distortion model.
    pub fn model(&self) -> BrownConrady<f64> {
        self.model
    }

    /// Whether correction changes nothing (every coefficient zero and no lateral colour).
    pub fn is_identity(&self) -> bool {
        self.model.is_identity() && self.lateral_colour.is_none()
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

    /// Mesh nodes across a frame `width` wide: one every [`LensDistortion::mesh_cell`] pixels
    /// from column 0, through the right edge of the last column's cell. (The same for rows and
    /// the height.)
    pub fn mesh_columns(&self, width: usize) -> usize {
        (width.saturating_sub(1) >> self.cell_bits) + 2
    }

    /// Mesh node `(i, j)`: where the lens put pixel `(i c, j c)` (`c` the cell's side) by the
    /// exact model, in 1/256 pixel (nearest, ties to even), or `[NO_NODE; 2]`.
    pub fn mesh_node(&self, i: usize, j: usize) -> [i32; 2] {
        let x = ((i << self.cell_bits) as f64 - self.cx) / self.fx;
        let y = ((j << self.cell_bits) as f64 - self.cy) / self.fy;
        let Ok([xd, yd]) = self.model.distort([x, y]) else {
            return [NO_NODE; 2];
        };
        let (px, py) = (self.fx * xd + self.cx, self.fy * yd + self.cy);
        // Also false for NaN.
        if px.abs() < NODE_LIMIT && py.abs() < NODE_LIMIT {
            let scale = f64::from(1u32 << NODE_BITS);
            [round_half_even(px * scale), round_half_even(py * scale)]
        } else {
            [NO_NODE; 2]
        }
    }

    /// Nodes `first..` of mesh row `j` into `out`, two elements (x, y) a node, as many nodes
    /// as `out` holds.
    pub fn mesh_row(&self, j: usize, first: usize, out: &mut [i32]) {
        for (i, node) in out.chunks_exact_mut(2).enumerate() {
            node.copy_from_slice(&self.mesh_node(first + i, j));
        }
    }

    /// Where output pixel `(u, v)` samples the input by the mesh, in 1/32 pixel, or `None`
    /// where a node of its cell is unusable: the nodes of its cell (`i = u / c`, `j = v / c`,
    /// `c` the cell's side) interpolated bilinearly with the integer weights `(c - fu, fu)` and
    /// `(c - fv, fv)` (`fu = u mod c`, `fv = v mod c`), then rounded to 1/32 pixel (half up).
    /// The correction computes the same a row at a time; this is the definition, for tests and
    /// single pixels.
    pub fn mesh_position(&self, u: usize, v: usize) -> Option<[i32; 2]> {
        let b = self.cell_bits;
        let (mut top, mut bottom, mut row) = ([0i32; 4], [0i32; 4], [0i32; 4]);
        self.mesh_row(v >> b, u >> b, &mut top);
        self.mesh_row((v >> b) + 1, u >> b, &mut bottom);
        interpolate_rows(b, &top, &bottom, v, &mut row);
        row_position(b, &row, u & ((1 << b) - 1))
    }

    /// The mesh's position of output pixel `(u, v)` before its rounding to 1/32, in pixels, for
    /// measuring the mesh against the exact model.
    pub fn mesh_position_unrounded(&self, u: usize, v: usize) -> Option<[f64; 2]> {
        let b = self.cell_bits;
        let (mut top, mut bottom, mut row) = ([0i32; 4], [0i32; 4], [0i32; 4]);
        self.mesh_row(v >> b, u >> b, &mut top);
        self.mesh_row((v >> b) + 1, u >> b, &mut bottom);
        interpolate_rows(b, &top, &bottom, v, &mut row);
        if row.contains(&NO_NODE) {
            return None;
        }
        let (c, fu) = (f64::from(1u32 << b), (u & ((1 << b) - 1)) as f64);
        let scale = f64::from(1u32 << (2 * b + NODE_BITS));
        Some([0, 1].map(|k| ((c - fu) * f64::from(row[k]) + fu * f64::from(row[2 + k])) / scale))
    }

    /// Widens `bounds` to the lowest and highest input rows (clipped to the frame) that any
    /// usable node of a row of interpolated nodes points into, with the next row: a bound on
    /// what an output row reads, since a position between two nodes lies between theirs.
    /// `reach` rows more each way for red and blue ([`LensDistortion::colour_reach`]).
    pub(crate) fn node_row_bounds(
        &self,
        row: &[i32],
        height: usize,
        reach: i64,
        bounds: &mut (i64, i64),
    ) {
        for node in row.chunks_exact(2) {
            if node[1] == NO_NODE {
                continue;
            }
            let q = round_row(self.cell_bits, i64::from(node[1]) << self.cell_bits);
            let y0 = i64::from(q >> SUBPIXEL_BITS);
            bounds.0 = bounds.0.min((y0 - reach).max(0));
            bounds.1 = bounds.1.max((y0 + 1 + reach).min(height as i64 - 1));
        }
    }

    /// The rows red and blue may read beyond green's, in a `width` x `height` frame: 0
    /// without lateral colour.
    pub(crate) fn colour_reach(&self, width: usize, height: usize) -> i64 {
        self.lateral_colour
            .map_or(0, |lca| lca.reach_rows_in(width, height) as i64)
    }

    /// The three colours' bilinear sums for a pixel whose green is read at `q`, with the
    /// lateral-colour correction `lca` (see [`LensDistortion::with_lateral_colour`]); `read`
    /// gives a colour at a column and row of the frame.
    #[inline(always)]
    pub(crate) fn colour_pixel<T: Sample>(
        lca: &LateralColour,
        q: Option<[i32; 2]>,
        width: usize,
        height: usize,
        read: impl Fn(usize, usize, usize) -> T,
    ) -> [T::Acc; 3] {
        let mut acc = [T::Acc::default(); 3];
        let Some(q) = q else {
            return acc;
        };
        let green = taps(q, width, height);
        if green.iter().all(Option::is_none) {
            return acc;
        }
        for (xi, yi, weight) in green.into_iter().flatten() {
            acc[1] = acc[1] + read(xi, yi, 1).weighted(weight);
        }
        let q = [i64::from(q[0]), i64::from(q[1])];
        for (k, c) in [(0, 0), (1, 2)] {
            for (xi, yi, weight) in clamped_taps(lca.map_position(k, q), width, height) {
                acc[c] = acc[c] + read(xi, yi, c).weighted(weight);
            }
        }
        acc
    }

    /// The input rows output row `v` reads (a bound from its cell row's nodes, see
    /// `LensDistortion::node_row_bounds`), or `None` when the row reads nothing of the
    /// frame. Evaluates the model at the nodes of `v`'s cell row.
    pub fn source_rows(
        &self,
        v: usize,
        width: usize,
        height: usize,
    ) -> Option<RangeInclusive<usize>> {
        let b = self.cell_bits;
        let reach = self.colour_reach(width, height);
        let mut bounds = (i64::MAX, i64::MIN);
        let (mut top, mut bottom, mut row) = strip_rows();
        for (first, n) in self.strips(width) {
            self.mesh_row(v >> b, first, &mut top[..n]);
            self.mesh_row((v >> b) + 1, first, &mut bottom[..n]);
            interpolate_rows(b, &top[..n], &bottom[..n], v, &mut row[..n]);
            self.node_row_bounds(&row[..n], height, reach, &mut bounds);
        }
        (bounds.0 <= bounds.1).then_some(bounds.0 as usize..=bounds.1 as usize)
    }

    /// The most input rows any output row of a `width` x `height` frame reads (0 when the lens
    /// shows nothing of the frame): the line buffers the correction needs. Evaluates the model
    /// at every mesh node twice.
    pub fn window_rows(&self, width: usize, height: usize) -> usize {
        self.window_rows_in(width, height, 0..height)
    }

    /// [`LensDistortion::window_rows`] over output rows `rows` alone (a band's).
    pub fn window_rows_in(&self, width: usize, height: usize, rows: Range<usize>) -> usize {
        let b = self.cell_bits;
        let cell = 1usize << b;
        let reach = self.colour_reach(width, height);
        let mut most = 0;
        let (mut top, mut bottom, mut row) = strip_rows();
        let last = rows.end.min(height);
        for j in rows.start >> b..last.div_ceil(cell).min(self.mesh_columns(height) - 1) {
            let mut bounds = [(i64::MAX, i64::MIN); MESH_CELL];
            for (first, n) in self.strips(width) {
                self.mesh_row(j, first, &mut top[..n]);
                self.mesh_row(j + 1, first, &mut bottom[..n]);
                for (fv, bound) in bounds[..cell].iter_mut().enumerate() {
                    interpolate_rows(b, &top[..n], &bottom[..n], fv, &mut row[..n]);
                    self.node_row_bounds(&row[..n], height, reach, bound);
                }
            }
            for (fv, &(lo, hi)) in bounds[..cell].iter().enumerate() {
                let v = (j << b) + fv;
                if lo <= hi && v >= rows.start && v < last {
                    most = most.max((hi - lo + 1) as usize);
                }
            }
        }
        most
    }

    /// The strips of a frame `width` wide: `(first node, elements of the strip's node rows)`,
    /// each at most [`STRIP_CELLS`] cells (its nodes overlap the next strip's by one).
    fn strips(&self, width: usize) -> impl Iterator<Item = (usize, usize)> {
        let cells = self.mesh_columns(width) - 1;
        (0..cells)
            .step_by(STRIP_CELLS)
            .map(move |first| (first, 2 * ((cells - first).min(STRIP_CELLS) + 1)))
    }

    /// [`LensDistortion::correct_row`] with each pixel's position from
    /// [`LensDistortion::mesh_position`] (its cell's nodes evaluated for it): the same output,
    /// for the reference engine, which keeps no node rows.
    pub(crate) fn correct_row_by_pixel<'r, T: Sample>(
        &self,
        v: usize,
        width: usize,
        height: usize,
        source: impl Fn(usize) -> &'r [T],
        out: &mut [T],
    ) {
        for (u, px) in out.chunks_exact_mut(3).enumerate().take(width) {
            if let Some(lca) = &self.lateral_colour {
                let read = |xi: usize, yi: usize, c: usize| source(yi)[3 * xi + c];
                let acc = Self::colour_pixel(lca, self.mesh_position(u, v), width, height, read);
                for c in 0..3 {
                    px[c] = T::scaled_down(acc[c], WEIGHT_BITS);
                }
                continue;
            }
            let mut acc = [T::Acc::default(); 3];
            for (xi, yi, weight) in self
                .mesh_position(u, v)
                .map_or([None; 4], |q| taps(q, width, height))
                .into_iter()
                .flatten()
            {
                let src = &source(yi)[3 * xi..3 * xi + 3];
                for c in 0..3 {
                    acc[c] = acc[c] + src[c].weighted(weight);
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
        let b = self.cell_bits;
        let (mut top, mut bottom, mut row) = strip_rows();
        for (first, n) in self.strips(w) {
            // The strip's columns: its cells, clipped to the frame.
            let u0 = (first << b).min(w);
            let u1 = ((first + n / 2 - 1) << b).min(w);
            for v in 0..h {
                if v == 0 || v & ((1 << b) - 1) == 0 {
                    self.mesh_row(v >> b, first, &mut top[..n]);
                    self.mesh_row((v >> b) + 1, first, &mut bottom[..n]);
                }
                interpolate_rows(b, &top[..n], &bottom[..n], v, &mut row[..n]);
                let out = &mut dst.row_mut(v)[3 * u0..3 * u1];
                for (k, px) in out.chunks_exact_mut(3).enumerate() {
                    let position = row_position(b, &row[2 * (k >> b)..n], k & ((1 << b) - 1));
                    if let Some(lca) = &self.lateral_colour {
                        // Rows of a checked view below its height always exist, and taps lie
                        // within the frame.
                        let read = |xi: usize, yi: usize, c: usize| {
                            let src = src.row(yi).unwrap_or(&[]);
                            src.get(3 * xi + c).copied().unwrap_or_default()
                        };
                        let acc = Self::colour_pixel(lca, position, w, h, read);
                        for c in 0..3 {
                            px[c] = T::scaled_down(acc[c], WEIGHT_BITS);
                        }
                        continue;
                    }
                    let mut acc = [T::Acc::default(); 3];
                    for (xi, yi, weight) in position
                        .map_or([None; 4], |q| taps(q, w, h))
                        .into_iter()
                        .flatten()
                    {
                        // Rows of a checked view below its height always exist, and taps lie
                        // within the frame.
                        let src = src.row(yi).unwrap_or(&[]);
                        for (c, acc) in acc.iter_mut().enumerate() {
                            let sample = src.get(3 * xi + c).copied().unwrap_or_default();
                            *acc = *acc + sample.weighted(weight);
                        }
                    }
                    for c in 0..3 {
                        px[c] = T::scaled_down(acc[c], WEIGHT_BITS);
                    }
                }
            }
        }
        Ok(())
    }
}

/// Three node rows of one strip on the stack: the rows above and below a cell row, and the
/// row interpolated between them.
fn strip_rows() -> (
    [i32; 2 * (STRIP_CELLS + 1)],
    [i32; 2 * (STRIP_CELLS + 1)],
    [i32; 2 * (STRIP_CELLS + 1)],
) {
    (
        [0; 2 * (STRIP_CELLS + 1)],
        [0; 2 * (STRIP_CELLS + 1)],
        [0; 2 * (STRIP_CELLS + 1)],
    )
}

/// `row[k] = (c - fv) top[k] + fv bottom[k]` for output row `v` (`c = 2^bits` the cell's side,
/// `fv = v mod c`): the mesh interpolated down to the row, in `1 / (256 c)` pixel (below
/// 2^30), [`NO_NODE`] where either node is.
pub(crate) fn interpolate_rows(bits: u32, top: &[i32], bottom: &[i32], v: usize, row: &mut [i32]) {
    let c = 1i32 << bits;
    let fv = (v & ((1 << bits) - 1)) as i32;
    for ((r, &a), &b) in row.iter_mut().zip(top).zip(bottom) {
        *r = if a == NO_NODE || b == NO_NODE {
            NO_NODE
        } else {
            // |a|, |b| < 2^26 and c <= 16, so this stays below 2^30.
            (c - fv) * a + fv * b
        };
    }
}

/// A position in `1 / (256 c^2)` pixel (`c = 2^bits`) rounded to 1/32 (half up).
#[inline(always)]
fn round_row(bits: u32, s: i64) -> i32 {
    let shift = 2 * bits + NODE_BITS - SUBPIXEL_BITS;
    ((s + (1 << (shift - 1))) >> shift) as i32
}

/// The position in 1/32 pixel of the pixel `fu` columns into the cell whose left node is the
/// first of `row` (interpolated nodes, two elements a node; cells of `2^bits`), or `None`
/// where one of the cell's nodes is unusable.
#[inline(always)]
pub(crate) fn row_position(bits: u32, row: &[i32], fu: usize) -> Option<[i32; 2]> {
    let [ax, ay, bx, by] = [*row.first()?, *row.get(1)?, *row.get(2)?, *row.get(3)?];
    if ax == NO_NODE || bx == NO_NODE {
        return None;
    }
    let (c, fu) = (1i64 << bits, fu as i64);
    let along = |a: i32, b: i32| round_row(bits, (c - fu) * i64::from(a) + fu * i64::from(b));
    Some([along(ax, bx), along(ay, by)])
}

/// The four taps of a source position `q` (1/32 pixel) in a `width` x `height` frame: column,
/// row and integer weight (the four sum to 1024), `None` for a tap off the frame (black). Both
/// columns off the frame read nothing.
#[inline(always)]
pub(crate) fn taps(q: [i32; 2], width: usize, height: usize) -> [Option<(usize, usize, i32)>; 4] {
    let [qx, qy] = q;
    let (x0, y0) = (qx >> SUBPIXEL_BITS, qy >> SUBPIXEL_BITS);
    let (ax, ay) = (qx & FRACTION_MASK, qy & FRACTION_MASK);
    let (w, h) = (width as i64, height as i64);
    let tap = |x: i32, y: i32, weight: i32| {
        let inside = x >= 0 && i64::from(x) < w && y >= 0 && i64::from(y) < h;
        inside.then_some((x as usize, y as usize, weight))
    };
    [
        tap(x0, y0, (SUBPIXELS - ax) * (SUBPIXELS - ay)),
        tap(x0 + 1, y0, ax * (SUBPIXELS - ay)),
        tap(x0, y0 + 1, (SUBPIXELS - ax) * ay),
        tap(x0 + 1, y0 + 1, ax * ay),
    ]
}
